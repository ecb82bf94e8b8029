"""``view``: one interactive page (HTML, offline) of a mission in its scenario, or of a
scenario alone.

The page shows what the project's checks found, never measured another way: the mission
check (:func:`uavplan.app.check.mission_flight`, :func:`~uavplan.app.check.check_flight_in`)
for the planned legs, the flight model (:func:`uavplan.view.build.fly_mission`, through
:func:`uavplan.rehearsal.rehearse`) or a flown track (``--track``) for the flight as flown,
the autopilot's return as the flight model flies it and the proof of
:func:`uavplan.wayhome.prove_rtl` for the way home. ``plan --view`` and ``simulate --view``
write the same page through :func:`mission_page`.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uavplan.app.check import check_flight_in, mission_flight
from uavplan.app.feedback import Feedback
from uavplan.app.inputs import load_scenario_file, mission_kind, sniff_mission_kind
from uavplan.app.outputs import OutputSet
from uavplan.errors import InputError, NoPathError
from uavplan.flavour import Autopilot
from uavplan.scenario import Scenario

if TYPE_CHECKING:
    from uavplan.flightcheck import Flight
    from uavplan.mission.items import MissionPlan
    from uavplan.view.build import Flown

#: the autopilots the flight model flies
FLOWN_AUTOPILOTS = (Autopilot.PX4, Autopilot.ARDUPILOT)
#: what a page is named
PAGE_SUFFIXES = (".html", ".htm")


@dataclass(frozen=True)
class ViewRequest:
    """``uavplan view SOURCE -o OUTPUT``: SOURCE a mission file (with ``scenario``, the
    scenario it flies in) or a scenario; ``track`` a flown track to show instead of the
    flight model's."""

    source: str
    output: str
    scenario: str | None = None
    track: str | None = None


@dataclass(frozen=True)
class ViewOutcome:
    """The page written, and what it shows."""

    output: str
    size_bytes: int
    elapsed_s: float
    waypoints: int | None = None
    red_legs: tuple[int, ...] = ()
    problems: tuple[str, ...] = ()

    def summary(self) -> str:
        text = f"{Path(self.output).name}: {self.size_bytes / 1e6:.1f} MB"
        if self.waypoints is not None:
            red = (
                "no leg under the margin"
                if not self.red_legs
                else f"{len(self.red_legs)} leg(s) under the margin: "
                + ", ".join(str(k) for k in self.red_legs)
            )
            text += f", {self.waypoints} waypoints, {red}"
        return text + f" (made in {self.elapsed_s:.2f} s)"


def check_page_path(path: str) -> None:
    """Refuse a page name that is not ``*.html`` (exit 2)."""
    if Path(path).suffix.lower() not in PAGE_SUFFIXES:
        raise InputError("the view is an HTML page; name the file *.html", file=path)


def view(request: ViewRequest, feedback: Feedback) -> ViewOutcome:
    """Write the page ``request`` asks for (one output: complete, or not at all). A mission
    that breaks the margin anywhere (planned, as flown, on the way home) raises NoPathError
    (exit 3) once the page that shows where is written."""
    from uavplan.view.page import page_html, plotly_script

    t0 = time.perf_counter()
    check_page_path(request.output)
    _not_an_input(request.output, request.source, request.scenario, request.track)
    outputs = OutputSet(feedback.interrupts)
    page = outputs.file(request.output)
    outputs.check()
    script = plotly_script()  # the optional extra, before any long work
    kind = mission_kind(request.source) or sniff_mission_kind(request.source)
    with outputs:
        if kind in ("plan", "waypoints"):
            if request.scenario is None:
                raise InputError(
                    "a mission is shown in the scenario it flies in: give --scenario S",
                    file=request.source,
                )
            scn = load_scenario_file(request.scenario, "view")
            from uavplan.mission.io import load_mission

            plan = load_mission(request.source)
            document = mission_document_for(
                scn, plan, source=request.source, track=request.track, feedback=feedback
            )
        else:
            if request.scenario is not None:
                raise InputError(
                    "--scenario goes with a mission file (SOURCE is a scenario already)"
                )
            if request.track is not None:
                raise InputError("--track goes with a mission file (and --scenario)")
            scn = load_scenario_file(request.source, "view")
            from uavplan.view.build import scenario_document

            document = scenario_document(scn, title=scn.name, source=request.source)
        text = page_html(document, plotly=script)
        page.write_text(text)
        outputs.commit()
    mission = document.get("mission")
    problems = tuple(document["verdict"]["problems"])
    if problems:  # the page is written (it shows where); the verdict is exit 3
        more = "" if len(problems) == 1 else f" (and {len(problems) - 1} more on the page)"
        raise NoPathError(f"{request.output} written; {problems[0]}{more}")
    return ViewOutcome(
        request.output,
        len(text.encode("utf-8")),
        time.perf_counter() - t0,
        None if mission is None else len(mission["legs"]),
        () if mission is None else tuple(mission["red_legs"]),
        problems,
    )


