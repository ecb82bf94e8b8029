"""The one widen-until-safe loop (:func:`uavplan.flown_safe.widened_until_flown_safe`) that
routes, reroutes, the planned return and surveys all go through: how far the margin grows,
when it stops, and what it says."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from uavplan.flown_safe import MAX_REPLANS, PAD_STEP_M, VOLUME_PAD_M, widened_until_flown_safe

MARGIN = 10.0


def check(clearance_m: float, *, outside: int | None = None) -> Any:
    """A track check that found ``clearance_m`` against the margin (duck-typed)."""
    ok = outside is None and clearance_m >= MARGIN
    return SimpleNamespace(
        ok=ok,
        outside=outside,
        required_m=MARGIN,
        min_clearance_m=clearance_m,
        problem=lambda: None if ok else f"{clearance_m:.2f} m from an obstacle",
    )


def run(clearances: list[float], **kwargs: Any):  # type: ignore[no-untyped-def]
    """The loop over attempts whose flights keep ``clearances[k]`` (attempt k, pad made)."""
    made: list[float] = []

    def again(pad: float) -> tuple[int, float]:
        made.append(pad)
        return len(made), pad

    ended = widened_until_flown_safe(
        (0, 0.0),
        lambda value: check(clearances[value[0]]),
        kwargs.pop("again", again),
        stopped=kwargs.pop("stopped", lambda value: False),
        noted=lambda why, pad: f"{why}; again {pad:.2f} m wider",
        exhausted=lambda pad: f"gave up at {pad:.2f} m",
        **kwargs,
    )
    return ended, made


def test_a_flight_that_keeps_the_margin_is_taken_as_it_is() -> None:
    ended, made = run([10.5])
    assert (ended.value, ended.pad_m, ended.notes, ended.gave_up) == ((0, 0.0), 0.0, (), "")
    assert made == [] and not ended.stopped


def test_the_margin_grows_by_what_the_flight_lacked_plus_a_step_each_time() -> None:
    ended, made = run([9.0, 9.5, 10.2])
    first = 0.0 + (MARGIN - 9.0) + PAD_STEP_M
    second = first + (MARGIN - 9.5) + PAD_STEP_M
    assert made == pytest.approx([first, second])
    assert ended.value == (2, pytest.approx(second)) and ended.pad_m == pytest.approx(second)
    assert ended.notes == (
        f"9.00 m from an obstacle; again {first:.2f} m wider",
        f"9.50 m from an obstacle; again {second:.2f} m wider",
    )
    assert ended.gave_up == ""


def test_it_gives_up_after_the_last_widening_and_says_so() -> None:
    ended, made = run([9.0] * (MAX_REPLANS + 1))
    assert len(made) == MAX_REPLANS  # planned again at most MAX_REPLANS times
    assert ended.value[0] == MAX_REPLANS
    assert ended.gave_up == f"gave up at {ended.pad_m:.2f} m"
    assert len(ended.notes) == MAX_REPLANS


def test_a_flight_outside_the_volume_widens_by_the_volume_pad() -> None:
    made: list[float] = []

    def again(pad: float) -> int:
        made.append(pad)
        return 1

    ended = widened_until_flown_safe(
        0,
        lambda value: check(12.0, outside=3) if value == 0 else check(12.0),
        again,
        stopped=lambda value: False,
        noted=lambda why, pad: why,
        exhausted=lambda pad: "",
        pad_m=0.5,
    )
    assert made == [pytest.approx(0.5 + VOLUME_PAD_M + PAD_STEP_M)]
    assert ended.value == 1


def test_no_wider_margin_to_be_had_ends_with_the_reason_and_the_last_flight() -> None:
    ended, _ = run([9.0, 9.0], again=lambda pad: f"no route keeps {pad:.2f} m more")
    assert ended.value == (0, 0.0) and ended.pad_m == 0.0
    assert ended.gave_up == f"no route keeps {MARGIN - 9.0 + PAD_STEP_M:.2f} m more"
    assert ended.notes == ()


def test_an_interrupted_attempt_comes_back_as_it_is() -> None:
    ended, made = run([9.0, 9.0], stopped=lambda value: value[0] == 1)
    assert ended.stopped and ended.value[0] == 1 and ended.gave_up == ""
    assert len(made) == 1
