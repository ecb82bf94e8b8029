"""The autopilot parameters the flight model flies by: one table per flavour, with sources.

Every row names a firmware parameter exactly as the firmware spells it, its default in the
firmware's own unit (ArduPilot Copter keeps centimetres and cm/s, PX4 metres and m/s), and
the file in the firmware's source tree that defines that default. :class:`Parameters` holds a
table's current values: the defaults, changed by name (``--param`` style overrides, or the
vehicle's PARAM_SET); the flight model reads them through :func:`guidance_limits` in SI units.

The tables are also the vehicle's parameter set: PARAM_REQUEST_LIST lists exactly these
rows, in this order (the index of a row is its ``param_index``). A real autopilot holds
hundreds more; the ones here are those the flight model honours (docs/flight-model.md).

ArduPilot values are Copter 4.5's, which ArduCopter V4.7.0-dev SITL (ArduPilot 90700977c553)
still holds under the same names and values (read back from it: tests/sitl/test_sitl_fly.py).
PX4 values are those a PX4 v1.16 multicopter holds: the parameter files' defaults, with
the three that every multicopter airframe overrides in ROMFS/px4fmu_common/init.d/
rc.mc_defaults (NAV_ACC_RAD 2, RTL_RETURN_ALT 30, RTL_DESCEND_ALT 10; read back from PX4
v1.16.0 SIH).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field

from uavplan.flavour import Autopilot

__all__ = [
    "ARDUPILOT_PARAMS",
    "FENCE_TYPE_ALT_MAX",
    "FENCE_TYPE_POLYGON",
    "PX4_PARAMS",
    "GuidanceLimits",
    "ParamSpec",
    "ParamType",
    "ParameterValueError",
    "Parameters",
    "UnknownParameter",
    "guidance_limits",
    "param_table",
    "parameters_from",
]

_AP = "https://github.com/ArduPilot/ardupilot/blob/Copter-4.5/"
_AP_WPNAV = _AP + "libraries/AC_WPNav/AC_WPNav.cpp"
_AP_WPNAV_H = _AP + "libraries/AC_WPNav/AC_WPNav.h"
_AP_CONFIG = _AP + "ArduCopter/config.h"
_AP_PARAMS = _AP + "ArduCopter/Parameters.cpp"
_PX4 = "https://github.com/PX4/PX4-Autopilot/blob/main/src/modules/"
_PX4_AUTO = _PX4 + "mc_pos_control/multicopter_autonomous_params.yaml"
_PX4_LIMITS = _PX4 + "mc_pos_control/multicopter_position_control_limits_params.yaml"
_PX4_TKO_LAND = _PX4 + "mc_pos_control/multicopter_takeoff_land_params.yaml"
_PX4_REF = "https://docs.px4.io/main/en/advanced_config/parameter_reference.html#"
_PX4_NAV = _PX4 + "navigator/navigator_params.yaml"
_PX4_RTL = _PX4 + "navigator/rtl_params.yaml"
_PX4_ARM = _PX4_REF + "COM_ARM_MIS_REQ"
_AP_FENCE = _AP + "libraries/AC_Fence/AC_Fence.cpp"
_AP_POSCONTROL = _AP + "libraries/AC_AttitudeControl/AC_PosControl.cpp"
_AP_ATC_MULTI = _AP + "libraries/AC_AttitudeControl/AC_AttitudeControl.cpp"
_PX4_GEOFENCE = _PX4 + "navigator/geofence_params.yaml"
#: every PX4 multicopter airframe runs this first; it overrides the parameter files' defaults
_PX4_MC_DEFAULTS = (
    "https://github.com/PX4/PX4-Autopilot/blob/v1.16.0/ROMFS/px4fmu_common/init.d/rc.mc_defaults"
)


#: ArduPilot FENCE_TYPE bit of the maximum-altitude fence (AC_Fence.h AC_FENCE_TYPE_ALT_MAX)
FENCE_TYPE_ALT_MAX = 1
#: ArduPilot FENCE_TYPE bit of the fence items uploaded (AC_FENCE_TYPE_POLYGON)
FENCE_TYPE_POLYGON = 4


class ParamType(enum.IntEnum):
    """MAV_PARAM_TYPE of a parameter on the wire."""

    INT8 = 2
    INT16 = 4
    INT32 = 6
    REAL32 = 9


@dataclass(frozen=True)
class ParamSpec:
    """One firmware parameter: its name, default (firmware unit), unit and where it is defined."""

    name: str
    default: float
    unit: str
    description: str
    source: str
    minimum: float | None = None
    maximum: float | None = None
    type: ParamType = ParamType.REAL32

    def __post_init__(self) -> None:
        if not (1 <= len(self.name) <= 16 and self.name.isascii()):
            raise ValueError(f"parameter name {self.name!r} must be 1..16 ASCII characters")
        self.check(self.default)

    def check(self, value: float, *, ranged: bool = True) -> float:
        """``value`` as this parameter holds it (whole numbers for integer types); raises
        ``ValueError`` when it is not finite or (``ranged``) outside the parameter's range."""
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{self.name} must be finite, got {value!r}")
        if self.type != ParamType.REAL32:
            value = float(round(value))
        if not ranged:
            return value
        if self.minimum is not None and value < self.minimum:
            raise ValueError(f"{self.name} {value:g} is below its minimum {self.minimum:g}")
        if self.maximum is not None and value > self.maximum:
            raise ValueError(f"{self.name} {value:g} is above its maximum {self.maximum:g}")
        return value


