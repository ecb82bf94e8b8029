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
from uavplan.app.vehicle_params import ParameterCheck, ParamPolicy, enforce_parameters
from uavplan.errors import InputError
from uavplan.mission.items import Autopilot, MissionPlan, MissionType

if TYPE_CHECKING:
    from uavplan.mavlink.link import VehicleLink
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
    ``verify``: read every plan type back and compare it item for item. The parameters the
    .plan says the mission relies on are read first (:mod:`uavplan.app.vehicle_params`):
    one the vehicle holds another value of refuses the upload (exit 4, nothing sent) unless
    ``set_params`` (set and read back) or ``accept_vehicle_params`` (the flight proven again
    in ``scenario`` with the vehicle's values). ``clear``: an empty mission is sent (it
    clears the vehicle's); without it an empty mission is refused. ``max_items``: the
    vehicle's storage, the mission's limit or (mission, fence, rally) items, checked before
    anything is sent (None: the flavour's defaults,
    :data:`~uavplan.mavlink.transfer.DEFAULT_STORAGE`)."""

    mission: str
    link: LinkOptions
    verify: bool = True
    set_params: bool = False
    accept_vehicle_params: bool = False
    scenario: str | None = None
    clear: bool = False
    max_items: tuple[int, ...] | None = None


@dataclass(frozen=True, eq=False)
class UploadOutcome:
    plan: MissionPlan
    report: PlanTransferReport
    vehicle: str
    #: what was found (and with ``--set-params`` done) about each relied-upon parameter
    parameters: ParameterCheck | None = None

    def summary(self) -> str:
        counts = self.report.item_counts
        home = self.report.autopilot is Autopilot.ARDUPILOT
        mission = counts[MissionType.MISSION] - (1 if home else 0)
        checked = "verified by read-back" if self.report.verified else "not verified"
        what = _counts(mission, counts.get(MissionType.FENCE), counts.get(MissionType.RALLY), home)
        return f"uploaded {what} to {self.vehicle}; {checked} ({self.report.elapsed_s:.2f} s)"

    def parameter_lines(self) -> list[str]:
        """``parameters (1 changed, read back): RTL_ALT 1500 → 23000, ...``; with
        ``--set-params`` on a mission that relies on none, that it relies on none."""
        check = self.parameters
        if check is None or (not check.results and check.policy is ParamPolicy.CHECK):
            return []
        return check.lines()


#: what ``upload`` and ``fly`` say to do about a parameter the vehicle holds another value of
UPLOAD_PARAMS_ADVICE = (
    "Nothing was sent. Set them with --set-params (each read back), or keep the vehicle's "
    "values once the flight is proven again with them: --accept-vehicle-params --scenario S"
)


def upload(request: UploadRequest, feedback: Feedback) -> UploadOutcome:
    """Read the mission file, check that it fits the wire and the vehicle's storage,
    connect, check (or set) the parameters it relies on and upload it."""
    from uavplan.mavlink.parameters import ParamTimeouts
    from uavplan.mavlink.transfer import (
        check_plan_fits_storage,
        check_plan_fits_wire,
        layout_autopilot,
        storage_limits,
        upload_plan,
    )
    from uavplan.mission.io import load_mission

    plan = load_mission(request.mission)
    check_plan_fits_wire(plan, file=request.mission)
    if not plan.items and not request.clear:
        raise InputError(
            "the mission has no items: uploading it would clear the vehicle's mission; give "
            "--clear to do that (or uavplan clear --type mission)",
            file=request.mission,
        )
    limits = storage_limits(plan.autopilot, request.max_items)
    check_plan_fits_storage(plan, plan.autopilot, limits, file=request.mission)
    if request.accept_vehicle_params and request.scenario is None:
        raise InputError(
            "--accept-vehicle-params proves the flight again with the vehicle's parameter "
            "values, in the scenario it was planned for: give --scenario"
        )
    policy = ParamPolicy.CHECK
    if request.set_params:
        policy = ParamPolicy.SET
    elif request.accept_vehicle_params:
        policy = ParamPolicy.ACCEPT
    with _connect(request.link) as link:
        # laid out for the vehicle's flavour (ArduPilot's home item takes a slot)
        flavour = layout_autopilot(link.vehicle.autopilot, plan.autopilot)
        if flavour is not plan.autopilot:
            limits = storage_limits(flavour, request.max_items)
            check_plan_fits_storage(plan, flavour, limits, file=request.mission)
        parameters = enforce_parameters(
            link,
            plan,
            policy,
            timeouts=ParamTimeouts(request.link.timeout_s, request.link.retries),
            advice=UPLOAD_PARAMS_ADVICE,
            step="check parameters",
            file=request.mission,
            scenario=request.scenario,
        )
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
