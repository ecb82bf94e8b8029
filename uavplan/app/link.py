"""``upload``, ``download`` and ``clear``: missions to and from a vehicle over MAVLink.

Each use case connects (:class:`LinkOptions`), runs one transfer of
:mod:`uavplan.mavlink.transfer` and returns what it did. A file the user gave that cannot be
sent is an :class:`~uavplan.errors.InputError` (exit 2) before anything is connected; a
failure of the vehicle or the link is a :class:`~uavplan.errors.LinkError` (exit 4) naming the
step. ``download`` writes its file as an output set (:mod:`uavplan.app.outputs`): checked
before connecting, written whole once the transfer is done, nothing on an error or Ctrl-C.

Counting: the mission's items are counted the same way up and down, without the home that
ArduPilot keeps as mission item 0 (the summaries say when there is one). The MAVLink package
loads inside the functions, so ``uavplan --help`` stays fast.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from uavplan.app.feedback import Feedback
from uavplan.app.outputs import OutputSet
from uavplan.errors import InputError
from uavplan.mission.items import Autopilot, MissionPlan, MissionType

if TYPE_CHECKING:
    from uavplan.mavlink.link import VehicleLink
    from uavplan.mavlink.parameters import ParamResult
    from uavplan.mavlink.protocol import MissionClient
    from uavplan.mavlink.transfer import PlanTransferReport


@dataclass(frozen=True)
class LinkOptions:
    """How to reach the vehicle: the connection string and the protocol's timing."""

    conn: str
    timeout_s: float = 1.5
    retries: int = 5
    target_system: int | None = None
    heartbeat_timeout_s: float = 5.0
    source_system: int = 255
    source_component: int | None = None


def _connect(options: LinkOptions) -> VehicleLink:
    from uavplan.mavlink.link import VehicleLink

    return VehicleLink.connect(
        options.conn,
        target_system=options.target_system,
        heartbeat_timeout_s=options.heartbeat_timeout_s,
        system_id=options.source_system,
        component_id=options.source_component,
    )


def _client(link: VehicleLink, options: LinkOptions) -> MissionClient:
    from uavplan.mavlink.protocol import MissionClient, ProtocolTimeouts

    return MissionClient(link, ProtocolTimeouts.scaled(options.timeout_s, options.retries))


def _vehicle(link: VehicleLink) -> str:
    vehicle = link.vehicle
    return (
        f"system {vehicle.system_id} ({vehicle.autopilot.label}) on {link.connection.description}"
    )


def _progress(feedback: Feedback) -> Callable[[str, int, int], None] | None:
    """``progress(phase, done, total)`` over the feedback's bar: one bar per phase."""
    bar = feedback.progress
    if bar is None:
        return None
    return lambda phase, done, total: bar.show(done, total, label=phase)


def _counts(mission: int, fence: int | None, rally: int | None, home: bool) -> str:
    """``40 mission items, 9 fence items, 2 rally points (and home, ArduPilot's item 0)``."""
    parts = [f"{mission} mission items"]
    if fence is not None:
        parts.append(f"{fence} fence items")
    if rally is not None:
        parts.append(f"{rally} rally points")
    return ", ".join(parts) + (" (and home, ArduPilot's mission item 0)" if home else "")


# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class UploadRequest:
    """``uavplan upload MISSION``: the mission file (with a .plan's fence and rally points);
    ``verify``: read every plan type back and compare it item for item; ``set_params``:
    first make the vehicle hold the parameters the .plan says the mission relies on."""

    mission: str
    link: LinkOptions
    verify: bool = True
    set_params: bool = False


@dataclass(frozen=True, eq=False)
class UploadOutcome:
    plan: MissionPlan
    report: PlanTransferReport
    vehicle: str
    #: what ``--set-params`` did to each parameter (empty without it)
    parameters: tuple[ParamResult, ...] = ()

    def summary(self) -> str:
        counts = self.report.item_counts
        home = self.report.autopilot is Autopilot.ARDUPILOT
        mission = counts[MissionType.MISSION] - (1 if home else 0)
        checked = "verified by read-back" if self.report.verified else "not verified"
        what = _counts(mission, counts.get(MissionType.FENCE), counts.get(MissionType.RALLY), home)
        return f"uploaded {what} to {self.vehicle}; {checked} ({self.report.elapsed_s:.2f} s)"

    def parameter_summary(self) -> str | None:
        """``parameters: RTL_ALT 1500 → 4500, FENCE_ENABLE 1 (kept)`` (None without any)."""
        if not self.parameters:
            return None
        changed = sum(1 for r in self.parameters if r.old != r.new)
        return f"parameters ({changed} changed, read back): " + ", ".join(
            r.describe() for r in self.parameters
        )