ARDUPILOT_PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "WPNAV_SPEED", 1000.0, "cm/s", "horizontal speed between waypoints", _AP_WPNAV, 20.0, 2000.0
    ),
    ParamSpec("WPNAV_SPEED_UP", 250.0, "cm/s", "climb speed in missions", _AP_WPNAV, 10.0, 1000.0),
    ParamSpec("WPNAV_SPEED_DN", 150.0, "cm/s", "descent speed in missions", _AP_WPNAV, 10.0, 500.0),
    ParamSpec(
        "WPNAV_ACCEL",
        250.0,
        "cm/s/s",
        "horizontal acceleration in missions (the header's WPNAV_ACCELERATION)",
        _AP_WPNAV_H,
        50.0,
        500.0,
    ),
    ParamSpec(
        "WPNAV_ACCEL_Z",
        100.0,
        "cm/s/s",
        "vertical acceleration in missions",
        _AP_WPNAV,
        50.0,
        500.0,
    ),
    ParamSpec(
        "WPNAV_ACCEL_C",
        0.0,
        "cm/s/s",
        "cornering acceleration; 0: twice WPNAV_ACCEL",
        _AP_WPNAV,
        0.0,
        500.0,
    ),
    ParamSpec(
        "WPNAV_JERK",
        1.0,
        "m/s/s/s",
        "jerk of the S-curve legs between waypoints (with ATC_INPUT_TC: how fast the "
        "acceleration builds up; a 59 m leg peaks at 9.1 m/s of WPNAV_SPEED's 10)",
        _AP_WPNAV,
        1.0,
        20.0,
    ),
    ParamSpec(
        "ATC_INPUT_TC",
        0.15,
        "s",
        "attitude control input time constant: the S-curves' snap is "
        "WPNAV_JERK·π/(4·max(ATC_INPUT_TC, 0.1)) (AC_WPNav::calc_scurve_jerk_and_snap)",
        _AP_ATC_MULTI,
        0.0,
        1.0,
    ),
    ParamSpec(
        "WPNAV_RADIUS",
        200.0,
        "cm",
        "how far from a waypoint the apex of a corner may pass (S-curve corners)",
        _AP_WPNAV,
        5.0,
        1000.0,
    ),
    ParamSpec(
        "WPNAV_TER_MARGIN",
        10.0,
        "m",
        "terrain-frame legs: from half of it the altitude's lag behind the terrain "
        "slows the vehicle along the leg, to 1 % of its speed at all of it",
        _AP_WPNAV,
        0.1,
        100.0,
    ),
    ParamSpec(
        "PSC_JERK_Z",
        5.0,
        "m/s/s/s",
        "terrain-frame legs: how fast the altitude takes up a change of the ground "
        "(the vertical shaping's jerk: its gain, half of it over WPNAV_ACCEL_Z)",
        _AP_POSCONTROL,
        5.0,
        50.0,
    ),
    ParamSpec(
        "RTL_ALT",
        1500.0,
        "cm",
        "lowest altitude above home the return flies at",
        _AP_CONFIG,
        30.0,
        300000.0,
        ParamType.INT32,
    ),
    ParamSpec(
        "RTL_ALT_FINAL",
        0.0,
        "cm",
        "altitude the return ends at; 0: land",
        _AP_CONFIG,
        0.0,
        1000.0,
        ParamType.INT32,
    ),
    ParamSpec(
        "RTL_CLIMB_MIN",
        0.0,
        "cm",
        "least climb at the start of a return",
        _AP_CONFIG,
        0.0,
        3000.0,
        ParamType.INT16,
    ),
    ParamSpec(
        "RTL_SPEED",
        0.0,
        "cm/s",
        "horizontal speed of the return; 0: WPNAV_SPEED",
        _AP_PARAMS,
        0.0,
        2000.0,
        ParamType.INT16,
    ),
    ParamSpec(
        "RTL_CONE_SLOPE",
        3.0,
        "",
        "cone above home that lowers the return altitude "
        "near home (height / distance); below 0.5: no cone",
        _AP_CONFIG,
        0.0,
        10.0,
    ),
    ParamSpec(
        "RTL_LOIT_TIME",
        5000.0,
        "ms",
        "hover above home before the final descent",
        _AP_CONFIG,
        0.0,
        60000.0,
        ParamType.INT32,
    ),
    ParamSpec(
        "LAND_SPEED",
        50.0,
        "cm/s",
        "descent speed of the last stage of a landing",
        _AP_CONFIG,
        30.0,
        200.0,
        ParamType.INT16,
    ),
    ParamSpec(
        "LAND_SPEED_HIGH",
        0.0,
        "cm/s",
        "descent speed above LAND_ALT_LOW; 0: WPNAV_SPEED_DN",
        _AP_PARAMS,
        0.0,
        500.0,
        ParamType.INT16,
    ),
    ParamSpec(
        "LAND_ALT_LOW",
        1000.0,
        "cm",
        "altitude below which a landing slows to LAND_SPEED",
        _AP_PARAMS,
        100.0,
        10000.0,
        ParamType.INT16,
    ),
    ParamSpec(
        "FENCE_ENABLE",
        0.0,
        "",
        "1: the fence is enabled (its ceiling caps the return altitude, a breach is reported)",
        _AP_FENCE,
        0.0,
        1.0,
        ParamType.INT8,
    ),
    ParamSpec(
        "FENCE_TYPE",
        7.0,
        "",
        "fences enabled (bitmask): 1 maximum altitude, 2 circle around home, 4 polygons and "
        "circles uploaded, 8 minimum altitude",
        _AP_FENCE,
        0.0,
        15.0,
        ParamType.INT8,
    ),
    ParamSpec(
        "FENCE_ALT_MAX",
        100.0,
        "m",
        "the fence's ceiling above home",
        _AP_FENCE,
        10.0,
        1000.0,
    ),
    ParamSpec(
        "FENCE_MARGIN",
        2.0,
        "m",
        "distance kept from the fence: the return flies at most FENCE_ALT_MAX less this",
        _AP_FENCE,
        1.0,
        10.0,
    ),
)

