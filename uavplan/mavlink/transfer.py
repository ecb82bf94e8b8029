"""Whole-plan operations: upload a MissionPlan (mission, fence, rally) and read it back.

This is where the vehicle's flavour is applied to a plan (reference §4, §7.18-19, §7.24):

- the mission layout follows the vehicle's HEARTBEAT autopilot, not the file's: ArduPilot
  gets the home placeholder at seq 0 and DO_JUMP targets counted with it, PX4 neither
  (a vehicle reporting a generic autopilot gets the file's layout);
- params that are unset (NaN on the wire) become 0 for ArduPilot except where it accepts
  NaN (param4 yaw of WAYPOINT, LOITER_UNLIM, LAND, TAKEOFF, VTOL_TAKEOFF);
- frames the firmware rejects (terrain frames on PX4) are refused before anything is sent;
- items go in the form the firmware parses (:func:`uavplan.mavlink.stored_form.upload_form`: PX4
  takes commands without a position, such as NAV_RETURN_TO_LAUNCH and DO_LAND_START, only in
  MAV_FRAME_MISSION).

Order follows QGroundControl: mission, then fence, then rally (fence and rally only when
the plan has them); then, unless ``verify=False``, each is downloaded and compared item by
item with what the firmware keeps of it (:func:`compare_items`: the firmware's form of each
item, :func:`uavplan.mavlink.stored_form.stored_form`; synonymous frames, float32 params,
1e-7 deg, 1 cm). A difference names the item and field; it blames another ground station
only when the vehicle holds another mission (:class:`ReadBackDifference`). All
uploads come before all read-backs: PX4 refuses a new upload for 5 s when a download's
final ACK is lost, but happily starts another download.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

from uavplan.errors import InputError, LinkError
from uavplan.mavlink.messages import Capability, MissionResult
from uavplan.mavlink.protocol import (
    MissionClient,
    MissionTransferError,
    Operation,
    TransferOutcome,
    TransferStatus,
    describe_item,
    type_label,
    wire_range_problem,
)
from uavplan.mavlink.storage import (  # re-exported: the checks before an upload
    DEFAULT_STORAGE as DEFAULT_STORAGE,
)
from uavplan.mavlink.storage import StorageLimits as StorageLimits
from uavplan.mavlink.storage import check_plan_fits_storage as check_plan_fits_storage
from uavplan.mavlink.storage import check_storage as check_storage
from uavplan.mavlink.storage import storage_limits as storage_limits
from uavplan.mavlink.storage import storage_problem as storage_problem
from uavplan.mavlink.stored_form import stored_form, upload_form
from uavplan.mission.items import (
    Autopilot,
    GeoFence,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    MissionType,
    RallyPoint,
    canonical_frame,
    items_equal,
)

#: ``progress(phase, done, total)``, phase like ``"upload mission"``
PlanProgress = Callable[[str, int, int], None]

#: commands whose param4 (yaw) ArduPilot accepts as NaN (AP_Mission::sanity_check_params)
ARDUPILOT_NAN_PARAM4 = frozenset({16, 17, 21, 22, 84})
#: positional frames each firmware accepts in a mission (reference §4, §7.19)
SUPPORTED_FRAMES = {
    Autopilot.PX4: frozenset({0, 2, 3, 5, 6}),
    Autopilot.ARDUPILOT: frozenset({0, 2, 3, 5, 6, 10, 11}),
}
_CAPABILITY_OF = {
    MissionType.FENCE: Capability.MISSION_FENCE,
    MissionType.RALLY: Capability.MISSION_RALLY,
}


@dataclass(frozen=True)
class PlanTransferReport:
    """What an upload did: one outcome per transfer (uploads, then read-backs)."""

    outcomes: tuple[TransferOutcome, ...]
    autopilot: Autopilot  # the mission layout used
    item_counts: dict[MissionType, int]
    verified: bool
    elapsed_s: float
    notes: tuple[str, ...] = ()


# ---------------------------------------------------------------------------------------------
# Plan -> wire items for one vehicle


def layout_autopilot(vehicle_autopilot: Autopilot, plan_autopilot: Autopilot) -> Autopilot:
    """The layout to use: the vehicle's flavour, or the plan's when the vehicle is generic."""
    if vehicle_autopilot in (Autopilot.PX4, Autopilot.ARDUPILOT):
        return vehicle_autopilot
    return plan_autopilot


def retarget(plan: MissionPlan, autopilot: Autopilot) -> MissionPlan:
    """The same plan laid out for ``autopilot``: DO_JUMP targets shift with the home slot."""
    if plan.autopilot == autopilot:
        return plan
    old_slots = 1 if plan.autopilot == Autopilot.ARDUPILOT else 0
    new_slots = 1 if autopilot == Autopilot.ARDUPILOT else 0
    shift = new_slots - old_slots
    items = tuple(
        replace(item, param1=item.param1 + shift)
        if item.command == MavCmd.DO_JUMP and item.param1 is not None and shift
        else item
        for item in plan.items
    )
    return replace(plan, items=items, autopilot=autopilot)


def sanitise_item(item: MissionItem, autopilot: Autopilot) -> MissionItem:
    """ArduPilot: unset params become 0 except where it accepts NaN (MAVSDK checks the same)."""
    if autopilot != Autopilot.ARDUPILOT:
        return item
    params = list(item.params)
    for index, value in enumerate(params):
        if value is None and not (index == 3 and item.command in ARDUPILOT_NAN_PARAM4):
            params[index] = 0.0
    return replace(item, param1=params[0], param2=params[1], param3=params[2], param4=params[3])


def check_plan_fits_wire(plan: MissionPlan, *, file: str | None = None) -> None:
    """Raise :class:`InputError` (exit 2, naming ``file`` and the item) for a value no
    MISSION_ITEM_INT can carry; checked before connecting, so nothing is sent."""
    for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
        for seq, item in enumerate(plan.wire_items(mission_type)):
            problem = wire_range_problem(item)
            if problem is not None:
                raise InputError(
                    f"{type_label(mission_type)} item {seq} ({describe_item(item)}): {problem}",
                    file=file,
                )


def plan_wire_items(
    plan: MissionPlan, mission_type: MissionType, autopilot: Autopilot
) -> list[MissionItem]:
    """The items of one plan type as they go to a vehicle of flavour ``autopilot``.

    Raises :class:`InputError` for an item the firmware is known to reject (frame).
    """
    laid_out = retarget(plan, autopilot) if mission_type == MissionType.MISSION else plan
    items = [
        upload_form(sanitise_item(it, autopilot), autopilot)
        for it in laid_out.wire_items(mission_type)
    ]
    for seq, item in enumerate(items):
        problem = wire_range_problem(item)
        if problem is not None:
            raise InputError(
                f"{type_label(mission_type)} item {seq} ({describe_item(item)}): {problem}"
            )
    allowed = SUPPORTED_FRAMES.get(autopilot)
    if allowed is not None:
        for seq, item in enumerate(items):
            if item.frame not in allowed:
                raise InputError(
                    f"{type_label(mission_type)} item {seq} ({describe_item(item)}): "
                    f"{autopilot.label} does not accept frame {item.frame}",
                )
    return items


# ---------------------------------------------------------------------------------------------
# Read-back comparison


@dataclass(frozen=True)
class ReadBackDifference:
    """How a read-back differs from what was uploaded. ``text`` names the item and field;
    ``other_mission``: the vehicle holds a different mission (another item count, another
    command, or a position moved by more than a firmware rounds): evidence that something
    else changed it, where a param or a frame alone is the firmware keeping the item in a
    form uavplan did not expect."""

    text: str
    other_mission: bool


#: a position the firmware moved by more than this (m, about 1e-5 degrees) was not rounded
_MOVED_DEG = 1e-5


def _fmt(value: float | None) -> str:
    return "unset (NaN)" if value is None else f"{value:g}"


def _field_difference(sent: MissionItem, expected: MissionItem, got: MissionItem) -> str:
    """The first field of ``got`` that differs from ``expected`` (the firmware's form of
    ``sent``), with the value sent, the value expected when the firmware changes it, and
    the value held."""

    def say(name: str, a: object, e: object, g: object) -> str:
        kept = "" if a == e else f" (kept by the firmware as {e})"
        return f"{name}: uploaded {a}{kept}, the vehicle holds {g}"

    if canonical_frame(expected.frame) != canonical_frame(got.frame):
        return say("frame", sent.frame, expected.frame, got.frame)
    for name in ("param1", "param2", "param3", "param4"):
        if not items_equal(expected, replace(expected, **{name: getattr(got, name)})):
            return say(
                name,
                _fmt(getattr(sent, name)),
                _fmt(getattr(expected, name)),
                _fmt(getattr(got, name)),
            )
    if not items_equal(expected, replace(expected, x=got.x, y=got.y)):
        return say(
            "position",
            f"({sent.x:.7f}, {sent.y:.7f})",
            f"({expected.x:.7f}, {expected.y:.7f})",
            f"({got.x:.7f}, {got.y:.7f})",
        )
    return say("altitude", f"{sent.z:g} m", f"{expected.z:g} m", f"{got.z:g} m")


def read_back_difference(
    sent: Sequence[MissionItem],
    received: Sequence[MissionItem],
    mission_type: MissionType,
    autopilot: Autopilot,
) -> ReadBackDifference | None:
    """``None`` when the read-back holds what was sent, in the form the firmware keeps it
    (:func:`uavplan.mavlink.stored_form.stored_form`) or as it was sent (a vehicle or simulator
    that keeps every field, as MAVSDK's mission server does), else the first difference.

    Tolerances are those of :func:`~uavplan.mission.items.items_equal`. ArduPilot's mission
    seq 0 is the vehicle's home, which it overwrites, so it is not compared.
    """
    if len(sent) != len(received):
        return ReadBackDifference(
            f"the vehicle holds {len(received)} items, {len(sent)} were uploaded", True
        )
    ardupilot = autopilot == Autopilot.ARDUPILOT
    for seq, (a, b) in enumerate(zip(sent, received, strict=True)):
        if ardupilot and mission_type == MissionType.MISSION and seq == 0:
            continue
        expected = stored_form(a, autopilot, mission_type)
        if items_equal(expected, b) or items_equal(a, b):
            continue  # as the firmware keeps it, or (a vehicle that keeps it all) as sent
        where = f"item {seq} ({describe_item(a)})"
        if expected.command != b.command:
            return ReadBackDifference(
                f"{where}: the vehicle holds command {b.command} there instead", True
            )
        moved = (
            expected.is_global
            and b.is_global
            and max(abs(expected.x - b.x), abs(expected.y - b.y)) > _MOVED_DEG
        )
        return ReadBackDifference(f"{where}: {_field_difference(a, expected, b)}", moved)
    return None


def compare_items(
    sent: Sequence[MissionItem],
    received: Sequence[MissionItem],
    mission_type: MissionType,
    autopilot: Autopilot,
) -> str | None:
    """``None`` when the read-back matches what was sent, in the form the firmware keeps
    it, else the first difference (:func:`read_back_difference`)."""
    difference = read_back_difference(sent, received, mission_type, autopilot)
    return None if difference is None else difference.text


# ---------------------------------------------------------------------------------------------


def _check_capability(client: MissionClient, mission_type: MissionType) -> None:
    flag = _CAPABILITY_OF.get(mission_type)
    if flag is None:
        return
    caps = client.link.wait_capabilities(client.timeouts.ack_s)
    if caps is not None and not caps & flag:
        raise LinkError(
            f"the vehicle does not support {type_label(mission_type)} transfers "
            f"(AUTOPILOT_VERSION lacks MAV_PROTOCOL_CAPABILITY_{flag.name})",
            step=f"upload {type_label(mission_type)}: capabilities",
        )


_PLAN_NAMES = {MissionType.FENCE: "geofence", MissionType.RALLY: "rally points"}
_CLEAR_OPTION = {MissionType.FENCE: "fence", MissionType.RALLY: "rally"}


def _untouched_plan_notes(client: MissionClient, uploaded: Sequence[MissionType]) -> list[str]:
    """What stays on the vehicle of the plan types this upload did not send (a mission
    without a fence leaves the vehicle's old fence active): read its count, or say that it
    was not checked. Never fails the upload."""
    notes = []
    for mission_type in (MissionType.FENCE, MissionType.RALLY):
        if mission_type in uploaded:
            continue
        name = _PLAN_NAMES[mission_type]
        flag = _CAPABILITY_OF[mission_type]
        caps = client.link.capabilities
        if caps is not None and not caps & flag:
            continue  # the vehicle has no such plan type: nothing can be left over
        verb, pronoun = ("were", "them") if mission_type == MissionType.RALLY else ("was", "it")
        outcome: TransferOutcome | None = None
        try:
            outcome = client.download(mission_type)
            reason = outcome.message
        except LinkError as err:
            reason = str(err)
        if outcome is None or not outcome.ok:
            notes.append(
                f"the plan has no {name}; the vehicle's {name}, if any, {verb} left unchanged "
                f"(not checked: {reason})"
            )
        elif outcome.items:
            notes.append(
                f"the plan has no {name}; the vehicle's {name} ({len(outcome.items)} items) "
                f"{verb} left unchanged (uavplan clear --type {_CLEAR_OPTION[mission_type]} "
                f"removes {pronoun})"
            )
    return notes


def upload_plan(
    client: MissionClient,
    plan: MissionPlan,
    *,
    verify: bool = True,
    progress: PlanProgress | None = None,
) -> PlanTransferReport:
    """Upload ``plan`` (its fence and rally points too, when it has them), then verify.

    Raises :class:`MissionTransferError` (exit 4) naming the plan type and step that failed,
    or :class:`InputError` (exit 2) for items the vehicle's firmware cannot take.
    """
    started = time.monotonic()
    autopilot = layout_autopilot(client.link.vehicle.autopilot, plan.autopilot)
    notes: list[str] = []
    if plan.autopilot != autopilot and plan.autopilot != Autopilot.GENERIC:
        notes.append(
            f"the plan was made for {plan.autopilot.label}; laid out for the vehicle's "
            f"{autopilot.label} instead"
        )
    types = [MissionType.MISSION]
    if not plan.fence.is_empty:
        types.append(MissionType.FENCE)
    if plan.rally:
        types.append(MissionType.RALLY)
    wire = {t: plan_wire_items(plan, t, autopilot) for t in types}
    for mission_type in types:
        _check_capability(client, mission_type)

    outcomes: list[TransferOutcome] = []
    need_check: list[MissionType] = []
    for mission_type in types:
        label = f"upload {type_label(mission_type)}"
        outcome = client.upload(
            mission_type,
            wire[mission_type],
            progress=None if progress is None else _phase(progress, label),
        )
        outcomes.append(outcome)
        if outcome.status is TransferStatus.NO_FINAL_ACK:
            notes.append(f"{outcome.where}: {outcome.detail}; checked by reading back")
            need_check.append(mission_type)
        elif verify:
            outcome.raise_for_status()
            need_check.append(mission_type)
        else:
            outcome.raise_for_status()

    def read_back(mission_type: MissionType, label: str) -> TransferOutcome:
        outcome = client.download(
            mission_type, progress=None if progress is None else _phase(progress, label)
        )
        outcomes.append(replace(outcome, operation=Operation.VERIFY))
        return outcomes[-1]

    for mission_type in need_check:
        label = f"verify {type_label(mission_type)}"
        outcome = read_back(mission_type, label)
        if outcome.status is TransferStatus.BUSY:
            # Two refusals of the read-back's first request can both be stale: the vehicle's
            # "no transfer" answers to late duplicates of our own upload's items, on a link
            # that duplicates and reorders. Asked once more, a vehicle that took our plan
            # answers; one busy with another upload refuses (or stays silent) again.
            again = read_back(mission_type, label)
            if again.ok:
                outcome = again
        if outcome.status is TransferStatus.BUSY:
            # the vehicle took our plan whole, then started receiving someone else's
            raise MissionTransferError(
                replace(
                    outcome,
                    detail="another upload took over: the vehicle accepted our plan, then "
                    f"refused the read-back while busy with another transfer ({outcome.detail})",
                )
            )
        outcome.raise_for_status()
        difference = read_back_difference(
            wire[mission_type], outcome.items, mission_type, autopilot
        )
        if difference is not None:
            # blame another ground station only on evidence: the vehicle accepted our plan
            # and now holds another mission, not the same one with a field in another form
            took_over = outcomes[types.index(mission_type)].ok and difference.other_mission
            raise MissionTransferError(
                replace(
                    outcome,
                    status=TransferStatus.MISMATCH,
                    step="read-back",
                    detail=(
                        "another upload took over: the vehicle accepted our plan but now "
                        f"holds a different one (read-back differs: {difference.text})"
                        if took_over
                        else f"read-back differs: {difference.text}"
                    ),
                )
            )
    notes.extend(_untouched_plan_notes(client, types))
    return PlanTransferReport(
        outcomes=tuple(outcomes),
        autopilot=autopilot,
        item_counts={t: len(wire[t]) for t in types},
        verified=verify or bool(need_check),
        elapsed_s=time.monotonic() - started,
        notes=tuple(notes),
    )


def _phase(progress: PlanProgress, label: str) -> Callable[[int, int], None]:
    return lambda done, total: progress(label, done, total)


# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PlanDownload:
    plan: MissionPlan
    outcomes: tuple[TransferOutcome, ...]
    notes: tuple[str, ...] = ()


def download_plan(
    client: MissionClient,
    *,
    fence_and_rally: bool = True,
    progress: PlanProgress | None = None,
) -> PlanDownload:
    """Read the vehicle's mission (and, if it supports them, geofence and rally points).

    ArduPilot's seq 0 becomes the plan's home. A vehicle whose AUTOPILOT_VERSION lacks the
    fence / rally capability is not asked for them (as QGroundControl does).
    """
    autopilot = layout_autopilot(client.link.vehicle.autopilot, Autopilot.PX4)
    outcomes: list[TransferOutcome] = []
    notes: list[str] = []

    def fetch(mission_type: MissionType) -> TransferOutcome:
        label = f"download {type_label(mission_type)}"
        outcome = client.download(
            mission_type, progress=None if progress is None else _phase(progress, label)
        )
        outcomes.append(outcome)
        return outcome

    mission = fetch(MissionType.MISSION).raise_for_status()
    home, items = MissionPlan.split_wire_mission(mission.items, autopilot)
    fence = GeoFence()
    rally: list[RallyPoint] = []
    if fence_and_rally:
        caps = client.link.wait_capabilities(client.timeouts.ack_s)
        for mission_type in (MissionType.FENCE, MissionType.RALLY):
            if caps is not None and not caps & _CAPABILITY_OF[mission_type]:
                notes.append(f"the vehicle does not support {type_label(mission_type)}")
                continue
            outcome = fetch(mission_type)
            if outcome.status is TransferStatus.REJECTED and outcome.vehicle_result in (
                MissionResult.UNSUPPORTED,
                MissionResult.UNSUPPORTED_FRAME,
            ):
                notes.append(f"the vehicle refused the {type_label(mission_type)} download")
                continue
            outcome.raise_for_status()
            if mission_type == MissionType.FENCE:
                fence = _fence_from(outcome)
            else:
                rally, skipped = _rally_from(outcome.items)
                if skipped:
                    notes.append(f"{skipped} rally item(s) that are not rally points skipped")
    plan = MissionPlan(items=items, autopilot=autopilot, home=home, fence=fence, rally=tuple(rally))
    return PlanDownload(plan, tuple(outcomes), tuple(notes))


def _fence_from(outcome: TransferOutcome) -> GeoFence:
    try:
        return GeoFence.from_wire_items(outcome.items)
    except ValueError as err:
        raise MissionTransferError(
            replace(
                outcome,
                status=TransferStatus.PROTOCOL_ERROR,
                step="geofence",
                detail=f"the vehicle's geofence is not valid: {err}",
            )
        ) from None


def _rally_from(items: Sequence[MissionItem]) -> tuple[list[RallyPoint], int]:
    points: list[RallyPoint] = []
    skipped = 0
    for item in items:
        if item.command == MavCmd.NAV_RALLY_POINT and item.is_global and math.isfinite(item.z):
            points.append(RallyPoint(item.x, item.y, item.z))
        else:
            skipped += 1
    return points, skipped


def clear_plan(client: MissionClient, types: Sequence[MissionType]) -> list[TransferOutcome]:
    """Clear each plan type in turn (type ALL is not sent: ArduPilot does not support it).

    ArduPilot may refuse MISSION_CLEAR_ALL for the mission (for example while it flies it);
    then, as MAVSDK does, a mission holding only the home placeholder is uploaded instead.
    """
    outcomes: list[TransferOutcome] = []
    ardupilot = client.link.vehicle.autopilot == Autopilot.ARDUPILOT
    for mission_type in types:
        outcome = client.clear(mission_type)
        if (
            not outcome.ok
            and ardupilot
            and mission_type == MissionType.MISSION
            and outcome.status is TransferStatus.REJECTED
        ):
            home_only = MissionItem(
                command=MavCmd.NAV_WAYPOINT,
                frame=MavFrame.GLOBAL,
                param1=0.0,
                param2=0.0,
                param3=0.0,
                param4=0.0,
            )
            outcome = client.upload(MissionType.MISSION, [home_only])
        outcomes.append(outcome.raise_for_status())
    return outcomes
