"""Time integration of the rotor-bearing system for the plant: Newmark average acceleration with sub-steps.

The plant's "truth" must not be the estimator's discrete model, so it integrates the second-order equations of
``RotorBearingSystem`` (usually the full 84-dof model) with the trapezoidal rule (Newmark beta = 1/4,
gamma = 1/2: unconditionally stable, second order, no numerical damping), as the paper's truth does, with the
bearing coefficients evaluated at each sub-step's flowrates.

Cost. Only the bearing blocks depend on the flowrates: the effective stiffness is ``S0 + U dB U^T`` with ``U``
selecting the bearing dofs, solved with the Sherman-Morrison-Woodbury identity around a factorization at a
reference flowrate. While the flowrates stay constant, the sub-step recursion is linear and time-invariant, so
the whole sampling period collapses into one precomputed propagator (one matrix-vector product per step).
While they change, the bearing blocks of all sub-steps are interpolated at once and the sub-steps run in one
compiled loop (:func:`_trapezoid_steps`), since the per-call overhead of a dozen small numpy operations per
sub-step would otherwise dominate.

Reference: N. M. Newmark, "A method of computation for structural dynamics",
J. Eng. Mech. Div. ASCE 85 (1959).
"""

from __future__ import annotations

from collections.abc import Callable

import numba
import numpy as np
from scipy.linalg import inv, solve

from ..validation import InputError, require_positive
from .rotor_bearing import RotorBearingSystem

FlowSchedule = Callable[[np.ndarray], np.ndarray]
"""``schedule(times_s (m,)) -> flowrates (m, 2)`` [m^3/s]: the bearings' supply flowrates at the times."""
BETA, GAMMA = 0.25, 0.5
# Flowrates closer than this (relative) count as constant over a period. A logistic transition never becomes
# exactly constant in floating point; a 1e-9 relative flow change moves the shaft by ~1e-14 m.
CONSTANT_FLOW_RTOL = 1e-9