PX4_PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "MPC_XY_CRUISE",
        5.0,
        "m/s",
        "horizontal speed in missions unless a waypoint says otherwise",
        _PX4_AUTO,
        3.0,
        20.0,
    ),
    ParamSpec(
        "MPC_XY_VEL_MAX",
        12.0,
        "m/s",
        "horizontal speed limit of every mode (caps DO_CHANGE_SPEED)",
        _PX4_LIMITS,
        0.0,
        20.0,
    ),
    ParamSpec(
        "MPC_Z_V_AUTO_UP", 3.0, "m/s", "climb speed in autonomous modes", _PX4_AUTO, 0.5, 8.0
    ),
    ParamSpec(
        "MPC_Z_V_AUTO_DN", 1.5, "m/s", "descent speed in autonomous modes", _PX4_AUTO, 0.5, 4.0
    ),
    ParamSpec(
        "MPC_ACC_HOR",
        3.0,
        "m/s^2",
        "horizontal acceleration in autonomous modes",
        _PX4_AUTO,
        2.0,
        15.0,
    ),
    ParamSpec(
        "MPC_ACC_UP_MAX",
        4.0,
        "m/s^2",
        "upward acceleration limit",
        _PX4_REF + "MPC_ACC_UP_MAX",
        2.0,
        15.0,
    ),
    ParamSpec(
        "MPC_ACC_DOWN_MAX",
        3.0,
        "m/s^2",
        "downward acceleration limit",
        _PX4_REF + "MPC_ACC_DOWN_MAX",
        2.0,
        15.0,
    ),
    ParamSpec(
        "MPC_JERK_AUTO",
        4.0,
        "m/s^3",
        "jerk limit in autonomous modes (its delay enters the braking distance)",
        _PX4_AUTO,
        1.0,
        80.0,
    ),
    ParamSpec(
        "MPC_XY_TRAJ_P", 0.5, "", "share of MPC_ACC_HOR a corner may use", _PX4_AUTO, 0.1, 1.0
    ),
    ParamSpec(
        "MPC_TKO_SPEED",
        1.5,
        "m/s",
        "take-off climb speed below MPC_LAND_ALT1",
        _PX4_TKO_LAND,
        1.0,
        5.0,
    ),
    ParamSpec(
        "MPC_TKO_RAMP_T",
        3.0,
        "s",
        "take-off ramp: below MPC_LAND_ALT1 the climb accelerates at most MPC_TKO_SPEED / this",
        _PX4_TKO_LAND,
        0.0,
        10.0,
    ),
    ParamSpec(
        "MPC_LAND_SPEED",
        0.7,
        "m/s",
        "descent speed of a landing below MPC_LAND_ALT2",
        _PX4_TKO_LAND,
        0.6,
        None,
    ),
    ParamSpec(
        "MPC_LAND_ALT1",
        10.0,
        "m",
        "below it a landing slows from MPC_Z_V_AUTO_DN toward MPC_LAND_SPEED",
        _PX4_TKO_LAND,
        0.0,
        122.0,
    ),
    ParamSpec(
        "MPC_LAND_ALT2",
        5.0,
        "m",
        "below it a landing descends at MPC_LAND_SPEED",
        _PX4_TKO_LAND,
        0.0,
        122.0,
    ),
    ParamSpec(
        "NAV_ACC_RAD",
        2.0,
        "m",
        "acceptance radius of a waypoint, unless the item gives its own (navigator_params.yaml "
        "says 10; rc.mc_defaults sets 2 for every multicopter)",
        _PX4_MC_DEFAULTS,
        0.05,
        200.0,
    ),
    ParamSpec(
        "NAV_MC_ALT_RAD", 0.8, "m", "altitude acceptance of a waypoint", _PX4_NAV, 0.05, 200.0
    ),
    ParamSpec(
        "MIS_TAKEOFF_ALT",
        2.5,
        "m",
        "lowest altitude above home a take-off climbs to (a mission started on the ground, "
        "Takeoff mode)",
        _PX4 + "navigator/mission_params.yaml",
        0.0,
        80.0,
    ),
    ParamSpec(
        "RTL_RETURN_ALT",
        30.0,
        "m",
        "lowest altitude above home the return flies at (rtl_params.yaml says 60; "
        "rc.mc_defaults sets 30 for every multicopter)",
        _PX4_MC_DEFAULTS,
        0.0,
        None,
    ),
    ParamSpec(
        "RTL_DESCEND_ALT",
        10.0,
        "m",
        "altitude above home the return descends to before landing (rtl_params.yaml says "
        "30; rc.mc_defaults sets 10 for every multicopter)",
        _PX4_MC_DEFAULTS,
        0.0,
        None,
    ),
    ParamSpec(
        "RTL_LAND_DELAY",
        0.0,
        "s",
        "hover at RTL_DESCEND_ALT before landing; -1: stay",
        _PX4_RTL,
        -1.0,
        300.0,
    ),
    ParamSpec(
        "RTL_MIN_DIST",
        10.0,
        "m",
        "within this distance of home the return altitude follows the cone",
        _PX4_RTL,
        0.5,
        None,
    ),
    ParamSpec(
        "RTL_CONE_ANG",
        45.0,
        "deg",
        "half-angle of the return-altitude cone; 0: none",
        _PX4_RTL,
        0.0,
        90.0,
        ParamType.INT32,
    ),
    ParamSpec(
        "COM_ARM_MIS_REQ",
        0.0,
        "",
        "1: arming needs a valid mission",
        _PX4_ARM,
        0.0,
        1.0,
        ParamType.INT32,
    ),
    ParamSpec(
        "RTL_TYPE",
        0.0,
        "",
        "return type: 0 home directly; 2 in a mission with a landing, fly the mission on to "
        "its landing (1 and 3: not modelled, flown as 0)",
        _PX4_RTL,
        0.0,
        3.0,
        ParamType.INT32,
    ),
    ParamSpec(
        "GF_ACTION",
        2.0,
        "",
        "geofence action: 0 none (no fence), 1 warning, 2 hold, 3 return, 4 terminate, 5 land "
        "(the model reports a breach, it does not act on it)",
        _PX4_GEOFENCE,
        0.0,
        5.0,
        ParamType.INT32,
    ),
    ParamSpec(
        "GF_MAX_VER_DIST",
        0.0,
        "m",
        "the fence's ceiling above home; 0: none",
        _PX4_GEOFENCE,
        0.0,
        10000.0,
    ),
)

