"""Energy estimation from the battery monitor: a 0-1 estimate of low energy.

The monitor (``battery``, 3) gives [state of charge in [0, 1], terminal voltage V,
current A]. The state of charge is low-passed with the sampled first-order lag of
``memberships.low_pass_step`` (time constant ``time_constant``) and the estimate is the
falling ramp membership (the piecewise-linear kind of Eq. (9)) of the filtered charge::

    energy_hat = 1 - clip((soc_hat - soc_low) / (soc_high - soc_low), 0, 1)

1 at or below ``soc_low`` (low energy: a behaviour that saves power should take over), 0
at or above ``soc_high``, linear between. The voltage and the current are not used: the
state of charge is the monitor's own coulomb count, which the load's voltage sag (large
while the servos push, gone when they rest) would only disturb.
"""

import dataclasses as dc

from manta_drake.control.filtered_estimator import FilteredEstimator
from manta_drake.control.memberships import check_ramp, ramp_membership

BATTERY_SIZE = 3  # [state of charge, terminal voltage V, current A]


@dc.dataclass
class EnergyEstimatorParams:
    """The state-of-charge thresholds of ``energy_hat`` and the filter's time constant [s]."""

    soc_low: float = 0.2  # energy_hat = 1 at or below this state of charge
    soc_high: float = 0.4  # energy_hat = 0 at or above this state of charge
    time_constant: float = 5.0  # of the state-of-charge low-pass (0: no filter)

    def validate(self, where: str = "") -> "EnergyEstimatorParams":
        """Checks every field's range; ScenarioError names the field (``<where>.<field>``)
        and the allowed range."""
        check_ramp(self, "soc_low", "soc_high", 1.0, time_constant_max=1000.0, where=where)
        return self


def energy_membership(soc, params: EnergyEstimatorParams):
    """``energy_hat`` of states of charge ``soc``: 1 - the ramp from soc_low to soc_high."""
    return 1.0 - ramp_membership(soc, params.soc_low, params.soc_high)


class EnergyEstimator(FilteredEstimator):
    """The filtered state of charge and its low-energy membership.

    .. pydrake_system::

        name: EnergyEstimator
        input_ports:
        - battery
        output_ports:
        - energy_hat
        - soc_hat

    * ``battery`` (3): [state of charge, terminal voltage V, current A]; may be NaN.
    * ``energy_hat`` (1): in [0, 1], 1 - the ramp membership of ``soc_hat`` between
      ``soc_low`` and ``soc_high`` (1: low energy).
    * ``soc_hat`` (1): the filtered state of charge.

    Discrete state (2): the filtered state of charge and whether it has seen a finite
    reading (default: [1, 0], full and unseeded, so nothing reads low energy before the
    first reading). Updated every ``period`` seconds from t = 0 with ``alpha = 1 -
    exp(-period / time_constant)``; it starts at its first finite reading (an initialization
    event reads the input when a Simulator initializes, so a consumer's first update already
    sees it) and holds its value while its input is NaN or infinite. The outputs depend on
    the state only.

    Args:
        params: ``EnergyEstimatorParams`` (None: the defaults).
        period: the update period [s], in (0, 10] (the battery monitor's sample period).

    Raises:
        ValueError: naming the invalid field and its allowed range.
    """

    def __init__(self, params: EnergyEstimatorParams | None = None, period: float = 0.1):
        params = (params if params is not None else EnergyEstimatorParams()).validate()
        super().__init__(
            "battery",
            BATTERY_SIZE,
            [0],
            period,
            params.time_constant,
            initial=[1.0],
            max_period=10.0,
        )
        self.params = params
        self.DeclareEstimateOutputPort(
            "energy_hat", 1, lambda soc: energy_membership(soc[0], params)
        )
        self.DeclareEstimateOutputPort("soc_hat", 1, lambda soc: soc[0])
