"""The vehicle parameters a mission relies on, enforced before it flies (issue 37, item 3).

A ``.plan`` written by ``uavplan plan`` lists the parameters its proof assumed
(:attr:`~uavplan.mission.items.MissionPlan.parameters`: the RTL altitude, the RTL type, the
fence's switches and ceiling, and whatever else the plan lists; this module enforces the
list, it does not decide it). :func:`enforce_parameters` is the one step ``upload`` and
``fly`` run on the connected vehicle before they send or start anything:

- read each parameter (PARAM_REQUEST_READ, retried, :mod:`uavplan.mavlink.parameters`);
- every value accepted: go on;
- :attr:`ParamPolicy.SET` (``--set-params``): set each one that differs and read it back
  (PARAM_SET / PARAM_VALUE); one the vehicle refuses or never answers is exit 4;
- :attr:`ParamPolicy.ACCEPT` (``--accept-vehicle-params``): keep the vehicle's values, read
  the rest of the flight model's parameters too, and prove the flight again with them
  (:func:`reprove_with_vehicle_parameters`, which needs the scenario); the flight must still
  keep the margin, else exit 4 naming what breaks it;
- :attr:`ParamPolicy.CHECK` (neither): a value that differs is exit 4
  (:class:`ParametersDiffer`), naming the parameter, the vehicle's value and the value or
  range the mission needs, before anything on the vehicle changed.

A parameter no PARAM_VALUE answers (the vehicle does not know the name, or the link lost
every reply) cannot be checked: exit 4 in every policy.
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from uavplan.errors import InputError, LinkError
from uavplan.flavour import Autopilot
from uavplan.mission.items import MissionPlan

if TYPE_CHECKING:
    from uavplan.autopilot.params import Parameters
    from uavplan.mavlink.link import VehicleLink
    from uavplan.mavlink.parameters import ParamClient, ParamRequest, ParamResult, ParamTimeouts
    from uavplan.scenario import Scenario

# the MAVLink package loads inside the functions, so ``uavplan --help`` stays fast


class ParamPolicy(enum.Enum):
    """What to do about a relied-upon parameter the vehicle holds another value of."""

    CHECK = "check"  # refuse (exit 4)
    SET = "set"  # --set-params: set it, read it back
    ACCEPT = "accept"  # --accept-vehicle-params: keep it, prove the flight again with it


class ParametersDiffer(LinkError):
    """The vehicle holds values of relied-upon parameters the mission does not accept
    (exit 4): ``results`` names each; nothing was changed on the vehicle."""

    def __init__(self, results: Sequence[ParamResult], advice: str, step: str) -> None:
        self.results = tuple(results)
        wrong = [r for r in self.results if not r.ok]
        super().__init__(
            "the vehicle does not hold the parameters the mission relies on: "
            + "; ".join(r.describe() for r in wrong)
            + f". {advice}",
            step=step,
        )


class ReproofFailed(LinkError):
    """``--accept-vehicle-params``: the flight proven again with the vehicle's values does
    not keep the margin (exit 4, nothing moved)."""


@dataclass(frozen=True)
class ParameterCheck:
    """What :func:`enforce_parameters` found and did: one result per relied-upon
    parameter; ``accepted``: the values that differ and were kept (``--accept-vehicle-params``,
    the flight re-proven with them)."""

    results: tuple[ParamResult, ...]
    policy: ParamPolicy
    accepted: tuple[ParamResult, ...] = ()

    def lines(self) -> list[str]:
        """What to print: nothing to check, what was kept and set, what was accepted."""
        from uavplan.mavlink.parameters import ParamStatus

        if not self.results:
            return ["parameters: the mission relies on no vehicle parameter (nothing to check)"]
        changed = sum(1 for r in self.results if r.status is ParamStatus.CHANGED)
        verb = f"{changed} changed, read back" if self.policy is ParamPolicy.SET else "read"
        out = [f"parameters ({verb}): " + ", ".join(_phrase(r) for r in self.results)]
        if self.accepted:
            out.append(
                "warning: --accept-vehicle-params: flying with the vehicle's "
                + ", ".join(f"{r.name} {_num(r.old)}" for r in self.accepted)
                + " instead of the planned "
                + ", ".join(f"{r.name} {r.needed}" for r in self.accepted)
                + "; the flight proven again with them keeps the margin"
            )
        return out


def _phrase(result: ParamResult) -> str:
    from uavplan.mavlink.parameters import ParamStatus

    if result.status is ParamStatus.DIFFERS:
        return f"{result.name} {_num(result.old)} (the plan needs {result.needed})"
    return result.describe()


def _num(value: float | None) -> str:
    return "?" if value is None else f"{value:g}"


def requests_of(plan: MissionPlan) -> list[ParamRequest]:
    """The plan's relied-upon parameters as the parameter protocol's requests."""
    from uavplan.mavlink.parameters import ParamRequest

    return [ParamRequest(p.name, p.value, p.at_least, p.at_most) for p in plan.parameters]


def enforce_parameters(
    link: VehicleLink,
    plan: MissionPlan,
    policy: ParamPolicy,
    *,
    timeouts: ParamTimeouts,
    advice: str,
    step: str,
    file: str | None = None,
    scenario: Scenario | str | None = None,
) -> ParameterCheck:
    """Make sure the vehicle on ``link`` holds what ``plan`` relies on, as ``policy`` says
    (the module doc); ``advice`` ends the refusal's message (how to fix it, in the command's
    own options), ``step`` names the step in it. Raises :class:`ParametersDiffer`,
    :class:`ReproofFailed`, :class:`~uavplan.mavlink.parameters.ParameterError` (exit 4) or
    :class:`~uavplan.errors.InputError` (exit 2: the parameters are another firmware's, or
    ``--accept-vehicle-params`` without a scenario to prove the flight in). ``scenario``
    (or its file, read only when the flight must be proven again): where the mission was
    planned."""
    from uavplan.mavlink.parameters import ParamClient, ParameterError, ParamStatus

    if not plan.parameters:
        return ParameterCheck((), policy)
    vehicle = link.vehicle.autopilot
    if plan.autopilot not in (vehicle, Autopilot.GENERIC):
        raise InputError(
            f"the parameters the mission relies on are {plan.autopilot.label}'s and the vehicle "
            f"is {vehicle.label}: plan the mission for it (plan --autopilot {vehicle.label})",
            file=file,
        )
    if policy is ParamPolicy.ACCEPT and scenario is None:
        raise InputError(
            "--accept-vehicle-params proves the flight again with the vehicle's parameter "
            "values, in the scenario it was planned for: give --scenario"
        )
    client = ParamClient(link, timeouts)
    requests = requests_of(plan)
    if policy is ParamPolicy.SET:
        results = client.apply(requests)
        if not all(r.ok for r in results):
            raise ParameterError(results)
        return ParameterCheck(tuple(results), policy)
    results = client.read(requests)
    unanswered = [r for r in results if r.status is ParamStatus.UNANSWERED]
    if unanswered:
        raise ParameterError(results)
    differing = tuple(r for r in results if r.status is ParamStatus.DIFFERS)
    if not differing:
        return ParameterCheck(tuple(results), policy)
    if policy is ParamPolicy.CHECK:
        raise ParametersDiffer(results, advice, step)
    assert scenario is not None
    if isinstance(scenario, str):
        from uavplan.scenario import load_site

        scenario = load_site(scenario)
    autopilot = vehicle if vehicle in (Autopilot.PX4, Autopilot.ARDUPILOT) else plan.autopilot
    values = vehicle_values(client, autopilot, results)
    problems = reprove_with_vehicle_parameters(plan, scenario, autopilot, values)
    if problems:
        held = ", ".join(f"{r.name} {_num(r.old)}" for r in differing)
        raise ReproofFailed(
            f"--accept-vehicle-params: with the vehicle's {held} the flight does not keep the "
            f"margin: {'; '.join(problems)}. Nothing was changed; set the planned values with "
            "--set-params instead",
            step=step,
        )
    return ParameterCheck(tuple(results), policy, differing)


def vehicle_values(
    client: ParamClient, autopilot: Autopilot, relied: Sequence[ParamResult]
) -> Parameters:
    """Every parameter of the flight model's table for ``autopilot`` as the vehicle holds it
    (read; one it does not answer keeps the table's default), the relied-upon ones as
    ``relied`` read them: the values the flight is proven again with."""
    from uavplan.autopilot.params import Parameters, param_table
    from uavplan.mavlink.parameters import ParamRequest

    known = {r.name: r.old for r in relied if r.old is not None}
    rest = [
        ParamRequest(spec.name, spec.default)
        for spec in param_table(autopilot)
        if spec.name not in known
    ]
    for result in client.read(rest):
        if result.old is not None:
            known[result.name] = result.old
    table = {spec.name for spec in param_table(autopilot)}
    return Parameters(autopilot, {k: v for k, v in known.items() if k in table}, ranged=False)


def reprove_with_vehicle_parameters(
    plan: MissionPlan, scenario: Scenario, autopilot: Autopilot, params: Parameters
) -> list[str]:
    """The flight of ``plan`` in ``scenario`` proven again with the vehicle's parameter
    values ``params``: what breaks the margin (empty: it holds).

    The one whole-flight verdict (:func:`uavplan.verdict.judge_flight`) with ``params`` as
    the whole set the vehicle holds: the flight from take-off to touchdown (its return to
    launch at the vehicle's RTL altitude included) must keep the margin; and where the
    mission's own parameters make every failsafe return safe, the vehicle's must too (a
    failsafe that was already unsafe as planned is the plan's warning, not the vehicle's
    doing)."""
    from uavplan.rehearsal import CheckSite, conditions_of
    from uavplan.verdict import judge_flight

    site = CheckSite.of_scenario(scenario)
    conditions = conditions_of(scenario)
    verdict = judge_flight(plan, site, autopilot=autopilot, params=params, **conditions)
    problems: list[str] = []
    problem = verdict.problem()
    if problem is not None:
        problems.append(problem)
    if not verdict.failsafe_ok:
        planned = judge_flight(plan, site, autopilot=autopilot, **conditions)
        if planned.failsafe_ok:
            assert verdict.failsafe is not None
            problems.append(
                "with the vehicle's values a failsafe return no longer keeps the margin "
                f"(it does with the mission's): {verdict.failsafe.summary()}"
            )
    return problems
