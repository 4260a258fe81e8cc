"""The two-layer CPG of section 3.1: 16 coupled oscillators (Eq. 5).

Oscillator i = 4k + j drives joint j (yaw, roll1, pitch, roll2) of leg-fin k
(fl, fr, rl, rr), the plant's joint order. Each has continuous states phase phi,
amplitude r and its rate, bias chi and its rate::

    dphi_i/dt  = 2 pi f + sum_j w_ij sin(phi_j - phi_i - dphi_ij)
    d2r_i/dt2  = a (a/4 (R_i - r_i) - dr_i/dt)
    d2chi_i/dt2 = b (b/4 (X_i - chi_i) - dchi_i/dt)
    theta_i    = chi_i + r_i sin(phi_i)

Coupling (Fig. 1b):

* layer 1, SCS: a chain inside each leg-fin, joint j <-> joint j+1, with
  ``phi_{j+1} - phi_j -> Phi[k, j]`` (so dphi_{i,i+1} = Phi[k, j] and
  dphi_{i+1,i} = -Phi[k, j]); weight ``chain_weight``;
* layer 2, FCS: all-to-all among the four base (yaw) oscillators 4k, with
  ``phi_{4l} - phi_{4k} -> Phi'[k, l]``; weight ``fcs_weight``.

Defaults and why:

* f = 0.5 Hz (``gaits.DEFAULT_FREQUENCY_HZ``), shared by every gait;
* a = b = 20 1/s: the amplitude and bias equations are critically damped with
  double pole a/2 = 10 1/s, so a step settles to 2 % in 5.83 / 10 = 0.58 s
  without overshoot (the paper's "about 0.5 s");
* chain_weight = fcs_weight = 4 rad/s: the slowest phase-locking mode of the
  coupled graph decays at ~1.5 1/s (lock within ~3 s from any start) while a
  swing of the biases by the transition system (a few seconds) is followed
  closely; the fastest mode (~16 1/s) stays far inside the stability region of
  explicit Euler / RK2 at 1 ms.
"""

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from manta_drake.config_io import Range
from manta_drake.control import cpg_kernels as K
from manta_drake.control.gaits import DEFAULT_FREQUENCY_HZ, phase_lock_targets
from manta_drake.model.robot_params import (
    GAIT_SHAPE,
    JOINTS_PER_LEG,
    NUM_CPG_PARAMS,
    NUM_JOINTS,
    NUM_LEGS,
)

NUM_OSC = NUM_JOINTS  # one oscillator per joint

# The allowed ranges of the CPG's parameters, the constructor's and the scenario's cpg.*
# fields alike: beyond 5 Hz a 1 ms step no longer resolves the oscillation, beyond 200 1/s
# the RK2 step is unstable.
FREQUENCY_HZ = Range(0.0, 5.0, "Hz", open_low=True)
COUPLING_WEIGHT = Range(0.0, 100.0, "rad/s")  # chain_weight and fcs_weight
GAIN = Range(0.0, 200.0, "1/s", open_low=True)  # a and b
NUM_PARAMS = NUM_CPG_PARAMS
NUM_STATES = 5 * NUM_OSC  # phi, r, dr, chi, dchi

