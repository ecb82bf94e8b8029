"""The MAVLink parameter protocol's ground side: read, set and read back, with no I/O.

A mission can rely on vehicle parameters (the RTL altitude that brings it home clear of the
obstacles, the fence's ceiling, whether the fence is on). :class:`ParamMachine` makes the
vehicle hold them, one parameter after another, as a state machine that takes events and
returns the messages to send, like the mission protocol's machines (:mod:`.machines`):

- ``start(now)``: the first messages;
- ``on_message(message, now)``: a PARAM_VALUE or STATUSTEXT from the vehicle;
- ``on_timeout(now)``: called once ``now >= machine.deadline`` with nothing received.

For each :class:`ParamRequest`:

1. **read** it (PARAM_REQUEST_READ by name): its value and type on the vehicle. A value the
   request accepts (within ``at_least`` .. ``at_most``) is kept as it is;
2. otherwise **set** it (PARAM_SET, in the type the vehicle reported, integer types encoded
   as the vehicle encodes them: bytewise on PX4, a C cast on ArduPilot). The vehicle answers
   with PARAM_VALUE (MAVLink parameter protocol: the new value, or the one it kept);
3. **read it back** (PARAM_REQUEST_READ again) and judge on that reply: the value asked
   for is *changed*; the old value is set once more (the PARAM_SET may have been lost
   while a late reply to an earlier read passed for its answer) and, read back unchanged
   again, *refused* (with the vehicle's STATUSTEXT, e.g. ArduPilot's ``Param write denied
   (NAME)``).

With ``set_values=False`` the machine only reads: a value the request does not accept ends
that parameter as *differs* (nothing is sent but PARAM_REQUEST_READ), which is how ``fly``
and ``upload`` check the vehicle before they change anything.

Each step is re-sent after ``timeouts.reply_s`` without an answer, ``timeouts.retries``
times; a step never answered ends that parameter as *unanswered* (a name the vehicle does
not know: ArduPilot stays silent, PX4 says ``[pm] unknown param: NAME``; or a link that lost
every reply). The machine goes on with the next parameter either way, so one run reports on
all of them. :class:`ParamClient` is the thin loop that drives it over a
:class:`~uavplan.mavlink.link.VehicleLink` (the only place here with a clock and a socket).

Protocol: https://mavlink.io/en/services/parameter.html (PARAM_SET is answered by
PARAM_VALUE; "If the sending GCS did not receive a PARAM_VALUE within its timeout time, it
should re-send the PARAM_SET message").
"""

from __future__ import annotations

import enum
import math
import struct
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from uavplan.errors import LinkError
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.messages import (
    Capability,
    Message,
    ParamRequestRead,
    ParamSet,
    ParamValue,
    StatusText,
)

__all__ = [
    "ParamClient",
    "ParamMachine",
    "ParamRequest",
    "ParamResult",
    "ParamStatus",
    "ParamTimeouts",
    "ParameterError",
    "decode_value",
    "encode_value",
]

#: MAV_PARAM_TYPE: the integer types, and whether each is signed
_INTEGER_TYPES = {1: False, 2: True, 3: False, 4: True, 5: False, 6: True}
#: MAV_PARAM_TYPE_REAL32
REAL32 = 9
#: PARAM_SET rounds before a read-back that keeps showing the old value is a refusal
SET_ROUNDS = 2


@dataclass(frozen=True)
class ParamTimeouts:
    """How long to wait for each PARAM_VALUE and how often to ask again."""

    reply_s: float = 1.5
    retries: int = 5

    def __post_init__(self) -> None:
        if not (math.isfinite(self.reply_s) and self.reply_s > 0.0):
            raise ValueError(f"reply_s must be positive, got {self.reply_s!r}")
        if self.retries < 0:
            raise ValueError(f"retries must be >= 0, got {self.retries!r}")


