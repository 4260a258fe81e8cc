"""The shared maths of the controller's 0-1 estimators (posture, flow, energy, altitude).

Two plain functions, both vectorised over numpy arrays, and the check of their parameters
(``check_ramp``):

* ``ramp_membership``: the piecewise-linear membership of the kind Eq. (9)'s layers use,
  0 at or below ``low``, 1 at or above ``high`` and linear between::

      mu(x) = clip((x - low) / (high - low), 0, 1)

* ``low_pass_step``: one update of a first-order lag tau dy/dt = x - y sampled every
  ``period`` seconds with the input held between samples (the exact zero-order-hold
  discretisation)::

      y_{k+1} = y_k + alpha (x_k - y_k),   alpha = 1 - exp(-period / tau)

  so a step of the input from a to b at a sample reads, ``j`` samples later (the step's
  own sample counted), y = b + (a - b) exp(-j period / tau): the continuous lag at the
  sample times, with no discretisation error there. tau = 0 is no filter (alpha = 1).
  Each channel starts at its first finite sample (a filter started at zero would report
  a false tilt, a false heading or an empty battery until it caught up) and holds its last
  value while its input is NaN or infinite (sensor dropout). Angles are filtered on the
  circle: the step is taken along the wrapped difference and the result wrapped to
  (-pi, pi], so a heading crossing +-pi does not swing the long way round.
"""

import numpy as np

from manta_drake.config_io import check_in_range, field_name
from manta_drake.control.transition import wrap


def check_ramp(
    params,
    low: str,
    high: str,
    top: float,
    unit: str = "",
    time_constant_max: float = 100.0,
    where: str = "",
) -> None:
    """Checks an estimator's ramp and lag parameters: ``params.<low>`` in [0, top),
    ``params.<high>`` in (low, top] and ``params.time_constant`` in [0, time_constant_max];
    ScenarioError names the field (``<where>.<field>``, the field alone without ``where``)
    and the allowed range (``unit`` after it, e.g. `` m/s``)."""
    lo = getattr(params, low)
    check_in_range(field_name(where, low), lo, 0.0, top, f"[0, {top:g}){unit}", open_high=True)
    check_in_range(
        field_name(where, high),
        getattr(params, high),
        lo,
        top,
        f"({low} = {lo:g}, {top:g}]{unit}",
        open_low=True,
    )
    check_in_range(
        field_name(where, "time_constant"),
        params.time_constant,
        0.0,
        time_constant_max,
        f"[0, {time_constant_max:g}] s (0: no filter)",
    )


def ramp_membership(x, low: float, high: float):
    """The membership ``clip((x - low) / (high - low), 0, 1)`` of ``x`` (a NaN stays NaN).

    Raises:
        ValueError: unless ``low < high`` (both finite).
    """
    if not (np.isfinite(low) and np.isfinite(high) and low < high):
        raise ValueError(
            f"ramp_membership: low = {low!r} must be below high = {high!r}, both finite"
        )
    return np.clip((np.asarray(x, dtype=float) - low) / (high - low), 0.0, 1.0)


def lag_coefficient(period: float, time_constant: float) -> float:
    """alpha = 1 - exp(-period / time_constant) of the sampled first-order lag (1 for
    time_constant = 0: no filter)."""
    if time_constant == 0.0:
        return 1.0
    return float(-np.expm1(-period / time_constant))


def low_pass_step(value, seeded, sample, alpha: float, circular=False) -> tuple:
    """One sampled update of first-order lags, channel by channel.

    Args:
        value: the filtered values y_k, shape (n,).
        seeded: (n,) booleans (or 0/1): has the channel seen a finite sample yet.
        sample: the inputs x_k, shape (n,); NaN or infinite entries hold their channel.
        alpha: ``lag_coefficient(period, time_constant)``.
        circular: a boolean or (n,) booleans: the channels that are angles [rad].

    Returns:
        (y_{k+1} (n,) floats, seeded (n,) booleans).
    """
    value = np.asarray(value, dtype=float)
    seeded = np.asarray(seeded, dtype=bool)
    sample = np.asarray(sample, dtype=float)
    circular = np.broadcast_to(np.asarray(circular, dtype=bool), value.shape)
    finite = np.isfinite(sample)
    x = np.where(finite, sample, value)  # a held channel sees its own value: no step
    x = np.where(circular, wrap(x), x)
    difference = np.where(circular, wrap(x - value), x - value)
    stepped = value + alpha * difference
    stepped = np.where(circular, wrap(stepped), stepped)
    new = np.where(finite, np.where(seeded, stepped, x), value)
    return new, seeded | finite
