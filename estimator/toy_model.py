"""A small rotor-like reference implementation of :class:`oilwatch.estimator.model.AugmentedModel`, and its
truth simulator.

Two journal masses (x, y each), joined by a shaft spring, each carried by a fluid-film-like bearing whose
linearized coefficients and static position depend on that bearing's supply flowrate q_i:

* stiffness ``K_b(q) = k0 (q_nom / q)^0.5 [[1, 0.5], [-0.5, 1.3]]`` (Lund's convention, cross-coupled, stiffer
  when starved), damping ``C_b(q) = c0 (q / q_nom)^0.3 diag(1, 1.1)``;
* static journal position ``r0(q) = e_nom (q_nom / q)^1.2 [sin 60 deg, -cos 60 deg]`` (eccentricity grows as
  the flow falls), entering as the input ``K_b(q) r0(q)``;
* unbalance forces of Eqs. 5-6 at the turbine's nominal speed on both masses (half the G2.5 unbalance
  each, phases 0 and 90 deg).

The sizes are the turbine's: 333.6 kg per journal (half of the 6545.6 N rotor), a first mode near 55 Hz,
orbits of tens of micrometres and a static shift of about 6 um between 100 % and 75 % flow.

The filter's discrete model is exact for the continuous equations at fixed q (Van Loan block exponential with
the unbalance exosystem) tabulated on a flowrate grid and bilinearly interpolated, like a coefficient table.
The truth comes from :func:`simulate` with RK4 sub-steps and a flowrate that may vary in time: a different
integrator and no interpolation, so the estimator is not tested on its own discrete model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.linalg import expm

from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.validation import InputError

from .ekf_config import ML_MIN

STIFFNESS_N_M = 4.0e7
SHAFT_STIFFNESS_N_M = 3.0e7
DAMPING_N_S_M = 8.0e4
ECCENTRICITY_M = 15.0e-6
_TURBINE = load_machine()
# The journal carries the bundled turbine's static bearing load (its machine file), as a mass under gravity.
MASS_KG = float(Rotor.from_machine(_TURBINE).bearing_static_loads_n[0]) / 9.81
SPEED_HZ = _TURBINE.nominal_speed_hz
"""The toy's speed and nominal flowrate are the bundled turbine's (its machine file)."""
NOMINAL_FLOWRATE_M3_S = _TURBINE.lubrication.nominal_flowrate_m3_s
UNBALANCE_KG_M = 3.540e-3
TABLE_BOUNDS_M3_S = (273.0 * ML_MIN, 819.0 * ML_MIN)

# [k0, c0, ks, m, e_nom, q_nom, omega, F_unbalance per mass, attitude]
_PARAMS = np.array(
    [
        STIFFNESS_N_M,
        DAMPING_N_S_M,
        SHAFT_STIFFNESS_N_M,
        MASS_KG,
        ECCENTRICITY_M,
        NOMINAL_FLOWRATE_M3_S,
        2.0 * np.pi * SPEED_HZ,
        0.5 * UNBALANCE_KG_M * (2.0 * np.pi * SPEED_HZ) ** 2,
        np.deg2rad(60.0),
    ]
)
_PHASES = np.array([0.0, 0.5 * np.pi])


@njit(cache=True)
def _bearing(q: float, params: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K_b (2, 2) [N/m], C_b (2, 2) [N s/m] and r0 (2,) [m] of one bearing at flowrate q [m^3/s]."""
    ratio = params[5] / q
    stiffness = params[0] * np.sqrt(ratio) * np.array([[1.0, 0.5], [-0.5, 1.3]])
    damping = params[1] * ratio**-0.3 * np.array([[1.0, 0.0], [0.0, 1.1]])
    eccentricity = params[4] * ratio**1.2
    position = eccentricity * np.array([np.sin(params[8]), -np.cos(params[8])])
    return stiffness, damping, position