@dataclass(frozen=True)
class ParamRequest:
    """A parameter a mission relies on, in the firmware's own name and unit: the vehicle's
    value is kept when it lies within ``at_least`` .. ``at_most`` (a bound left None is
    open; both None: it must equal ``value``), else it is set to ``value``."""

    name: str
    value: float
    at_least: float | None = None
    at_most: float | None = None

    def __post_init__(self) -> None:
        if not (1 <= len(self.name) <= 16 and self.name.isascii()):
            raise ValueError(f"parameter name {self.name!r} must be 1..16 ASCII characters")
        for bound in (self.value, self.at_least, self.at_most):
            if bound is not None and not math.isfinite(bound):
                raise ValueError(f"{self.name}: values must be finite")
        if not self.accepts(self.value):
            raise ValueError(f"{self.name}: {self.value:g} is outside its own bounds")

    def needed(self) -> str:
        """What the mission needs, in words: ``23000``, ``23000..24800``, ``23000 or more``."""
        if self.at_least is None and self.at_most is None:
            return _num(self.value)
        if self.at_least is not None and self.at_most is not None:
            if same_value(self.at_least, self.at_most):
                return _num(self.at_least)
            return f"{_num(self.at_least)}..{_num(self.at_most)}"
        if self.at_least is not None:
            return f"{_num(self.at_least)} or more"
        return f"{_num(self.at_most)} or less"

    def accepts(self, current: float) -> bool:
        """Is ``current`` a value the mission can fly with?"""
        if self.at_least is None and self.at_most is None:
            return same_value(current, self.value)
        low_ok = self.at_least is None or current >= self.at_least - _tolerance(self.at_least)
        high_ok = self.at_most is None or current <= self.at_most + _tolerance(self.at_most)
        return low_ok and high_ok


def _tolerance(value: float) -> float:
    """What a float32 round trip may change ``value`` by."""
    return max(1e-6, abs(value) * 1e-6)


def same_value(a: float, b: float) -> bool:
    """Equal as a float32 parameter holds them."""
    return abs(a - b) <= _tolerance(max(abs(a), abs(b)))


def encode_value(value: float, param_type: int, *, bytewise: bool) -> float:
    """``value`` as PARAM_SET's float field carries it for ``param_type``: integer types as
    the int's bytes (``bytewise``, PX4) or cast to float (ArduPilot)."""
    if param_type not in _INTEGER_TYPES:
        return float(value)
    number = int(round(value))
    if not bytewise:
        return float(number)
    fmt = "<i" if _INTEGER_TYPES[param_type] else "<I"
    return float(struct.unpack("<f", struct.pack(fmt, number))[0])


def decode_value(wire: float, param_type: int, *, bytewise: bool) -> float:
    """PARAM_VALUE's float field as the parameter's value (see :func:`encode_value`)."""
    if param_type not in _INTEGER_TYPES or not bytewise:
        return float(wire)
    fmt = "<i" if _INTEGER_TYPES[param_type] else "<I"
    return float(struct.unpack(fmt, struct.pack("<f", wire))[0])


class ParamStatus(enum.Enum):
    KEPT = "kept"  # already a value the mission accepts
    CHANGED = "changed"  # set, and read back as set
    REFUSED = "refused"  # set, and read back as something else
    UNANSWERED = "unanswered"  # no PARAM_VALUE for it after every retry
    DIFFERS = "differs"  # read only: the vehicle holds a value the mission does not accept

    @property
    def ok(self) -> bool:
        return self in (ParamStatus.KEPT, ParamStatus.CHANGED)


@dataclass(frozen=True)
class ParamResult:
    """What happened to one parameter: its value before (``old``) and after (``new``; None
    where unknown), in the firmware's unit."""

    name: str
    status: ParamStatus
    old: float | None = None
    new: float | None = None
    step: str = ""
    statustext: str | None = None
    #: what the mission needs (:meth:`ParamRequest.needed`), for the messages
    needed: str = ""

    @property
    def ok(self) -> bool:
        return self.status.ok

    @property
    def interrupted(self) -> bool:
        return False

    @property
    def reason(self) -> ParamStatus | None:
        """Why the vehicle does not hold what the mission needs
        (:class:`~uavplan.outcome.Ended`); None: it does."""
        return None if self.ok else self.status

    @property
    def message(self) -> str:
        return self.describe()

    def describe(self) -> str:
        """One phrase: ``RTL_ALT 1500 → 4500``, ``FENCE_ENABLE 1 (kept)``, or the failure."""
        if self.status is ParamStatus.CHANGED:
            return f"{self.name} {_num(self.old)} → {_num(self.new)}"
        if self.status is ParamStatus.KEPT:
            return f"{self.name} {_num(self.old)} (kept)"
        if self.status is ParamStatus.DIFFERS:
            return (
                f"{self.name} is {_num(self.old)} on the vehicle, the mission needs {self.needed}"
            )
        said = f' [vehicle: "{self.statustext}"]' if self.statustext else ""
        if self.status is ParamStatus.REFUSED:
            return (
                f"{self.name}: the vehicle refused {_num(self.new)} and kept {_num(self.old)}{said}"
            )
        return (
            f"{self.name}: no PARAM_VALUE answered {self.step} (the vehicle does not know "
            f"{self.name}, or the link lost every reply){said}"
        )