# Index sets of the coupled directed pairs (i <- j): dphi_i gets w sin(phi_j - phi_i - b_ij).
_chain_i = np.array(
    [JOINTS_PER_LEG * k + j for k in range(NUM_LEGS) for j in range(JOINTS_PER_LEG - 1)]
)
_chain_j = _chain_i + 1
_fcs_k, _fcs_l = np.array([(k, m) for k in range(NUM_LEGS) for m in range(NUM_LEGS) if k != m]).T
PAIR_I = np.concatenate([_chain_i, _chain_j, JOINTS_PER_LEG * _fcs_k])  # receiving oscillator
PAIR_J = np.concatenate([_chain_j, _chain_i, JOINTS_PER_LEG * _fcs_l])  # sending oscillator
_CHAIN_PHI_INDEX = _chain_i  # into Phi.ravel(): Phi[k, j] biases joint j -> j + 1
_FCS_INDEX = NUM_LEGS * _fcs_k + _fcs_l  # into Phi_prime.ravel()
# Slices of the parameter vector [R, X, Phi, Phi'].
_R, _X, _PHI, _PHI_PRIME = (slice(i * NUM_OSC, (i + 1) * NUM_OSC) for i in range(4))
# The pairs for the compiled kernels: each pair's bias as (index into params, sign), in
# the order of ``pair_biases``: chain biases, their negatives, then the FCS biases.
PAIRS = K.pack_pairs(
    PAIR_I,
    PAIR_J,
    np.concatenate(
        [
            _PHI.start + _CHAIN_PHI_INDEX,
            _PHI.start + _CHAIN_PHI_INDEX,
            _PHI_PRIME.start + _FCS_INDEX,
        ]
    ),
    np.concatenate([np.ones(len(_chain_i)), -np.ones(len(_chain_i)), np.ones(len(_fcs_k))]),
)


def pair_biases(params: np.ndarray) -> np.ndarray:
    """Phase biases dphi_ij of the coupled pairs (PAIR_I, PAIR_J) from the CPG params."""
    Phi = params[_PHI]
    Phi_prime = params[_PHI_PRIME]
    chain = Phi[_CHAIN_PHI_INDEX]
    return np.concatenate([chain, -chain, Phi_prime[_FCS_INDEX]])


def pair_weights(chain_weight: float, fcs_weight: float) -> np.ndarray:
    """Weights w_ij of the coupled pairs, in PAIR_I/PAIR_J order."""
    n_chain = 2 * len(_chain_i)
    return np.concatenate([np.full(n_chain, chain_weight), np.full(len(_fcs_k), fcs_weight)])


def phase_rates(phi, params, frequency_hz, weights) -> np.ndarray:
    """dphi/dt of Eq. (5) for all 16 oscillators."""
    coupling = weights * np.sin(phi[PAIR_J] - phi[PAIR_I] - pair_biases(params))
    return 2.0 * np.pi * frequency_hz + np.bincount(PAIR_I, weights=coupling, minlength=NUM_OSC)


def cpg_derivatives(x, params, frequency_hz, weights, a, b) -> np.ndarray:
    """Time derivative of the CPG state x = [phi, r, dr, chi, dchi] (80) under Eq. (5)."""
    phi, r, dr, chi, dchi = np.asarray(x, dtype=float).reshape(5, NUM_OSC)
    R, X = params[_R], params[_X]
    return np.concatenate(
        [
            phase_rates(phi, params, frequency_hz, weights),
            dr,
            a * (a / 4.0 * (R - r) - dr),
            dchi,
            b * (b / 4.0 * (X - chi) - dchi),
        ]
    )


def joint_angles(x) -> np.ndarray:
    """theta = chi + r sin(phi)."""
    phi, r, _, chi, _ = np.asarray(x, dtype=float).reshape(5, NUM_OSC)
    return chi + r * np.sin(phi)


def joint_rates(x, phi_dot) -> np.ndarray:
    """d theta / dt = dchi + dr sin(phi) + r cos(phi) dphi/dt (exact, from the state)."""
    phi, r, dr, _, dchi = np.asarray(x, dtype=float).reshape(5, NUM_OSC)
    return dchi + dr * np.sin(phi) + r * np.cos(phi) * phi_dot


def locked_phases(params) -> np.ndarray:
    """Phases with every chain at its bias and the bases at the FCS lock (leg 1 base = 0)."""
    params = np.asarray(params, dtype=float)
    base = phase_lock_targets(params[_PHI_PRIME].reshape(GAIT_SHAPE))
    Phi = params[_PHI].reshape(GAIT_SHAPE)
    offsets = np.concatenate([np.zeros((NUM_LEGS, 1)), np.cumsum(Phi[:, :-1], axis=1)], axis=1)
    return (base[:, None] + offsets).ravel()


