"""A file's view times in seconds, from the unit they were written in (``data.times_unit``), and the
gantry rotation they imply, checked against what scanners do: a clinical gantry turns in 0.2–0.5 s
and a lab scanner in up to minutes, so times in milliseconds read as seconds (a 0.25 s rotation at
250 s) look like a slow lab scan (a warning) and seconds read as milliseconds (0.25 ms) like no
scanner at all (an error)."""

from __future__ import annotations

import math

import numpy as np

from nct.errors import InputError

TIMES_UNITS = {"s": 1.0, "ms": 1e-3}  # data.times_unit -> seconds per unit
SLOWEST_S = 60.0  # a rotation slower than a minute: a lab scanner's, or times in ms read as s (warned)
FASTEST_S = 1e-3  # a rotation faster than a millisecond: no scanner's (refused)


def rotation_time(angles: np.ndarray, times: np.ndarray) -> float:
    """Seconds per gantry turn: the scan's duration over the turns its angles [V] (radians) span;
    ``times`` [V] in seconds."""
    return float(np.ptp(times)) * 2 * math.pi / float(np.ptp(angles))


def seconds_per(unit: str | None) -> float:
    """Seconds in one ``unit`` (a key of TIMES_UNITS; None: seconds)."""
    return TIMES_UNITS[unit or "s"]


def in_seconds(angles: np.ndarray, times: np.ndarray, unit: str | None, source: str) -> np.ndarray:
    """``times`` [V] in seconds, from ``unit`` (a key of TIMES_UNITS; None: seconds); `InputError`
    naming ``source``'s ``times`` and ``data.times_unit`` when they put a turn under FASTEST_S."""
    seconds = times * seconds_per(unit)
    turn = rotation_time(angles, seconds)
    if turn < FASTEST_S:
        raise InputError(f"{source}: key 'times': a gantry turn every {turn * 1e3:.3g} ms with the times in "
                         f"{_unit_name(unit)}, faster than any scanner (1 ms): set data.times_unit (s or ms) to the "
                         "unit the file's times are in")
    return seconds


def slow_rotation_warning(angles: np.ndarray, times: np.ndarray, unit: str | None) -> list[str]:
    """status.json's line when ``times`` [V] (s) put a turn over SLOWEST_S and no unit was stated
    (``unit`` None): lab scanners turn so slowly, and so do milliseconds read as seconds."""
    turn = rotation_time(angles, times)
    if unit is not None or turn <= SLOWEST_S:
        return []
    return [f"times: a gantry turn every {turn:.4g} s with the times read as seconds (data.times_unit unset), "
            f"slower than a minute: if the file's times are in milliseconds, set data.times_unit=ms "
            "(data.times_unit=s confirms seconds and silences this)"]


def _unit_name(unit: str | None) -> str:
    return "seconds (data.times_unit unset)" if unit is None else f"{unit} (data.times_unit={unit})"