_TABLES: dict[Autopilot, tuple[ParamSpec, ...]] = {
    Autopilot.ARDUPILOT: ARDUPILOT_PARAMS,
    Autopilot.PX4: PX4_PARAMS,
}


def param_table(autopilot: Autopilot) -> tuple[ParamSpec, ...]:
    """The parameter table of ``autopilot`` (PX4 or ArduPilot)."""
    try:
        return _TABLES[autopilot]
    except KeyError:
        raise ValueError(f"no flight model for autopilot {autopilot.label}") from None


class UnknownParameter(KeyError):
    """A parameter name the flavour's table does not hold."""

    def __init__(self, name: str, autopilot: Autopilot) -> None:
        super().__init__(name)
        self.name = name
        self.autopilot = autopilot

    def __str__(self) -> str:
        return f"{self.autopilot.label} has no parameter {self.name!r}"


@dataclass(frozen=True)
class Parameters:
    """The values of one flavour's parameter table (immutable; :meth:`with_values` changes)."""

    autopilot: Autopilot
    values: Mapping[str, float] = field(default_factory=dict)
    #: values outside a parameter's documented range are accepted (a PARAM_SET: the
    #: firmwares store what they are sent); the flight model clamps what it must
    ranged: bool = True

    def __post_init__(self) -> None:
        table = param_table(self.autopilot)
        resolved = {spec.name: spec.default for spec in table}
        for name, value in self.values.items():
            spec = self._spec(name)
            resolved[spec.name] = spec.check(value, ranged=self.ranged)
        object.__setattr__(self, "values", resolved)

    @classmethod
    def defaults(cls, autopilot: Autopilot) -> Parameters:
        return cls(autopilot)

    def _spec(self, name: str) -> ParamSpec:
        for spec in param_table(self.autopilot):
            if spec.name == name:
                return spec
        raise UnknownParameter(name, self.autopilot)

    def spec(self, name: str) -> ParamSpec:
        """The table row for ``name``; :class:`UnknownParameter` if there is none."""
        return self._spec(name)

    def with_values(self, changes: Mapping[str, float], *, checked: bool = True) -> Parameters:
        """These values with ``changes`` applied: names checked, values range-checked
        unless ``checked`` is false (what a PARAM_SET does)."""
        merged = dict(self.values)
        merged.update(changes)
        return Parameters(self.autopilot, merged, ranged=checked and self.ranged)

    def __getitem__(self, name: str) -> float:
        try:
            return self.values[name]
        except KeyError:
            raise UnknownParameter(name, self.autopilot) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.values)

    def __len__(self) -> int:
        return len(self.values)

    @property
    def specs(self) -> tuple[ParamSpec, ...]:
        return param_table(self.autopilot)

    def index_of(self, name: str) -> int:
        """The ``param_index`` of ``name`` (its row in the table)."""
        for index, spec in enumerate(self.specs):
            if spec.name == name:
                return index
        raise UnknownParameter(name, self.autopilot)