def _num(value: float | None) -> str:
    return "?" if value is None else f"{value:g}"


class _Step(enum.Enum):
    READ = "PARAM_REQUEST_READ"
    SET = "PARAM_SET"
    VERIFY = "PARAM_REQUEST_READ (read-back)"


class ParamMachine:
    """Make the vehicle hold ``requests`` (see the module docstring). ``target``: the
    vehicle's (system, component); ``bytewise``: its integer encoding. ``finished`` once
    every request has a :class:`ParamResult` in ``results``, in order."""

    def __init__(
        self,
        target: tuple[int, int],
        requests: Sequence[ParamRequest],
        *,
        bytewise: bool,
        timeouts: ParamTimeouts | None = None,
        set_values: bool = True,
    ) -> None:
        self.target = target
        self.requests = tuple(requests)
        self.bytewise = bytewise
        self.set_values = set_values
        self.timeouts = timeouts or ParamTimeouts()
        self.results: list[ParamResult] = []
        self.deadline = math.inf
        self.sent = 0
        self._index = 0
        self._step = _Step.READ
        self._tries = 0
        self._old: float | None = None
        self._type = REAL32
        self._text: str | None = None
        self._set_rounds = 0

    @property
    def finished(self) -> bool:
        return self._index >= len(self.requests)

    @property
    def _request(self) -> ParamRequest:
        return self.requests[self._index]

    # -- events ---------------------------------------------------------------------------
    def start(self, now: float) -> list[Message]:
        return self._begin(now)

    def on_message(self, message: Message, now: float) -> list[Message]:
        if self.finished:
            return []
        request = self._request
        if isinstance(message, StatusText):
            if request.name in message.text:
                self._text = message.text
            return []
        if not isinstance(message, ParamValue) or message.param_id != request.name:
            return []  # another parameter's value (a broadcast, a late reply): not ours
        value = decode_value(message.param_value, message.param_type, bytewise=self.bytewise)
        if self._step is _Step.READ:
            self._old, self._type = value, message.param_type
            needed = request.needed()
            if request.accepts(value):
                result = ParamResult(request.name, ParamStatus.KEPT, value, value, needed=needed)
                return self._done(result, now)
            if not self.set_values:
                result = ParamResult(request.name, ParamStatus.DIFFERS, value, None, needed=needed)
                return self._done(result, now)
            return self._go(_Step.SET, now)
        if self._step is _Step.SET:
            return self._go(_Step.VERIFY, now)
        if same_value(value, self._wanted()):
            result = ParamResult(
                request.name, ParamStatus.CHANGED, self._old, value, needed=request.needed()
            )
            return self._done(result, now)
        if self._set_rounds < SET_ROUNDS:
            # the read-back shows the old value: the PARAM_SET may have been lost after a
            # late reply to an earlier read was taken for its answer; set it once more
            return self._go(_Step.SET, now)
        result = ParamResult(
            request.name,
            ParamStatus.REFUSED,
            value,
            self._wanted(),
            _Step.SET.value,
            self._text,
            request.needed(),
        )
        return self._done(result, now)

    def on_timeout(self, now: float) -> list[Message]:
        if self.finished or now < self.deadline:
            return []
        if self._tries > self.timeouts.retries:
            request = self._request
            result = ParamResult(
                request.name,
                ParamStatus.UNANSWERED,
                self._old,
                None,
                f"{1 + self.timeouts.retries} × {self._step.value}",
                self._text,
                request.needed(),
            )
            return self._done(result, now)
        return self._send(now)

    # -- steps ----------------------------------------------------------------------------
    def _wanted(self) -> float:
        """The value asked for, as the vehicle's type holds it."""
        value = self._request.value
        return float(round(value)) if self._type in _INTEGER_TYPES else value

    def _begin(self, now: float) -> list[Message]:
        if self.finished:
            self.deadline = math.inf
            return []
        self._old, self._type, self._text = None, REAL32, None
        self._set_rounds = 0
        return self._go(_Step.READ, now)

    def _go(self, step: _Step, now: float) -> list[Message]:
        self._step, self._tries = step, 0
        if step is _Step.SET:
            self._set_rounds += 1
        return self._send(now)

    def _send(self, now: float) -> list[Message]:
        self._tries += 1
        self.sent += 1
        self.deadline = now + self.timeouts.reply_s
        system, component = self.target
        name = self._request.name
        if self._step is _Step.SET:
            wire = encode_value(self._wanted(), self._type, bytewise=self.bytewise)
            return [ParamSet(system, component, name, wire, self._type)]
        return [ParamRequestRead(system, component, name, -1)]

    def _done(self, result: ParamResult, now: float) -> list[Message]:
        self.results.append(result)
        self._index += 1
        return self._begin(now)