def upload(request: UploadRequest, feedback: Feedback) -> UploadOutcome:
    """Read the mission file, check that it fits the wire, connect and upload it."""
    from uavplan.mavlink.transfer import check_plan_fits_wire, upload_plan
    from uavplan.mission.io import load_mission

    plan = load_mission(request.mission)
    check_plan_fits_wire(plan, file=request.mission)
    if request.set_params and not plan.parameters:
        # issue 37: the safest missions (a planned return, no fence) rely on no parameter;
        # --set-params then has nothing to set, says so and uploads (the params branch
        # owns this step: reconcile at integration)
        feedback.say(f"{request.mission}: --set-params: the mission relies on no parameter")
    with _connect(request.link) as link:
        setting = request.set_params and bool(plan.parameters)
        parameters = _set_parameters(link, plan, request) if setting else ()
        try:
            report = upload_plan(
                _client(link, request.link),
                plan,
                verify=request.verify,
                progress=_progress(feedback),
            )
        except InputError as err:
            if err.file is not None:
                raise
            raise InputError(err.reason, file=request.mission, key=err.key) from None
        finally:
            if feedback.progress is not None:
                feedback.progress.close()
        return UploadOutcome(plan, report, _vehicle(link), parameters)


def _set_parameters(
    link: VehicleLink, plan: MissionPlan, request: UploadRequest
) -> tuple[ParamResult, ...]:
    """Make the vehicle hold ``plan``'s parameters (read, set, read back), before the
    mission that relies on them goes up; a parameter it does not end up holding is a
    :class:`~uavplan.mavlink.parameters.ParameterError` (exit 4) naming it."""
    from uavplan.mavlink.parameters import (
        ParamClient,
        ParameterError,
        ParamRequest,
        ParamTimeouts,
    )

    vehicle = link.vehicle.autopilot
    if plan.autopilot not in (vehicle, Autopilot.GENERIC):
        raise InputError(
            f"--set-params: the parameters are {plan.autopilot.label}'s and the vehicle is "
            f"{vehicle.label}: plan the mission for it (plan --autopilot {vehicle.label})",
            file=request.mission,
        )
    client = ParamClient(link, ParamTimeouts(request.link.timeout_s, request.link.retries))
    results = client.apply(
        [ParamRequest(p.name, p.value, p.at_least, p.at_most) for p in plan.parameters]
    )
    if not all(r.ok for r in results):
        raise ParameterError(results)
    return tuple(results)


# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DownloadRequest:
    """``uavplan download -o OUTPUT``: a .plan gets the geofence and rally points too."""

    output: str
    link: LinkOptions


@dataclass(frozen=True, eq=False)
class DownloadOutcome:
    plan: MissionPlan
    output: str
    vehicle: str
    with_fence_and_rally: bool
    notes: tuple[str, ...] = ()

    def summary(self) -> str:
        plan = self.plan
        fence = len(plan.fence.wire_items()) if self.with_fence_and_rally else None
        rally = len(plan.rally) if self.with_fence_and_rally else None
        home = plan.autopilot is Autopilot.ARDUPILOT and plan.home is not None
        what = _counts(len(plan.items), fence, rally, home)
        return f"downloaded {what} from {self.vehicle} into {self.output}"


def download(request: DownloadRequest, feedback: Feedback) -> DownloadOutcome:
    """Connect, read the vehicle's mission (and fence and rally points for a .plan) and
    write the file (checked before connecting)."""
    from uavplan.mavlink.transfer import download_plan
    from uavplan.mission.io import format_for, mission_text

    format_for(request.output)  # an unknown extension: fail before connecting
    wants_plan = Path(request.output).suffix.lower() == ".plan"
    outputs = OutputSet(feedback.interrupts)
    output = outputs.file(request.output)
    outputs.check()
    with outputs, _connect(request.link) as link:
        try:
            result = download_plan(
                _client(link, request.link),
                fence_and_rally=wants_plan,
                progress=_progress(feedback),
            )
        finally:
            if feedback.progress is not None:
                feedback.progress.close()
        output.write_text(mission_text(result.plan, request.output))
        outputs.commit()
        vehicle = _vehicle(link)
    return DownloadOutcome(result.plan, request.output, vehicle, wants_plan, result.notes)


# ---------------------------------------------------------------------------------------------

#: what ``clear --type`` takes, and the plan types each clears
CLEAR_TYPES: dict[str, tuple[MissionType, ...]] = {
    "mission": (MissionType.MISSION,),
    "fence": (MissionType.FENCE,),
    "rally": (MissionType.RALLY,),
    "all": (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY),
}


@dataclass(frozen=True)
class ClearRequest:
    """``uavplan clear --type TYPE``: one of :data:`CLEAR_TYPES`."""

    plan_type: str
    link: LinkOptions


@dataclass(frozen=True)
class ClearOutcome:
    types: tuple[MissionType, ...]
    vehicle: str

    def summary(self) -> str:
        return f"cleared {', '.join(t.name.lower() for t in self.types)} on {self.vehicle}"


def clear(request: ClearRequest, feedback: Feedback) -> ClearOutcome:
    """Connect and clear the plan types of ``request.plan_type``, one after another."""
    from uavplan.mavlink.transfer import clear_plan

    types = CLEAR_TYPES.get(request.plan_type)
    if types is None:
        choices = ", ".join(CLEAR_TYPES)
        raise InputError(f"expected one of {choices}, got {request.plan_type!r}", key="--type")
    with _connect(request.link) as link:
        clear_plan(_client(link, request.link), types)
        return ClearOutcome(types, _vehicle(link))