@njit(cache=True)
def _matrices(q: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous A (8, 8), constant input b0 (8,) and unbalance columns (8, 2) at flowrates q (2,)."""
    state_matrix = np.zeros((8, 8))
    constant = np.zeros(8)
    harmonic = np.zeros((8, 2))
    mass, ks = params[3], params[2]
    for i in range(4):
        state_matrix[i, 4 + i] = 1.0
    for b in range(2):
        stiffness, damping, position = _bearing(q[b], params)
        force = stiffness @ position
        for i in range(2):
            row = 4 + 2 * b + i
            constant[row] = force[i] / mass
            for j in range(2):
                state_matrix[row, 2 * b + j] -= stiffness[i, j] / mass
                state_matrix[row, 4 + 2 * b + j] -= damping[i, j] / mass
            other = 2 * (1 - b) + i
            state_matrix[row, 2 * b + i] -= ks / mass
            state_matrix[row, other] += ks / mass
        amplitude = params[7] / mass
        phase = _PHASES[b]
        harmonic[4 + 2 * b, 0] = amplitude * np.cos(phase)
        harmonic[4 + 2 * b + 1, 0] = amplitude * np.sin(phase)
        harmonic[4 + 2 * b, 1] = -amplitude * np.sin(phase)
        harmonic[4 + 2 * b + 1, 1] = amplitude * np.cos(phase)
    return state_matrix, constant, harmonic


@njit(cache=True)
def _derivative(state: np.ndarray, q: np.ndarray, time: float, params: np.ndarray) -> np.ndarray:
    state_matrix, constant, harmonic = _matrices(q, params)
    angle = params[6] * time
    return state_matrix @ state + constant + harmonic[:, 0] * np.cos(angle) + harmonic[:, 1] * np.sin(angle)


@njit(cache=True)
def _rk4_record(
    initial: np.ndarray, flowrate: np.ndarray, dt: float, substeps: int, params: np.ndarray
) -> np.ndarray:
    """States at t_k = k dt for k < K, integrating with RK4 and the flowrate held over each sample."""
    count = flowrate.shape[0]
    states = np.zeros((count, 8))
    state = initial.copy()
    h = dt / substeps
    for k in range(count):
        states[k] = state
        q = flowrate[k]
        for j in range(substeps):
            t = k * dt + j * h
            k1 = _derivative(state, q, t, params)
            k2 = _derivative(state + 0.5 * h * k1, q, t + 0.5 * h, params)
            k3 = _derivative(state + 0.5 * h * k2, q, t + 0.5 * h, params)
            k4 = _derivative(state + h * k3, q, t + h, params)
            state = state + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return states


@njit(cache=True)
def _interpolated_map(
    state: np.ndarray,
    q: np.ndarray,
    step: int,
    grid_low: float,
    grid_step: float,
    transition_grid: np.ndarray,
    input_grid: np.ndarray,
    omega_dt: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    last = transition_grid.shape[0] - 2
    cell = np.zeros(2, dtype=np.int64)
    frac = np.zeros(2)
    for b in range(2):
        position = (q[b] - grid_low) / grid_step
        index = min(max(int(np.floor(position)), 0), last)
        cell[b] = index
        frac[b] = position - index
    exo = np.array([1.0, np.cos(omega_dt * step), np.sin(omega_dt * step)])
    corners = np.zeros((2, 2, 8))
    for a in range(2):
        for b in range(2):
            ad = transition_grid[cell[0] + a, cell[1] + b]
            corners[a, b] = ad @ state + input_grid[cell[0] + a, cell[1] + b] @ exo
    t1, t2 = frac[0], frac[1]
    weights = np.array([[(1 - t1) * (1 - t2), (1 - t1) * t2], [t1 * (1 - t2), t1 * t2]])
    next_state = np.zeros(8)
    state_jacobian = np.zeros((8, 8))
    for a in range(2):
        for b in range(2):
            next_state += weights[a, b] * corners[a, b]
            state_jacobian += weights[a, b] * transition_grid[cell[0] + a, cell[1] + b]
    flow_jacobian = np.zeros((8, 2))
    flow_jacobian[:, 0] = (
        (1 - t2) * (corners[1, 0] - corners[0, 0]) + t2 * (corners[1, 1] - corners[0, 1])
    ) / grid_step
    flow_jacobian[:, 1] = (
        (1 - t1) * (corners[0, 1] - corners[0, 0]) + t1 * (corners[1, 1] - corners[1, 0])
    ) / grid_step
    return next_state, state_jacobian, flow_jacobian


class ToyRotor:
    """The toy model of the module docstring; satisfies :class:`oilwatch.estimator.model.AugmentedModel`.

    State ``s = [x1, y1, x2, y2, vx1, vy1, vx2, vy2]`` [m, m/s], absolute (static position included).

    Parameters
    ----------
    dt_s : sampling period [s]. grid_points : flowrate grid points per bearing over the table range.
    """

    n_states = 8

    def __init__(self, dt_s: float = 1.0e-3, grid_points: int = 33) -> None:
        self.dt_s = float(dt_s)
        self.speed_hz = SPEED_HZ
        self.nominal_flowrate_m3_s = NOMINAL_FLOWRATE_M3_S
        self.flowrate_bounds_m3_s = TABLE_BOUNDS_M3_S
        self.output_matrix = np.hstack([np.eye(4), np.zeros((4, 4))])
        self.velocity_output_matrix = np.hstack([np.zeros((4, 4)), np.eye(4)])
        self._grid = np.linspace(*TABLE_BOUNDS_M3_S, grid_points)
        self._grid_step = float(self._grid[1] - self._grid[0])
        omega = _PARAMS[6]
        self._omega_dt = omega * self.dt_s
        self._transition_grid = np.zeros((grid_points, grid_points, 8, 8))
        self._input_grid = np.zeros((grid_points, grid_points, 8, 3))
        block = np.zeros((11, 11))
        block[9, 10] = -omega
        block[10, 9] = omega
        for a, q1 in enumerate(self._grid):
            for b, q2 in enumerate(self._grid):
                state_matrix, constant, harmonic = _matrices(np.array([q1, q2]), _PARAMS)
                block[:8, :8] = state_matrix
                block[:8, 8] = constant
                block[:8, 9:] = harmonic
                exponential = expm(block * self.dt_s)
                self._transition_grid[a, b] = exponential[:8, :8]
                self._input_grid[a, b] = exponential[:8, 8:]

    def transition(
        self, state: np.ndarray, flowrate_m3_s: np.ndarray, step: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Eq. 16 on the interpolated table: ``(s_{k+1}, df/ds (8, 8), df/dq (8, 2))``."""
        return _interpolated_map(
            np.ascontiguousarray(state, dtype=np.float64),
            np.asarray(flowrate_m3_s, dtype=np.float64),
            step,
            self._grid[0],
            self._grid_step,
            self._transition_grid,
            self._input_grid,
            self._omega_dt,
        )

    def physical_covariance(self, displacement_std_m: float, velocity_std_m_s: float) -> np.ndarray:
        """diag(displacement_std^2 x 4, velocity_std^2 x 4)."""
        return np.diag([displacement_std_m**2] * 4 + [velocity_std_m_s**2] * 4)

    def static_state(self, flowrate_m3_s: np.ndarray) -> np.ndarray:
        """Static equilibrium (no unbalance) at flowrates (2,) [m^3/s]: ``A s + b0 = 0``."""
        state_matrix, constant, _ = _matrices(np.asarray(flowrate_m3_s, dtype=np.float64), _PARAMS)
        return np.linalg.solve(state_matrix, -constant)

    def continuous_eigenvalues(self, flowrate_m3_s: np.ndarray) -> np.ndarray:
        """Eigenvalues of the continuous state matrix [1/s] (for the stability check of the toy)."""
        state_matrix, _, _ = _matrices(np.asarray(flowrate_m3_s, dtype=np.float64), _PARAMS)
        return np.linalg.eigvals(state_matrix)


@dataclass
class TruthRecord:
    """A simulated measurement record: time (K,) [s], true states (K, 8), true and noisy displacements (K, 4)
    [m], and the true flowrates (K, 2) [m^3/s]."""

    time_s: np.ndarray
    states: np.ndarray
    displacement_true_m: np.ndarray
    displacement_m: np.ndarray
    flowrate_m3_s: np.ndarray


def simulate(
    model: ToyRotor, flowrate_m3_s: np.ndarray, noise_std_m: float, seed: int = 0, substeps: int = 8
) -> TruthRecord:
    """Integrate the toy's continuous equations (RK4, ``substeps`` per sample) for the flowrate history
    (K, 2) [m^3/s], starting at the static equilibrium of the first flowrates; add white noise of std
    ``noise_std_m`` to the four displacements."""
    flowrate = np.ascontiguousarray(flowrate_m3_s, dtype=np.float64)
    if flowrate.ndim != 2 or flowrate.shape[1] != 2:
        raise InputError(f"flowrate_m3_s must have shape (K, 2), got {flowrate.shape}")
    low, high = TABLE_BOUNDS_M3_S
    if not ((flowrate >= low) & (flowrate <= high)).all():
        raise InputError(f"flowrate_m3_s must lie in [{low:g}, {high:g}] m^3/s")
    initial = model.static_state(flowrate[0])
    states = _rk4_record(initial, flowrate, model.dt_s, substeps, _PARAMS)
    clean = states[:, :4].copy()
    rng = np.random.default_rng(seed)
    noisy = clean + noise_std_m * rng.standard_normal(clean.shape)
    time = np.arange(flowrate.shape[0]) * model.dt_s
    return TruthRecord(time, states, clean, noisy, flowrate)