def initial_state(params, joint_angles) -> np.ndarray:
    """The CPG state that starts ``params`` from rest without a jump: phases at the lock of
    the gait (the exact in-phase start is an unstable equilibrium of couplings with bias
    pi), amplitudes r = 0, biases chi at the robot's initial ``joint_angles``."""
    x = np.zeros((5, NUM_OSC))
    x[0] = locked_phases(params)
    x[3] = np.asarray(joint_angles, dtype=float).reshape(NUM_OSC)
    return x.ravel()


class CpgOscillators(LeafSystem):
    """The two-layer CPG (Eq. 5) with continuous states.

    .. pydrake_system::

        name: CpgOscillators
        input_ports:
        - cpg_params
        output_ports:
        - joint_angles
        - desired_state

    * ``cpg_params`` (64): R, X, Phi, Phi' (each 4x4 row-major), see ``gaits``.
    * ``joint_angles`` (16): theta_i = chi_i + r_i sin(phi_i), in the plant's joint
      order; depends on the state only.
    * ``desired_state`` (32): [theta, dtheta/dt] for the plant's PD; the rate is the
      exact derivative of theta (it uses dphi/dt, hence also the input's biases).

    Continuous state (80): [phi (16), r (16), dr/dt (16), chi (16), dchi/dt (16)];
    ``initial_state`` (default zeros) is the default context's value, e.g. from
    ``initial_state(params, joint_angles)``.

    The derivatives and outputs are computed by the compiled kernels of
    ``manta_drake.control.cpg_kernels`` (equal to this module's numpy functions to
    1e-12, ``compiled=False`` runs those); the Simulator integrates the state either way.

    Args:
        frequency_hz: f [Hz], finite and > 0 (None: ``gaits.DEFAULT_FREQUENCY_HZ``).
        chain_weight, fcs_weight: coupling weights [rad/s], finite and >= 0.
        a, b: amplitude and bias gains [1/s], finite and > 0.
        initial_state: 80 finite values [phi, r, dr, chi, dchi] (None: zeros).

    Raises:
        ValueError: naming the argument and its allowed range.
    """

    def __init__(
        self,
        frequency_hz: float | None = None,
        chain_weight: float = 4.0,
        fcs_weight: float = 4.0,
        a: float = 20.0,
        b: float = 20.0,
        initial_state=None,
        compiled: bool = True,
    ):
        super().__init__()
        if not isinstance(compiled, bool):
            raise ValueError(f"CpgOscillators.compiled: {compiled!r} is not true or false")
        if frequency_hz is None:
            frequency_hz = DEFAULT_FREQUENCY_HZ
        FREQUENCY_HZ.check("CpgOscillators.frequency_hz", frequency_hz)
        for name, value in (("chain_weight", chain_weight), ("fcs_weight", fcs_weight)):
            COUPLING_WEIGHT.check(f"CpgOscillators.{name}", value)
        for name, value in (("a", a), ("b", b)):
            GAIN.check(f"CpgOscillators.{name}", value)
        self.frequency_hz = float(frequency_hz)
        self.a, self.b = float(a), float(b)
        self.weights = pair_weights(chain_weight, fcs_weight)
        self._omega = 2.0 * np.pi * self.frequency_hz
        if initial_state is None:
            x0 = np.zeros(NUM_STATES)
        else:
            try:
                x0 = np.asarray(initial_state, dtype=float)
            except (TypeError, ValueError):
                x0 = None
        if x0 is None or x0.shape != (NUM_STATES,) or not np.all(np.isfinite(x0)):
            shape = (
                "not numbers"
                if x0 is None
                else f"shape {x0.shape}"
                + ("" if x0.shape != (NUM_STATES,) else " with non-finite values")
            )
            raise ValueError(
                f"CpgOscillators.initial_state: expected {NUM_STATES} finite "
                f"values [phi, r, dr, chi, dchi], got {shape}"
            )
        # The default context starts here (see ``initial_state``).
        self.DeclareContinuousState(BasicVector(x0))
        self._params_port = self.DeclareVectorInputPort("cpg_params", NUM_PARAMS)
        # The kernels' output buffers (SetFromVector copies out of them).
        self._xdot, self._angles = np.empty(NUM_STATES), np.empty(NUM_OSC)
        self._desired = np.empty(2 * NUM_OSC)
        if not compiled:
            # pybind looks the override up on the instance, so this replaces the kernel
            # version for this system only (and the kernel path has no extra call).
            self.DoCalcTimeDerivatives = self._derivatives_numpy  # type: ignore[method-assign]
        self.DeclareVectorOutputPort(
            "joint_angles",
            NUM_OSC,
            self._calc_joint_angles if compiled else self._calc_joint_angles_numpy,
            prerequisites_of_calc={self.xc_ticket()},
        )
        self.DeclareVectorOutputPort(
            "desired_state",
            2 * NUM_OSC,
            self._calc_desired_state if compiled else self._calc_desired_state_numpy,
            prerequisites_of_calc={
                self.xc_ticket(),
                self.input_port_ticket(self._params_port.get_index()),
            },
        )

    def _params(self, context) -> np.ndarray:
        return self._params_port.Eval(context)

    # The callbacks run two (derivatives) or one (desired state) times per 1 ms step: each
    # is one kernel call between reading the state and writing the result.

    # (context.get_continuous_state() and ContinuousState.SetFromVector: the shortest
    # pybind paths to the 80 numbers, measured ~1 us cheaper per call than via the vector.)

    def DoCalcTimeDerivatives(self, context, derivatives):
        K.derivatives(
            context.get_continuous_state().CopyToVector(),
            self._params_port.Eval(context),
            self._omega,
            PAIRS,
            self.weights,
            self.a,
            self.b,
            NUM_OSC,
            self._xdot,
        )
        derivatives.SetFromVector(self._xdot)

    def _calc_joint_angles(self, context, output: BasicVector):
        K.angles(context.get_continuous_state().CopyToVector(), NUM_OSC, self._angles)
        output.SetFromVector(self._angles)

    def _calc_desired_state(self, context, output: BasicVector):
        K.desired_state(
            context.get_continuous_state().CopyToVector(),
            self._params_port.Eval(context),
            self._omega,
            PAIRS,
            self.weights,
            NUM_OSC,
            self._desired,
        )
        output.SetFromVector(self._desired)

    # The numpy reference (compiled=False).

    def _derivatives_numpy(self, context, derivatives):
        x = context.get_continuous_state_vector().CopyToVector()
        xdot = cpg_derivatives(
            x, self._params(context), self.frequency_hz, self.weights, self.a, self.b
        )
        derivatives.get_mutable_vector().SetFromVector(xdot)

    def _calc_joint_angles_numpy(self, context, output: BasicVector):
        output.SetFromVector(joint_angles(context.get_continuous_state_vector().CopyToVector()))

    def _calc_desired_state_numpy(self, context, output: BasicVector):
        x = context.get_continuous_state_vector().CopyToVector()
        phi_dot = phase_rates(x[:NUM_OSC], self._params(context), self.frequency_hz, self.weights)
        output.SetFromVector(np.concatenate([joint_angles(x), joint_rates(x, phi_dot)]))

    def set_state(self, context, phi=None, r=None, dr=None, chi=None, dchi=None) -> None:
        """Sets (part of) the oscillator state in this system's context; the rest is kept."""
        x = context.get_continuous_state_vector().CopyToVector().reshape(5, NUM_OSC)
        for row, value in enumerate((phi, r, dr, chi, dchi)):
            if value is not None:
                value = np.broadcast_to(np.asarray(value, dtype=float), (NUM_OSC,))
                if not np.all(np.isfinite(value)):
                    raise ValueError("CpgOscillators.set_state: non-finite value")
                x[row] = value
        context.get_mutable_continuous_state_vector().SetFromVector(x.ravel())
