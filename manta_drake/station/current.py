"""The water's current as a function of time: a schedule of keyed velocities.

A pool's current is not steady: a pump switched on, a gust through an inlet. The
scenario gives it as keys ``CurrentPoint(time, velocity)``; between two keys the
current is linear in time, before the first key it is the first key's velocity and
after the last the last's. With no keys the current is one constant.

``current_at`` is the pure maths (the tests check it against hand-computed values);
``CurrentSchedule`` holds a checked schedule for the systems that read the current
(``HydrodynamicForces``, ``FlowVelocitySensor``), and ``check_current_schedule`` is the
check, with messages naming the scenario's fields.
"""

import bisect
import dataclasses as dc
import math
import numbers

import numpy as np

from manta_drake.config_io import ScenarioError

MAX_TIME = 3600.0  # s: a key beyond an hour is a units mistake (ms for s), not a run
# m/s: the bound on the water's speed (a pool, not a river), the scenario's and the Systems'
# that read a schedule.
MAX_SPEED = 1.0


@dc.dataclass
class CurrentPoint:
    """One key of the schedule: the water's velocity at ``time``.

    Plain types only, so Drake's ``yaml_load_typed`` reads a list of these.
    """

    time: float = 0.0  # s, simulation time
    velocity: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])  # m/s, world


def current_at(t: float, times, velocities, out=None) -> np.ndarray:
    """The current at time ``t``: piecewise linear between the keys, constant outside.

    Args:
        t: the time [s].
        times: (n,) key times [s], n >= 1, non-decreasing. Two equal times make a step:
            at that time and after it the later key's velocity holds.
        velocities: (n, 3) the water's velocity at each key [m/s], world frame.
        out: an optional (3,) float array to write the result into (no allocation).

    Returns:
        (3,) the velocity [m/s] (``out`` when given).
    """
    if out is None:
        out = np.empty(3)
    n = len(times)
    # The last key at or before t: times[i] <= t < times[i + 1], so the interval is never
    # empty and the interpolation never divides by zero.
    i = bisect.bisect_right(times, t) - 1
    if i < 0:
        v = velocities[0]
        out[0], out[1], out[2] = v[0], v[1], v[2]
    elif i >= n - 1:
        v = velocities[n - 1]
        out[0], out[1], out[2] = v[0], v[1], v[2]
    else:
        t0, t1 = times[i], times[i + 1]
        s = (t - t0) / (t1 - t0)
        a, b = velocities[i], velocities[i + 1]
        out[0] = a[0] + s * (b[0] - a[0])
        out[1] = a[1] + s * (b[1] - a[1])
        out[2] = a[2] + s * (b[2] - a[2])
    return out