class NewmarkIntegrator:
    """Sub-stepped trapezoidal integration of the rotor-bearing system with time-varying flowrates.

    Parameters
    ----------
    system : the rotor-bearing system (full or reduced coordinates).
    dt_s : output period [s]; each call of ``advance`` integrates this long.
    substeps : trapezoidal steps per period.
    reference_flowrates_m3_s : flowrates of the factorized effective stiffness (any value in range).
    """

    def __init__(
        self,
        system: RotorBearingSystem,
        dt_s: float,
        substeps: int,
        reference_flowrates_m3_s: tuple[float, float],
    ) -> None:
        self.system = system
        self.dt_s = require_positive("dt_s", dt_s, "s")
        if int(substeps) != substeps or substeps < 1:
            raise InputError(f"substeps must be an integer >= 1, got {substeps!r}")
        self.substeps = int(substeps)
        self.h = self.dt_s / self.substeps
        n = system.n_coordinates
        self.n = n
        mass, damping, stiffness, _ = system.second_order(reference_flowrates_m3_s)
        self._reference_blocks = self._bearing_blocks(reference_flowrates_m3_s)
        self._base_damping = damping - self._scatter(self._reference_blocks[1])
        self._base_stiffness = stiffness - self._scatter(self._reference_blocks[0])
        effective = stiffness + GAMMA / (BETA * self.h) * damping + mass / (BETA * self.h**2)
        self._effective_inverse = inv(effective)
        self._mass_inverse = inv(mass)
        self._substep_offsets = self.h * np.arange(0, self.substeps + 1)
        self._acceleration_current = True
        self._select = system.bearing_maps.reshape(-1, n)
        self._z = self._effective_inverse @ self._select.T
        self._s = self._select @ self._z
        self.mass = mass
        self._propagator_flowrates: tuple[float, ...] | None = None  # conditions key of the propagator
        self._propagator: tuple[np.ndarray, np.ndarray] | None = None
        self._last_flowrates: tuple[float, ...] | None = None  # conditions key of the last steady period
        self.time_s = 0.0
        self.state = np.zeros(3 * n)
        # Complex unbalance moment u = m exp(i phi) [kg m]: the harmonic load is Re(u F_1 exp(i Omega t)).
        self.unbalance_moment = system.unbalance_moment_kg_m * np.exp(1j * system.unbalance_phase_rad)
        # The instantaneous spin speed (held over each period) and the rotor angle at ``time_s``: the
        # unbalance load turns with the angle and grows as the speed squared; the gyroscopic term's change
        # from the system's speed, (Omega - Omega_0) G, is taken explicitly (from the previous sub-step's
        # velocity), which keeps the factorized effective stiffness (see :meth:`set_speed`).
        self.speed_rad_s = system.omega_rad_s
        self.rotor_angle_rad = 0.0
        # Compile (or load from numba's cache) the sub-step kernel now, not inside the first steps of a run.
        no_blocks = np.zeros((0, self._select.shape[0], self._select.shape[0]))
        self._steps(np.zeros((3 * n, 1)), np.zeros((0, n, 1)), no_blocks, no_blocks)

    def set_speed(self, speed_rad_s: float) -> None:
        """The spin speed [rad/s] for the next periods (the bearing tables' conditions are set apart)."""
        self.speed_rad_s = require_positive("speed", speed_rad_s, "rad/s")

    def _gyroscopic_change(self) -> np.ndarray:
        """(Omega - Omega_0) G: the gyroscopic matrix's change from the system's speed."""
        return (self.speed_rad_s - self.system.omega_rad_s) * self.system.gyroscopic

    def _conditions_key(self, flows: tuple[float, float]) -> tuple[float, ...]:
        """What a cached propagator depends on: flowrates, speed, and the tables' viscosities."""
        viscosities = tuple(getattr(t, "viscosity_pa_s", 0.0) for t in self.system.tables)
        return (*flows, self.speed_rad_s, *viscosities)

    def _bearing_blocks(self, flowrates: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Block-diagonal bearing K, C (2 nb, 2 nb) and the constant bearing load (2 nb,) at the flowrates."""
        k, c, load = self._substep_blocks(np.array([flowrates], dtype=float))
        return k[0], c[0], load[0]

    def _scatter(self, block: np.ndarray) -> np.ndarray:
        """``P^T block P`` on the system's coordinates."""
        p = self.system.bearing_maps.reshape(-1, self.system.n_coordinates)
        return p.T @ block @ p

    def reset(self, time_s: float, flowrates_m3_s: tuple[float, float], initial: str = "steady") -> None:
        """Start at ``time_s`` in the static equilibrium (``"static"``) or the steady unbalance orbit
        (``"steady"``) of the given flowrates."""
        coordinates = self.system.static_coordinates(flowrates_m3_s)
        velocity = np.zeros(self.n)
        self.speed_rad_s = self.system.omega_rad_s
        self.rotor_angle_rad = self.system.omega_rad_s * time_s
        self.time_s = time_s
        if initial == "steady":
            amplitude = self.system.unbalance_coordinates(flowrates_m3_s)
            rotation = np.exp(1j * self.system.omega_rad_s * time_s)
            coordinates = coordinates + (amplitude * rotation).real
            velocity = (1j * self.system.omega_rad_s * amplitude * rotation).real
        elif initial != "static":
            raise InputError(f"initial must be 'steady' or 'static', got {initial!r}")
        self.flowrates_m3_s = tuple(float(q) for q in flowrates_m3_s)
        _, damping, stiffness, force = self.system.second_order(flowrates_m3_s)
        load = force + self._harmonic_load(time_s)
        acceleration = solve(self.mass, load - damping @ velocity - stiffness @ coordinates)
        self.state = np.concatenate([coordinates, velocity, acceleration])
        self.time_s = time_s
        self._last_flowrates = self._conditions_key(self.flowrates_m3_s)
        self._acceleration_current = True
        # the start conditions' propagator now, not in the first period: a first step as fast as the others
        self._propagator = self._build_propagator(self.flowrates_m3_s)
        self._propagator_flowrates = self._last_flowrates

    def snapshot(self) -> dict:
        """Everything that determines the future outputs (for FMU state save and restore)."""
        return {
            "state": self.state.copy(),
            "time_s": self.time_s,
            "last_flowrates": self._last_flowrates,
            "propagator_flowrates": self._propagator_flowrates,
            "propagator": self._propagator,
            "flowrates": self.flowrates_m3_s,
            "acceleration_current": self._acceleration_current,
            "unbalance_moment": self.unbalance_moment,
            "speed_rad_s": self.speed_rad_s,
            "rotor_angle_rad": self.rotor_angle_rad,
        }

    def restore(self, snapshot: dict) -> None:
        """Return to a :meth:`snapshot`; the integration then continues bit-identically."""
        self.state = snapshot["state"].copy()
        self.time_s = snapshot["time_s"]
        self._last_flowrates = snapshot["last_flowrates"]
        self._propagator_flowrates = snapshot["propagator_flowrates"]
        self._propagator = snapshot["propagator"]
        self.flowrates_m3_s = snapshot["flowrates"]
        self._acceleration_current = snapshot["acceleration_current"]
        self.unbalance_moment = snapshot["unbalance_moment"]
        self.speed_rad_s = snapshot["speed_rad_s"]
        self.rotor_angle_rad = snapshot["rotor_angle_rad"]

    def _harmonic_load(self, time_s: float | np.ndarray) -> np.ndarray:
        """The unbalance load (n,) at a time [s], or (m, n) at the times (m,)."""
        times = np.asarray(time_s, dtype=float)[..., None]
        phase = self.rotor_angle_rad + self.speed_rad_s * (times - self.time_s)
        growth = (self.speed_rad_s / self.system.omega_rad_s) ** 2
        # The unit load at the flowrates of the period's start and its speed (the synchronous 1x load depends
        # on both).
        unit = self.system.unit_unbalance_load(self.flowrates_m3_s, self.speed_rad_s)
        return (growth * self.unbalance_moment * unit * np.exp(1j * phase)).real

    def _exogenous(self, time_s: float) -> np.ndarray:
        """``[1, Re(u e^{i Omega t}), Im(u e^{i Omega t})]``: the propagator's input (its harmonic columns are
        the responses to the cosine and sine parts of the unit unbalance load F_1)."""
        growth = (self.speed_rad_s / self.system.omega_rad_s) ** 2
        rotating = (
            growth
            * self.unbalance_moment
            * np.exp(1j * (self.rotor_angle_rad + self.speed_rad_s * (time_s - self.time_s)))
        )
        return np.array([1.0, rotating.real, rotating.imag])

    def advance(self, schedule: FlowSchedule) -> np.ndarray:
        """Integrate one period ``dt_s``; ``schedule`` gives the flowrates at the sub-step times.

        Returns the new coordinates (n,) (a view of the internal state).
        """
        times = self.time_s + self._substep_offsets
        samples = np.asarray(schedule(times), dtype=float)
        final = (float(samples[-1, 0]), float(samples[-1, 1]))
        steady = bool((np.abs(samples - samples[-1]) <= CONSTANT_FLOW_RTOL * np.abs(samples[-1])).all())
        # A propagator costs a few milliseconds: build one only for flowrates that have held for a
        # whole period already (or reuse the cached one), not for flowrates that change every period.
        key = self._conditions_key(final)
        if steady and (_close(self._propagator_flowrates, key) or _close(self._last_flowrates, key)):
            self.state = self._constant_step(final, key)
        else:
            self._refresh_acceleration()
            k_b, c_b, bearing_load = self._substep_blocks(samples[1:])
            loads = self.system.static_force + bearing_load @ self._select + self._harmonic_load(times[1:])
            state = np.ascontiguousarray(self.state[:, None])
            self.state = self._steps(state, loads[:, :, None], k_b, c_b)[:, 0]
        self._last_flowrates = key if steady else None
        self.flowrates_m3_s = final
        self.time_s += self.dt_s
        self.rotor_angle_rad += self.speed_rad_s * self.dt_s
        return self.state[: self.n]

    def _substep_blocks(self, flowrates: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`_bearing_blocks` at the flowrates (m, n_bearings) of m sub-steps: K, C (m, 2 nb, 2 nb)
        and the bearing loads (m, 2 nb)."""
        m = flowrates.shape[0]
        tables = self.system.tables
        nb = len(tables)
        k = np.zeros((m, 2 * nb, 2 * nb))
        c = np.zeros((m, 2 * nb, 2 * nb))
        load = np.zeros((m, 2 * nb))
        held = m > 1 and bool((flowrates == flowrates[0]).all())  # e.g. a speed ramp at constant flowrates
        for b, (table, f0) in enumerate(zip(tables, self.system.static_film_forces_n, strict=True)):
            rows = table.evaluate_many(flowrates[:1, b] if held else flowrates[:, b])
            rows = np.broadcast_to(rows, (m, rows.shape[1]))
            sl = slice(2 * b, 2 * b + 2)
            k[:, sl, sl] = rows[:, 2:6].reshape(m, 2, 2)
            c[:, sl, sl] = rows[:, 6:10].reshape(m, 2, 2)
            load[:, sl] = f0 + np.einsum("mij,mj->mi", k[:, sl, sl], rows[:, 0:2])
        return k, c, load

    def _steps(self, state: np.ndarray, loads: np.ndarray, k_b: np.ndarray, c_b: np.ndarray) -> np.ndarray:
        """Trapezoidal sub-steps of the state columns (3n, m_cols) under the loads (steps, n, m_cols) with
        the bearing K, C (steps, 2 nb, 2 nb) of each sub-step."""
        return _trapezoid_steps(
            state,
            loads,
            k_b,
            c_b,
            self.h,
            self.mass,
            self._base_damping,
            self._effective_inverse,
            self._select,
            self._z,
            self._s,
            self._reference_blocks[0],
            self._reference_blocks[1],
            self._gyroscopic_change(),
        )

    def _constant_step(self, flows: tuple[float, float], key: tuple[float, ...]) -> np.ndarray:
        """The whole period at constant flowrates, by the cached linear propagator on (r, v).

        The acceleration is left stale (it follows from equilibrium) until the sub-step path needs it.
        """
        if not _close(self._propagator_flowrates, key):
            self._propagator = self._build_propagator(flows)
            self._propagator_flowrates = key
        transition, forcing = self._propagator
        state = self.state.copy()
        state[: 2 * self.n] = transition @ self.state[: 2 * self.n] + forcing @ self._exogenous(self.time_s)
        self._acceleration_current = False
        return state

    def _equilibrium_acceleration(self, state: np.ndarray, flows: tuple[float, float], load: np.ndarray):
        """``M^-1 (load - D v - K r)`` for states (3n,) or (3n, m) at the flowrates."""
        _, damping, stiffness, _ = self.system.second_order(flows)
        damping = damping + self._gyroscopic_change()
        n = self.n
        return self._mass_inverse @ (load - damping @ state[n : 2 * n] - stiffness @ state[:n])

    def _refresh_acceleration(self) -> None:
        """Recompute a stale acceleration from equilibrium at the current time and flowrates."""
        if self._acceleration_current:
            return
        flows = self.flowrates_m3_s
        _, _, _, constant = self.system.second_order(flows)
        load = constant + self._harmonic_load(self.time_s)
        self.state[2 * self.n :] = self._equilibrium_acceleration(self.state, flows, load)
        self._acceleration_current = True

    def _build_propagator(self, flows: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Linear map ``((r, v), w(t_k)) -> (r, v) after one period`` at constant flowrates.

        The sub-step recursion is affine and the Newmark acceleration satisfies equilibrium at every step, so
        pushing unit (r, v) states (no load) and the three unit exogenous loads (zero r, v), each with its
        equilibrium acceleration, through it, all columns at once, gives the matrices exactly.
        """
        n, n2 = self.n, 2 * self.n
        blocks = self._bearing_blocks(flows)
        constant = self.system.static_force + self._select.T @ blocks[2]
        unit = self.system.unit_unbalance_load(flows, self.speed_rad_s)
        cosine, sine = unit.real, -unit.imag
        columns = np.zeros((3 * n, n2 + 3))
        columns[:n2, :n2] = np.eye(n2)
        initial_load = np.zeros((n, n2 + 3))
        initial_load[:, n2:] = np.column_stack([constant, cosine, sine])
        columns[n2:] = self._equilibrium_acceleration(columns, flows, initial_load)
        wh = self.speed_rad_s * self.h
        loads = np.zeros((self.substeps, n, n2 + 3))
        for i in range(1, self.substeps + 1):
            c, s = np.cos(i * wh), np.sin(i * wh)
            # Column n2 + j responds to w(t_k) = e_j; its load at t_k + i h follows by rotating the phase.
            loads[i - 1, :, n2] = constant
            loads[i - 1, :, n2 + 1] = c * cosine + s * sine
            loads[i - 1, :, n2 + 2] = -s * cosine + c * sine
        k_b = np.repeat(blocks[0][None], self.substeps, axis=0)
        c_b = np.repeat(blocks[1][None], self.substeps, axis=0)
        columns = self._steps(np.ascontiguousarray(columns), loads, k_b, c_b)
        return columns[:n2, :n2], columns[:n2, n2:]


def _close(cached: tuple[float, ...] | None, flows: tuple[float, ...]) -> bool:
    """True if the ``cached`` conditions equal ``flows`` (flowrates, speed, viscosities) within
    ``CONSTANT_FLOW_RTOL``."""
    return cached is not None and all(
        abs(a - b) <= CONSTANT_FLOW_RTOL * abs(b) for a, b in zip(cached, flows, strict=True)
    )


@numba.njit(cache=True)
def _trapezoid_steps(
    state, loads, k_b, c_b, h, mass, base_damping, effective_inverse, select, z, s, k_ref, c_ref, gyro_change
):
    """Newmark average-acceleration sub-steps of state columns [r; v; a] (3n, m) under ``loads[i]`` (n, m)
    with the bearing blocks ``k_b[i]``, ``c_b[i]`` (2 nb, 2 nb), i = 0 .. steps - 1.

    The effective stiffness is ``S_ref + P^T dB P`` with
    ``dB = (K_b - K_ref) + gamma/(beta h) (C_b - C_ref)``; its solve is
    ``x0 - Z dB (I + S dB)^-1 P x0`` (Sherman-Morrison-Woodbury) with ``x0 = S_ref^-1 rhs``,
    ``Z = S_ref^-1 P^T`` and ``S = P Z``. ``gyro_change`` (n, n), the gyroscopic matrix's change from the
    factorized speed, acts explicitly: its force -gyro_change v is taken at the sub-step's start.
    """
    n = mass.shape[0]
    nb2 = select.shape[0]
    identity = np.eye(nb2)
    for i in range(loads.shape[0]):
        r = state[:n]
        v = state[n : 2 * n]
        a = state[2 * n :]
        damping_term = GAMMA / (BETA * h) * r + (GAMMA / BETA - 1.0) * v
        rhs = (
            loads[i]
            - gyro_change @ v
            + mass @ (r / (BETA * h * h) + v / (BETA * h) + (0.5 / BETA - 1.0) * a)
            + base_damping @ damping_term
            + select.T @ (c_b[i] @ (select @ damping_term))
        )
        delta = (k_b[i] - k_ref) + GAMMA / (BETA * h) * (c_b[i] - c_ref)
        x0 = effective_inverse @ rhs
        r_new = x0 - z @ (delta @ np.linalg.solve(identity + s @ delta, select @ x0))
        a_new = (r_new - r) / (BETA * h * h) - v / (BETA * h) - (0.5 / BETA - 1.0) * a
        v_new = v + h * ((1.0 - GAMMA) * a + GAMMA * a_new)
        state = np.concatenate((r_new, v_new, a_new))
    return state