class ParameterValueError(ValueError):
    """A parameter given by name (``--param NAME=VALUE``) that the flavour's table does not
    hold, or a value outside the parameter's documented range."""


def parameters_from(
    autopilot: Autopilot, assignments: Iterable[tuple[str, float]] | Mapping[str, float]
) -> Parameters:
    """The one reading of parameters given by name (``simulate --param``, ``mock-vehicle
    --param``): the flavour's defaults with ``assignments`` applied (the last of a name
    wins), each name checked against :func:`param_table` and each value against the
    parameter's range (:meth:`ParamSpec.check`). Raises :class:`ParameterValueError`."""
    pairs = assignments.items() if isinstance(assignments, Mapping) else assignments
    values = {name: value for name, value in pairs}
    try:
        return Parameters(autopilot, values)
    except UnknownParameter as err:
        names = ", ".join(spec.name for spec in param_table(autopilot))
        raise ParameterValueError(f"{err} (it has {names})") from None
    except ValueError as err:
        raise ParameterValueError(str(err)) from None


@dataclass(frozen=True)
class GuidanceLimits:
    """What the flight model needs from the parameters, in SI units (m, s).

    ``acceptance_radius_m``: PX4's default acceptance radius (NAV_ACC_RAD), or ArduPilot's
    waypoint radius (WPNAV_RADIUS), the bound of an S-curve corner's apex.
    """

    autopilot: Autopilot
    speed_xy_m_s: float
    speed_xy_max_m_s: float
    speed_up_m_s: float
    speed_down_m_s: float
    accel_xy_m_s2: float
    accel_up_m_s2: float
    accel_down_m_s2: float
    accel_corner_m_s2: float
    jerk_m_s3: float | None
    acceptance_radius_m: float
    altitude_acceptance_m: float
    takeoff_speed_m_s: float
    takeoff_slow_below_m: float
    land_speed_m_s: float
    land_speed_high_m_s: float
    land_slow_below_m: float
    land_final_below_m: float
    rtl_altitude_m: float
    rtl_descend_altitude_m: float | None
    rtl_final_altitude_m: float
    rtl_climb_min_m: float
    rtl_speed_m_s: float
    rtl_loiter_s: float
    rtl_cone: float
    rtl_min_dist_m: float
    corner_gain: float
    #: the fence's ceiling above home when an altitude fence is enabled (None: none)
    fence_ceiling_m: float | None = None
    #: ArduPilot's FENCE_MARGIN: its return flies at most the ceiling less this
    fence_margin_m: float = 0.0
    #: PX4's RTL_TYPE (ArduPilot: 0)
    rtl_type: int = 0
    #: ArduPilot's WPNAV_TER_MARGIN (m): how far the altitude may lag the terrain on a
    #: terrain-frame leg before the vehicle slows along it (from half of it); 0: PX4
    terrain_margin_m: float = 0.0
    #: ArduPilot's PSC_JERK_Z (m/s³): the jerk of the vertical shaping that takes up the
    #: ground's changes on terrain-frame legs; 0: PX4
    jerk_z_m_s3: float = 0.0
    #: PX4's take-off ramp (MPC_TKO_RAMP_T, s): below takeoff_slow_below_m the climb's
    #: acceleration is at most takeoff_speed_m_s over it; 0: ArduPilot
    takeoff_ramp_s: float = 0.0
    #: ArduPilot's S-curve legs (AC_WPNav): their jerk (WPNAV_JERK, m/s³) and snap (m/s⁴);
    #: 0: constant-acceleration legs (PX4 has its own guidance)
    scurve_jerk_m_s3: float = 0.0
    scurve_snap_m_s4: float = 0.0
    #: PX4's MIS_TAKEOFF_ALT (m above home): a mission started on the ground climbs at least
    #: this high before its first waypoint, and Takeoff mode climbs to it; 0: ArduPilot
    takeoff_min_altitude_m: float = 0.0

    @property
    def is_px4(self) -> bool:
        return self.autopilot == Autopilot.PX4