def _check_velocity(field: str, value) -> None:
    """3 finite numbers of magnitude <= MAX_SPEED (ScenarioError naming ``field``)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if (
        not isinstance(value, (list, tuple))
        or len(value) != 3
        or not all(
            isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)
            for v in value
        )
    ):
        raise ScenarioError(f"{field}: {value!r} must be 3 finite numbers (m/s, world frame)")
    speed = math.sqrt(sum(float(v) ** 2 for v in value))
    if speed > MAX_SPEED:
        raise ScenarioError(
            f"{field}: {value!r} has magnitude {speed:.3g} m/s, outside the "
            f"allowed range [0, {MAX_SPEED:g}] m/s"
        )


def check_current_schedule(
    points, constant, field: str = "water.current_schedule", constant_field: str = "water.current"
) -> None:
    """Checks a schedule; ScenarioError (a ValueError), one line naming ``<field>[i].time`` or
    ``<field>[i].velocity`` (or ``constant_field``) and the allowed range.

    Args:
        points: a list of CurrentPoint (possibly empty).
        constant: the current without keys, (3,) [m/s].
        field, constant_field: the names the messages give.

    Rules: each time a finite number in [0, MAX_TIME] s, the times non-decreasing, each
    velocity (and ``constant``) 3 finite numbers of magnitude <= MAX_SPEED m/s.
    """
    _check_velocity(constant_field, constant)
    if not isinstance(points, (list, tuple)):
        raise ScenarioError(f"{field}: expected a list of {{time, velocity}} keys, got {points!r}")
    previous: numbers.Real | float = -math.inf
    for i, point in enumerate(points):
        if not (hasattr(point, "time") and hasattr(point, "velocity")):
            raise ScenarioError(
                f"{field}[{i}]: {point!r} is not a CurrentPoint (a time and a velocity)"
            )
        t = point.time
        if (
            isinstance(t, bool)
            or not isinstance(t, numbers.Real)
            or not (math.isfinite(t) and 0.0 <= float(t) <= MAX_TIME)
        ):
            raise ScenarioError(
                f"{field}[{i}].time: {t!r} is outside the allowed range [0, {MAX_TIME:g}] s"
            )
        if t < previous:
            raise ScenarioError(
                f"{field}[{i}].time: {t!r} is before the previous key's time "
                f"{previous!r} (times must be non-decreasing)"
            )
        previous = t
        _check_velocity(f"{field}[{i}].velocity", point.velocity)


class CurrentSchedule:
    """A checked current schedule: the constant, or the keys when there are any.

    Immutable: the keys are copied and frozen at construction, so a system built from a
    schedule cannot see it change.

    Args:
        constant: (3,) the current when ``points`` is empty [m/s], world frame.
        points: CurrentPoint keys (see ``current_at``); when given they replace
            ``constant``.
        field, constant_field: the names ``check_current_schedule``'s messages give.

    Raises:
        ValueError: one line naming the bad field and its allowed range.
    """

    __slots__ = ("_constant", "_times", "_velocities", "_rows", "_is_constant")
    _constant: np.ndarray
    _times: np.ndarray
    _velocities: np.ndarray
    _rows: tuple[tuple[float, ...], tuple[tuple[float, ...], ...]]
    _is_constant: bool

    def __init__(
        self,
        constant=(0.0, 0.0, 0.0),
        points=(),
        *,
        field: str = "water.current_schedule",
        constant_field: str = "water.current",
    ):
        points = list(points)
        check_current_schedule(points, constant, field, constant_field)
        constant = np.array(constant, dtype=float)
        if points:
            times = np.array([float(p.time) for p in points])
            velocities = np.array([[float(v) for v in p.velocity] for p in points])
        else:
            times, velocities = np.zeros(1), constant[None].copy()
        for array in (constant, times, velocities):
            array.setflags(write=False)
        object.__setattr__(self, "_constant", constant)
        object.__setattr__(self, "_times", times)
        object.__setattr__(self, "_velocities", velocities)
        # Plain Python copies for ``at``: bisect and scalar indexing on tuples cost a
        # fraction of numpy's per-call overhead, and ``at`` runs at every force evaluation.
        object.__setattr__(
            self, "_rows", (tuple(times.tolist()), tuple(tuple(v) for v in velocities.tolist()))
        )
        object.__setattr__(self, "_is_constant", bool(np.all(velocities == velocities[0])))

    def __setattr__(self, name, value):
        raise AttributeError(f"CurrentSchedule is immutable: cannot set {name!r}")

    @property
    def constant(self) -> np.ndarray:
        """The constant given at construction (3,) [m/s] (unused when there are keys)."""
        return self._constant

    @property
    def times(self) -> np.ndarray:
        """The key times (n,) [s]; with no keys, [0]."""
        return self._times

    @property
    def velocities(self) -> np.ndarray:
        """The key velocities (n, 3) [m/s]; with no keys, [constant]."""
        return self._velocities

    @property
    def is_constant(self) -> bool:
        """True when the current is the same at every time (no keys, or all keys equal)."""
        return self._is_constant

    def at(self, t: float, out=None) -> np.ndarray:
        """The current at time ``t`` [s], (3,) [m/s] (written into ``out`` if given)."""
        times, rows = self._rows
        return current_at(t, times, rows, out)

    def __repr__(self) -> str:
        if len(self._times) == 1 and np.array_equal(self._velocities[0], self._constant):
            return f"CurrentSchedule(constant={self._constant.tolist()})"
        keys = ", ".join(f"({t:g}, {v.tolist()})" for t, v in zip(self._times, self._velocities))
        return f"CurrentSchedule(keys=[{keys}])"
