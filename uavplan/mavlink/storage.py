"""The vehicle's mission storage: how many items each firmware holds, checked before a mission
file is written (``plan``) and before an upload connects (issue 37, item 6).

No I/O and no pymavlink here: ``plan`` checks its mission without loading the MAVLink
machinery. The numbers and their sources: :data:`DEFAULT_STORAGE`, docs/flying.md ("Before
you fly").
"""

from __future__ import annotations

from dataclasses import dataclass

from uavplan.errors import InputError
from uavplan.mission.items import Autopilot, MissionPlan, MissionType

__all__ = [
    "DEFAULT_STORAGE",
    "MAX_WIRE_COUNT",
    "StorageLimits",
    "check_plan_fits_storage",
    "check_storage",
    "storage_limits",
    "storage_problem",
]

_LABEL = {MissionType.MISSION: "mission", MissionType.FENCE: "fence", MissionType.RALLY: "rally"}


@dataclass(frozen=True)
class StorageLimits:
    """The most items a vehicle stores of each plan type, as they go on the wire: mission
    items (ArduPilot's home, seq 0, counts: it takes a slot), fence items (one per polygon
    vertex, one per circle), rally points. ``source`` says where the numbers come from."""

    mission: int
    fence: int
    rally: int
    source: str = "given"

    def __post_init__(self) -> None:
        for name in ("mission", "fence", "rally"):
            value = getattr(self, name)
            if not (isinstance(value, int) and 0 <= value <= MAX_WIRE_COUNT):
                raise ValueError(f"{name} item limit must be 0..{MAX_WIRE_COUNT}, got {value!r}")

    def of(self, mission_type: MissionType) -> int:
        return {
            MissionType.MISSION: self.mission,
            MissionType.FENCE: self.fence,
            MissionType.RALLY: self.rally,
        }[mission_type]


#: MISSION_COUNT's count is a uint16, and 65535 is no count a vehicle accepts
MAX_WIRE_COUNT = 65534

#: what each firmware stores by default (docs/flying.md, "Before you fly"):
#:
#: - PX4 v1.14-v1.16: mission items CONFIG_NUM_MISSION_ITEMS_SUPPORTED, 500 unless the board
#:   configures more (src/modules/dataman/Kconfig; PX4 v1.16 SITL, px4_sitl_default, holds
#:   10,000: measured); fence DM_KEY_FENCE_POINTS_MAX 64 and rally DM_KEY_SAFE_POINTS_MAX, of
#:   which v1.14 keeps the first slot for its statistics (63 and 7 usable,
#:   src/modules/mavlink/mavlink_mission.h MAX_COUNT) and v1.15 on, with the statistics in a
#:   key of their own, all (64 fence items and 32 rally points: PX4 v1.16 SITL answers
#:   MISSION_COUNT 65 and 33 with NO_SPACE, 64 and 32 with a request). The defaults are
#:   v1.14's, the smallest of the three.
#: - ArduPilot Copter: commands of 15 bytes in the StorageMission areas of
#:   libraries/StorageManager/StorageManager.cpp (layout_copter), less 4 bytes of header
#:   (AP_Mission::num_commands_max): on a board with 16 KiB of storage 2422 + 2132 + 5204
#:   bytes, 650 items (home included); fence points 70 and rally points 46 in the same
#:   layout. ArduPilot Copter SITL (4.7.0-dev) answers exactly 650, 70 and 46 (measured:
#:   NO_SPACE one above each). Boards with more storage, or missions on the SD card, hold
#:   more; in older releases (Copter 3.x) the third area was 6228 bytes: 718 items.
DEFAULT_STORAGE: dict[Autopilot, StorageLimits] = {
    Autopilot.PX4: StorageLimits(
        500, 63, 7, "PX4 v1.14-v1.16 defaults: dataman's NUM_MISSION_ITEMS_SUPPORTED 500"
    ),
    Autopilot.ARDUPILOT: StorageLimits(
        650, 70, 46, "ArduPilot Copter on a board with 16 KiB of storage, StorageManager.cpp"
    ),
}


def storage_limits(
    autopilot: Autopilot, given: tuple[int, ...] | int | None = None
) -> StorageLimits:
    """``autopilot``'s default limits (:data:`DEFAULT_STORAGE`; a generic vehicle: the
    smallest of both), with ``given`` in their place: the mission's limit, or (mission,
    fence, rally) (``--max-items``, ``mission.max_items``)."""
    base = DEFAULT_STORAGE.get(autopilot)
    if base is None:
        px4, ap = DEFAULT_STORAGE[Autopilot.PX4], DEFAULT_STORAGE[Autopilot.ARDUPILOT]
        base = StorageLimits(
            min(px4.mission, ap.mission),
            min(px4.fence, ap.fence),
            min(px4.rally, ap.rally),
            "the smaller of PX4's and ArduPilot's defaults",
        )
    if given is None:
        return base
    numbers = (given,) if isinstance(given, int) else tuple(given)
    mission, fence, rally = (*numbers, *(base.fence, base.rally)[len(numbers) - 1 :])[:3]
    return StorageLimits(mission, fence, rally, "as given (--max-items / mission.max_items)")


def storage_problem(plan: MissionPlan, autopilot: Autopilot, limits: StorageLimits) -> str | None:
    """Why ``plan`` does not fit a ``autopilot`` vehicle's storage ``limits`` (None: it
    fits), counting items as they go on the wire for that flavour."""
    for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
        if mission_type is MissionType.MISSION:
            count = len(plan.items) + (1 if autopilot is Autopilot.ARDUPILOT else 0)
        else:
            count = len(plan.wire_items(mission_type))
        limit = limits.of(mission_type)
        if count > limit:
            with_home = autopilot is Autopilot.ARDUPILOT and mission_type is MissionType.MISSION
            home = " (home included)" if with_home else ""
            return (
                f"{count:,} {_LABEL[mission_type]} items{home} do not fit the vehicle's "
                f"storage: {autopilot.label} holds {limit:,} ({limits.source}); a vehicle that "
                "stores more: give its limit with --max-items (plan: mission.max_items)"
            )
    return None


def check_plan_fits_storage(
    plan: MissionPlan,
    autopilot: Autopilot,
    limits: StorageLimits | None = None,
    *,
    file: str | None = None,
) -> None:
    """Raise :class:`InputError` (exit 2, naming ``file``) when ``plan`` does not fit a
    ``autopilot`` vehicle's storage (``limits``, default :func:`storage_limits`): checked
    before a mission file is written and before an upload connects, so nothing is written
    or sent."""
    problem = storage_problem(plan, autopilot, limits or storage_limits(autopilot))
    if problem is not None:
        raise InputError(problem, file=file)


def check_storage(
    plan: MissionPlan, max_items: tuple[int, ...] | int | None = None, *, file: str | None = None
) -> None:
    """The writer's check (``plan`` before it writes a mission file): ``plan`` fits the
    storage of a vehicle of its own flavour (:func:`storage_limits` with ``max_items``),
    else :class:`InputError` (exit 2, naming ``file``)."""
    check_plan_fits_storage(
        plan, plan.autopilot, storage_limits(plan.autopilot, max_items), file=file
    )
