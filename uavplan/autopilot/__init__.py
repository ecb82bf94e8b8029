"""The autopilot: what PX4 and ArduPilot Copter do with a mission, as pure functions of
simulated time, with no link and no I/O.

It imports only the vocabulary and the mission layer. Everything that needs to know how the
firmware flies (the rehearsal of ``plan``, the way home, the estimate, the verdict, ``fly``,
and the simulated vehicle of :mod:`uavplan.sim`) asks this layer. Its modules, each
importing only the ones above it:

- :mod:`.params` - each flavour's parameter table (name, default, unit, source) and the SI
  limits the flight model reads from it;
- :mod:`.kinematics` - vectors, speed profiles, wind, the firmwares' trajectory maths;
- :mod:`.rtl` - the altitude each firmware returns at;
- :mod:`.nav` - a mission read as the model flies it (:class:`~.nav.NavItem`: ENU positions
  in the frame at home);
- :mod:`.motion` - what moves the vehicle for one step, flavour aside: hold, brake, land;
- :mod:`.ardupilot` and :mod:`.px4` - each flavour's waypoint guidance (AC_WPNav's S-curve
  legs; FlightTaskAuto with PositionSmoothing);
- :mod:`.model` - the flight model (:class:`~.model.FlightModel`): take-off, the mission's
  items, landing, RTL, DO_CHANGE_SPEED, hold times, in simulated time, with the flavour's
  guidance;
- :mod:`.power` - the battery and the one function that says how much power is drawn;
- :mod:`.simulate` - :func:`~.simulate.simulate`: a mission plan → the flown track;
- :mod:`.camera` - where a flown track takes its photos.

What the flight model covers and what it leaves out, with every parameter's source:
docs/flight-model.md.
"""

from __future__ import annotations

from uavplan.lazy import lazy_exports

#: public name -> module that defines it; imported on first use
_EXPORTS = {
    "FlightModel": "model",
    "FlownTrack": "simulate",
    "Parameters": "params",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
