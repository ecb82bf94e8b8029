"""``convert``: a mission file into another mission format or a map export."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from uavplan.app.feedback import Feedback
from uavplan.app.outputs import OutputSet
from uavplan.errors import InputError
from uavplan.mission.io import format_for, load_mission, mission_text
from uavplan.mission.items import Autopilot, GeoFence, MissionPlan

if TYPE_CHECKING:
    from uavplan.mission.export import ExportExtras


@dataclass(frozen=True)
class ConvertRequest:
    """Mission file ``source`` (.plan, .waypoints) → ``output`` (.plan, .waypoints,
    .geojson, .kml); ``scenario`` adds its obstacles to a map export and, over terrain,
    places the route as the autopilot flies it there (altitudes AMSL); ``autopilot`` reads
    the source as that autopilot's mission."""

    source: str
    output: str
    scenario: str | None = None
    autopilot: str | None = None


@dataclass(frozen=True, eq=False)
class ConvertOutcome:
    plan: MissionPlan
    output: str
    format_name: str
    source: str
    notes: tuple[str, ...] = ()

    def summary(self) -> str:
        return (
            f"{Path(self.output).name}: {len(self.plan.items)} mission items from "
            f"{Path(self.source).name} ({self.format_name})"
        )


def convert(request: ConvertRequest, feedback: Feedback | None = None) -> ConvertOutcome:
    """Read, convert and write; what a format cannot hold is left out with a note. The
    output is checked before anything is read, and written whole or not at all."""
    out_format = format_for(request.output)  # an unknown extension fails before reading
    outputs = OutputSet(None if feedback is None else feedback.interrupts)
    outputs.reads(request.source, role="the mission to convert")
    outputs.reads(request.scenario, role="the scenario of --scenario")
    output = outputs.file(request.output)
    outputs.check()
    autopilot = Autopilot.from_name(request.autopilot) if request.autopilot else None
    plan = load_mission(request.source, autopilot)
    notes = []
    suffix = Path(request.output).suffix.lower()
    if out_format.dumps_extras is None and out_format.loads is not None:
        if suffix != ".plan" and (not plan.fence.is_empty or plan.rally):
            notes.append(
                f"{Path(request.output).suffix} holds no geofence or rally points; left out"
            )
            plan = replace(plan, fence=GeoFence(), rally=())
    if suffix != ".plan" and plan.parameters:
        names = ", ".join(p.name for p in plan.parameters)
        notes.append(
            f"{Path(request.output).suffix} holds no vehicle parameters ({names}); left out"
        )
        plan = replace(plan, parameters=())
    extras = None
    if request.scenario is not None:
        if out_format.dumps_extras is None:
            raise InputError("--scenario only adds obstacles to a .geojson or .kml")
        # the scenario's obstacles, in its site's frame: numpy and pyproj load for them
        from uavplan.app.reports import export_extras
        from uavplan.scenario import load_site

        scenario = load_site(request.scenario)
        outputs.reads(*scenario.files)
        try:
            extras = export_extras(scenario, plan=plan)
        except ValueError as err:  # an item's altitude cannot be placed
            raise InputError(str(err), file=request.source) from None
        from uavplan.scenario.values import is_survey_file

        if is_survey_file(request.scenario):
            extras = _with_survey(extras, request.scenario, plan)
    elif out_format.dumps_extras is not None and _terrain_frame_items(plan):
        notes.append(
            "terrain-frame altitudes are heights above the terrain: without --scenario (and "
            "its DEM) the export places them above home as if the ground were flat"
        )
    with outputs:
        output.write_text(mission_text(plan, request.output, extras=extras))
        outputs.commit()
    return ConvertOutcome(plan, request.output, out_format.name, request.source, tuple(notes))


def _with_survey(extras: ExportExtras, source: str, plan: MissionPlan) -> ExportExtras:
    """``extras`` with the survey of the scenario ``source``: its area, the photos ``plan``'s
    camera items ask for and, with a camera, their footprints."""
    import numpy as np

    from uavplan.mission.camera import mission_photos
    from uavplan.scenario.values import load_survey_scenario
    from uavplan.survey import coverage

    _, spec = load_survey_scenario(source)
    assert extras.frame is not None
    photos = mission_photos(plan, extras.frame)
    footprints = None
    side, front = spec.spacing.footprint_side_m, spec.spacing.footprint_front_m
    if side is not None and front is not None and len(photos):
        heading = coverage.photo_headings(photos, spec.spacing.trigger_distance_m)
        footprints = coverage.footprints(photos, heading, side, front)
    return replace(
        extras,
        survey_area_enu=np.asarray(spec.area_m, dtype=np.float64),
        photos_enu=photos,
        photo_footprints_enu=footprints,
    )


def _terrain_frame_items(plan: MissionPlan) -> bool:
    from uavplan.mission.items import MavFrame, canonical_frame

    return any(canonical_frame(i.frame) == MavFrame.GLOBAL_TERRAIN_ALT for i in plan.items)
