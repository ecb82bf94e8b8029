"""The autopilot flavours uavplan writes missions for and flies: PX4 and ArduPilot Copter
(and a generic MAVLink autopilot, for files that name none)."""

from __future__ import annotations

import enum

__all__ = ["Autopilot"]


class Autopilot(enum.Enum):
    """Autopilot flavour; ``value`` is the MAV_AUTOPILOT number (QGC's ``firmwareType``)."""

    GENERIC = 0
    ARDUPILOT = 3
    PX4 = 12

    @classmethod
    def from_name(cls, name: str) -> Autopilot:
        key = name.strip().lower()
        table = {
            "px4": cls.PX4,
            "ardupilot": cls.ARDUPILOT,
            "apm": cls.ARDUPILOT,
            "generic": cls.GENERIC,
        }
        if key not in table:
            raise ValueError(f"unknown autopilot {name!r} (expected px4 or ardupilot)")
        return table[key]

    @property
    def label(self) -> str:
        return {
            Autopilot.GENERIC: "generic",
            Autopilot.ARDUPILOT: "ardupilot",
            Autopilot.PX4: "px4",
        }[self]