def guidance_limits(params: Parameters) -> GuidanceLimits:
    """The SI limits the flight model uses, from the firmware parameters (values outside a
    parameter's range are clamped to it, as the firmware's own sanity checks do for the
    speeds, accelerations and radii)."""
    p = _Clamped(params)
    if params.autopilot == Autopilot.ARDUPILOT:
        cm = 0.01
        speed_xy = p["WPNAV_SPEED"] * cm
        accel_xy = p["WPNAV_ACCEL"] * cm
        speed_down = p["WPNAV_SPEED_DN"] * cm
        accel_c = p["WPNAV_ACCEL_C"] * cm or 2.0 * accel_xy
        return GuidanceLimits(
            autopilot=Autopilot.ARDUPILOT,
            speed_xy_m_s=speed_xy,
            speed_xy_max_m_s=20.0,  # WPNAV_SPEED's range; DO_CHANGE_SPEED beyond it is clipped
            speed_up_m_s=p["WPNAV_SPEED_UP"] * cm,
            speed_down_m_s=speed_down,
            accel_xy_m_s2=accel_xy,
            accel_up_m_s2=p["WPNAV_ACCEL_Z"] * cm,
            accel_down_m_s2=p["WPNAV_ACCEL_Z"] * cm,
            accel_corner_m_s2=accel_c,
            jerk_m_s3=None,
            acceptance_radius_m=p["WPNAV_RADIUS"] * cm,
            altitude_acceptance_m=p["WPNAV_RADIUS"] * cm,
            takeoff_speed_m_s=p["WPNAV_SPEED_UP"] * cm,
            takeoff_slow_below_m=0.0,
            land_speed_m_s=p["LAND_SPEED"] * cm,
            land_speed_high_m_s=(p["LAND_SPEED_HIGH"] * cm) or speed_down,
            land_slow_below_m=p["LAND_ALT_LOW"] * cm,
            land_final_below_m=p["LAND_ALT_LOW"] * cm,
            rtl_altitude_m=p["RTL_ALT"] * cm,
            rtl_descend_altitude_m=None,
            rtl_final_altitude_m=p["RTL_ALT_FINAL"] * cm,
            rtl_climb_min_m=p["RTL_CLIMB_MIN"] * cm,
            rtl_speed_m_s=(p["RTL_SPEED"] * cm) or speed_xy,
            rtl_loiter_s=p["RTL_LOIT_TIME"] / 1000.0,
            rtl_cone=p["RTL_CONE_SLOPE"],
            rtl_min_dist_m=0.0,
            corner_gain=1.0,
            fence_ceiling_m=(
                p["FENCE_ALT_MAX"]
                if p["FENCE_ENABLE"] >= 1 and int(p["FENCE_TYPE"]) & FENCE_TYPE_ALT_MAX
                else None
            ),
            fence_margin_m=p["FENCE_MARGIN"],
            terrain_margin_m=p["WPNAV_TER_MARGIN"],
            jerk_z_m_s3=p["PSC_JERK_Z"],
            scurve_jerk_m_s3=p["WPNAV_JERK"],
            scurve_snap_m_s4=_scurve_snap(p["WPNAV_JERK"], p["ATC_INPUT_TC"]),
        )
    if params.autopilot == Autopilot.PX4:
        return GuidanceLimits(
            autopilot=params.autopilot,
            speed_xy_m_s=min(p["MPC_XY_CRUISE"], p["MPC_XY_VEL_MAX"]),
            speed_xy_max_m_s=p["MPC_XY_VEL_MAX"],
            speed_up_m_s=p["MPC_Z_V_AUTO_UP"],
            speed_down_m_s=p["MPC_Z_V_AUTO_DN"],
            accel_xy_m_s2=p["MPC_ACC_HOR"],
            accel_up_m_s2=p["MPC_ACC_UP_MAX"],
            accel_down_m_s2=p["MPC_ACC_DOWN_MAX"],
            accel_corner_m_s2=p["MPC_ACC_HOR"] * p["MPC_XY_TRAJ_P"],
            jerk_m_s3=p["MPC_JERK_AUTO"],
            acceptance_radius_m=p["NAV_ACC_RAD"],
            altitude_acceptance_m=p["NAV_MC_ALT_RAD"],
            takeoff_speed_m_s=p["MPC_TKO_SPEED"],
            takeoff_slow_below_m=p["MPC_LAND_ALT1"],
            takeoff_ramp_s=p["MPC_TKO_RAMP_T"],
            land_speed_m_s=p["MPC_LAND_SPEED"],
            land_speed_high_m_s=p["MPC_Z_V_AUTO_DN"],
            land_slow_below_m=max(p["MPC_LAND_ALT1"], p["MPC_LAND_ALT2"]),
            land_final_below_m=p["MPC_LAND_ALT2"],
            rtl_altitude_m=p["RTL_RETURN_ALT"],
            rtl_descend_altitude_m=p["RTL_DESCEND_ALT"],
            rtl_final_altitude_m=0.0,
            rtl_climb_min_m=0.0,
            rtl_speed_m_s=min(p["MPC_XY_CRUISE"], p["MPC_XY_VEL_MAX"]),
            rtl_loiter_s=p["RTL_LAND_DELAY"],
            rtl_cone=p["RTL_CONE_ANG"],
            rtl_min_dist_m=p["RTL_MIN_DIST"],
            corner_gain=p["MPC_XY_TRAJ_P"],
            fence_ceiling_m=(
                p["GF_MAX_VER_DIST"] if p["GF_ACTION"] >= 1 and p["GF_MAX_VER_DIST"] > 0.0 else None
            ),
            rtl_type=int(p["RTL_TYPE"]),
            takeoff_min_altitude_m=p["MIS_TAKEOFF_ALT"],
        )
    raise ValueError(f"no flight model for autopilot {params.autopilot.label}")


def _scurve_snap(jerk_m_s3: float, input_tc_s: float) -> float:
    """``AC_WPNav::calc_scurve_jerk_and_snap``: snap is the jerk over the attitude
    controller's input time constant, ``jerk·π / (2·max(tc, 0.1))``, halved "from what the
    aircraft is capable of". (The jerk is also capped by the roll and pitch rate limits
    ATC_RATE_R_MAX / ATC_RATE_P_MAX times g, and the snap by ATC_ACCEL_R_MAX / _P_MAX times g:
    with their defaults, 0 (no limit) and 1100 deg/s² (188 m/s⁴), neither binds.)"""
    return 0.5 * jerk_m_s3 * math.pi / (2.0 * max(input_tc_s, 0.1))


class _Clamped:
    """Read parameters clamped to their documented ranges."""

    def __init__(self, params: Parameters) -> None:
        self._params = params

    def __getitem__(self, name: str) -> float:
        spec = self._params.spec(name)
        value = self._params[name]
        if spec.minimum is not None:
            value = max(value, spec.minimum)
        if spec.maximum is not None:
            value = min(value, spec.maximum)
        return value