class ParameterError(LinkError):
    """The vehicle did not end up holding every parameter the mission relies on (exit 4);
    ``results`` says what happened to each."""

    def __init__(self, results: Sequence[ParamResult]) -> None:
        self.results = tuple(results)
        failed = [r for r in self.results if not r.ok]
        done = [r for r in self.results if r.ok]
        message = "; ".join(r.describe() for r in failed)
        if done:
            message += " (" + ", ".join(r.describe() for r in done) + ")"
        super().__init__(message, step="set parameters")


#: the clock a client reads: seconds, monotonic
Clock = Callable[[], float]


class ParamClient:
    """Drives a :class:`ParamMachine` over ``link``: the parameter protocol's I/O loop."""

    def __init__(
        self,
        link: VehicleLink,
        timeouts: ParamTimeouts | None = None,
        *,
        clock: Clock = time.monotonic,
    ) -> None:
        self.link = link
        self.timeouts = timeouts or ParamTimeouts()
        self.clock = clock

    @property
    def bytewise(self) -> bool:
        """Does the vehicle send integer parameters bytewise? Its AUTOPILOT_VERSION says so;
        without one, PX4 does and ArduPilot does not."""
        caps = self.link.capabilities
        if caps is not None and caps & Capability.PARAM_ENCODE_BYTEWISE:
            return True
        if caps is not None and caps & Capability.PARAM_ENCODE_C_CAST:
            return False
        from uavplan.mission.items import Autopilot

        return self.link.vehicle.autopilot is Autopilot.PX4

    def apply(self, requests: Sequence[ParamRequest]) -> list[ParamResult]:
        """Make the vehicle hold ``requests``; what happened to each (nothing raised for a
        refusal: see :meth:`ParamResult.ok`, :class:`ParameterError`)."""
        return self._run(requests, set_values=True)

    def read(self, requests: Sequence[ParamRequest]) -> list[ParamResult]:
        """Read the vehicle's value of each of ``requests``, changing nothing: *kept* where
        the request accepts it, *differs* where not, *unanswered* where no PARAM_VALUE came."""
        return self._run(requests, set_values=False)

    def _run(self, requests: Sequence[ParamRequest], *, set_values: bool) -> list[ParamResult]:
        vehicle = self.link.vehicle
        machine = ParamMachine(
            (vehicle.system_id, vehicle.component_id),
            requests,
            bytewise=self.bytewise,
            timeouts=self.timeouts,
            set_values=set_values,
        )
        self._send_all(machine.start(self.clock()))
        while not machine.finished:
            received = self.link.recv(max(0.0, machine.deadline - self.clock()))
            now = self.clock()
            if received is not None:
                self._send_all(machine.on_message(received.message, now))
            elif now >= machine.deadline:
                self._send_all(machine.on_timeout(now))
        return list(machine.results)

    def _send_all(self, messages: list[Message]) -> None:
        for message in messages:
            self.link.send(message)