def _not_an_input(output: str, *inputs: str | None) -> None:
    """Outputs never overwrite inputs."""
    for name in inputs:
        if name is None:
            continue
        try:
            same = os.path.samefile(output, name)
        except OSError:
            same = False
        if same:
            raise InputError(f"the page would overwrite the input {name}", file=output)


def mission_document_for(
    scenario: Scenario,
    plan: MissionPlan,
    *,
    source: str,
    track: str | None = None,
    flown: Flown | None = None,
    feedback: Feedback | None = None,
) -> dict[str, Any]:
    """The page's document of ``plan`` in ``scenario``: the mission check, the flight as
    flown (``flown``; else the track file ``track``; else the flight model's) and the way
    home."""
    from uavplan.autopilot.simulate import refusal_of
    from uavplan.rehearsal import CheckSite
    from uavplan.view.build import flown_of_track, fly_mission, mission_document

    flight = mission_flight(plan, scenario, file=source)
    if len(flight.points_enu) < 2:
        raise InputError("the mission has fewer than two positions to fly", file=source)
    check = check_flight_in(scenario, flight)
    site = CheckSite.of_scenario(scenario)
    notes: list[str] = []
    if flown is None and track is not None:
        from uavplan.mission.track import Track

        flown = flown_of_track(Track.load(track), plan, site, f"track {Path(track).name}")
    elif flown is None and plan.home is not None and plan.autopilot in FLOWN_AUTOPILOTS:
        refusal = refusal_of(plan)
        if refusal is not None:
            notes.append(f"not flown through the flight model: {refusal.text()}")
        else:
            try:
                flown = fly_mission(scenario, plan, site)
            except ValueError as err:  # a parameter the plan carries that the model refuses
                notes.append(f"not flown through the flight model: {err}")
    if flown is not None and feedback is not None:
        feedback.say(f"the flight as flown: {flown.label}")
    return mission_document(
        scenario,
        plan,
        flight,
        check,
        world=site.world,
        flown=flown,
        title=f"{Path(source).name} in {scenario.name}",
        source=source,
        notes=notes,
        way_home=way_home_lines(scenario, plan, flight),
    )


def mission_page(
    scenario: Scenario, plan: MissionPlan, *, source: str, flown: Flown | None = None
) -> str:
    """The page of ``plan`` in ``scenario`` (``plan --view``, ``simulate --view``)."""
    from uavplan.view.page import page_html

    return page_html(mission_document_for(scenario, plan, source=source, flown=flown))


def way_home_lines(scenario: Scenario, plan: MissionPlan, flight: Flight) -> list[tuple[str, str]]:
    """What the page says about the whole flight and the way home, each line with its level
    (``ok``, ``problem``: the flight breaks the margin, exit 3; ``warning``: a failsafe
    return would): the one whole-flight verdict (:func:`uavplan.verdict.judge_flight`, the
    mission flown with the parameters it relies on, take-off to touchdown, and a failsafe
    return from every point), worded as every other command words it."""
    from uavplan.autopilot.simulate import refusal_of
    from uavplan.mission.items import MavCmd
    from uavplan.rehearsal import CheckSite, conditions_of
    from uavplan.verdict import judge_flight

    if plan.home is None or plan.autopilot not in FLOWN_AUTOPILOTS or len(flight.points_enu) < 2:
        return []
    lines: list[tuple[str, str]] = []
    if any(item.command == MavCmd.DO_LAND_START for item in plan.items):
        lines.append(("ok", "way home: the mission ends with a planned return (after "
                      "DO_LAND_START), drawn as its last legs"))  # fmt: skip
    refusal = refusal_of(plan)
    if refusal is not None:  # the vehicle would refuse it: no flight
        why = refusal.text()
        return [*lines, ("problem", f"whole flight: not flown through the flight model: {why}")]
    try:
        verdict = judge_flight(plan, CheckSite.of_scenario(scenario), **conditions_of(scenario))
    except ValueError as err:  # a parameter the plan carries that the model refuses
        return [*lines, ("problem", f"whole flight: not flown through the flight model: {err}")]
    lines.append(("ok" if verdict.flight_ok else "problem", verdict.summary()))
    lines.extend(("warning", line) for line in verdict.warnings())
    return lines
