"""The rotor on its two fluid-film bearings: Eqs. 2-10 of the paper, in full or reduced coordinates.

Each bearing's film force on the journal is linearized about the equilibrium ``e0(q)`` that the
coefficient table gives for the bearing's static load ``W_b`` (Lund's convention, see
``oilwatch.models.bearing``)::

    f = f0 - K(q) (r_b - e0(q)) - C(q) dr_b/dt,    f0 = (0, W_b) for a load along -y,

f0 the film force that balances the load along its own direction otherwise
(:func:`~oilwatch.models.bearing.equilibrium.film_force_at_equilibrium`). With the rotor's constant load g
(its weight, and the external force at a bearing whose machine file gives its load: ``Rotor.static_force``)
and the unbalance force of Eqs. 5-6 this gives::

    M r'' + (C_s + Omega G + C_b(q)) r' + (K_s + K_b(q)) r
        = g + sum_b P_b^T (f0 + K_b e0) + Re(F_u exp(i Omega t))

where ``P_b`` picks bearing b's (x, y) dofs. The state r is absolute (measured from the bearing
centres), so the measured output ``H s`` of Eq. 8 is the shaft position in each bearing, static
eccentricity included. The paper's Eq. 2 omits ``f0``; without it the journal would not sit at the
table's equilibrium under the load the table was computed for, so it is kept here.

With a ``ReductionBasis`` the coordinates are ``r = T eta``; the bearing dofs are its first coordinates.

Synchronous 1x response (``synchronous_tables``). A p-theta film's coefficients depend on the whirl
frequency (:mod:`oilwatch.models.bearing.dynamic`); constant coefficients are exact at one frequency only. The
1x unbalance orbit whirls at Omega, where K(Omega), C(Omega) are right (within 1-2 % of the transient film),
but the same constant coefficients applied to the free modes make the 75 Hz turbine unstable below 95 % of
nominal flow (a 47-51 Hz mode growing at up to +15 1/s) although the transient film and its exact roots
are stable there (least log decrement 0.10-0.13 at 75-100 %). So the state-space model keeps the
quasi-static coefficients of ``tables`` for its dynamics and replaces the unbalance load by the load whose
steady response through those dynamics is the synchronous model's orbit:

    F_eff(q) = F_u - sum_b P_b^T (Z_s,b(q) - Z_b(q)) P_b X_s(q),   Z = K + i Omega C,

with X_s the 1x response on the synchronous coefficients Z_s. Then (K - Omega^2 M + i Omega D) X_s = F_eff
exactly: the 1x orbit at any flowrate is the synchronous one, the free dynamics are the quasi-static ones.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import lu_factor, lu_solve, solve

from ..bearing.equilibrium import film_forces_at_equilibrium
from ..rotor.assembly import Rotor
from ..rotor.pedestals import Pedestals
from ..validation import InputError, require_finite, require_non_negative, require_positive
from .discretization import harmonic_input_map, zero_order_hold
from .reduction import ReductionBasis

if TYPE_CHECKING:
    from ..bearing.table import CoefficientTable


@dataclass(frozen=True)
class BearingState:
    """The linearized film of one bearing at a flowrate (SI): ``e0`` (2,), ``K`` (2, 2), ``C`` (2, 2)."""

    equilibrium_m: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray


class RotorBearingSystem:
    """Second-order and state-space model of the rotor on fluid-film bearings at one speed.

    Parameters
    ----------
    rotor : the finite-element rotor.
    tables : one coefficient table per bearing, in the order of ``rotor.bearing_nodes``, all at ``speed_hz``.
    speed_hz : spin speed [Hz]; must equal the tables' speed.
    basis : optional reduction; ``None`` keeps all ``rotor.n_dof`` physical dofs.
    unbalance_moment_kg_m, unbalance_phase_rad : override the rotor's unbalance (Eqs. 5-6) at its
        unbalance node; ``None`` keeps the machine file's.
    nominal_flowrates_m3_s : (n_bearings,) each bearing's nominal supply flowrate (the estimator's reference),
        if known.
    synchronous_tables : optional tables of K(Omega), C(Omega) (same flowrates' equilibria) that set the 1x
        unbalance response through :meth:`unit_unbalance_load` (module docstring); ``None``: ``tables``
        give both the dynamics and the 1x response.
    unit_unbalance_force : the 1x load (n_dof,) complex [N per kg m] in physical dofs that the complex
        unbalance moment multiplies; None: Eqs. 5-6 at the rotor's unbalance node. A plant whose 1x load
        is spread over several discs or holds a shaft bow passes its own (the moment and phase then scale
        the whole pattern).
    pedestals : flexible supports under the bearings (:mod:`oilwatch.models.rotor.pedestals`; full
        coordinates only): the pedestal coordinates are appended, the film acts on the journal relative to
        its pedestal and the outputs are that relative position, as probes in the housing read it.
    """

    def __init__(
        self,
        rotor: Rotor,
        tables: Sequence[CoefficientTable],
        speed_hz: float,
        basis: ReductionBasis | None = None,
        unbalance_moment_kg_m: float | None = None,
        unbalance_phase_rad: float | None = None,
        nominal_flowrates_m3_s: np.ndarray | None = None,
        synchronous_tables: Sequence[CoefficientTable] | None = None,
        unit_unbalance_force: np.ndarray | None = None,
        pedestals: Pedestals | None = None,
    ) -> None:
        speed_hz = require_positive("speed_hz", speed_hz, "Hz")
        self.nominal_flowrates_m3_s = nominal_flowrates_m3_s
        every = list(tables) + list(synchronous_tables or ())
        for name, group in (("tables", tables), ("synchronous_tables", synchronous_tables or tables)):
            if len(group) != len(rotor.bearing_nodes):
                raise InputError(
                    f"{name}: need one coefficient table per bearing ({len(rotor.bearing_nodes)}), "
                    f"got {len(group)}"
                )
        for table in every:
            if not np.isclose(table.speed_hz, speed_hz, rtol=1e-9):
                raise InputError(
                    f"speed_hz = {speed_hz:g} Hz has no coefficient table: the table is for "
                    f"{table.speed_hz:g} Hz (compute one with `oilwatch bearing-table --speed-hz`)"
                )
        self.rotor = rotor
        self.tables = tuple(tables)
        self.synchronous_tables = None if synchronous_tables is None else tuple(synchronous_tables)
        self._unit_loads: dict[tuple, np.ndarray] = {}
        self._synchronous_references: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self.speed_hz = speed_hz
        self.omega_rad_s = 2.0 * np.pi * speed_hz
        self.basis = basis
        transform = np.eye(rotor.n_dof) if basis is None else basis.basis
        self.transform = transform
        self.mass = transform.T @ rotor.mass_matrix @ transform
        self.stiffness = transform.T @ rotor.stiffness_matrix @ transform
        self.damping = (
            transform.T @ (rotor.damping_matrix + self.omega_rad_s * rotor.gyroscopic_matrix) @ transform
        )
        self.static_force = transform.T @ rotor.static_force
        self.gyroscopic = transform.T @ rotor.gyroscopic_matrix @ transform
        moment = rotor.unbalance_moment_kg_m if unbalance_moment_kg_m is None else unbalance_moment_kg_m
        phase = rotor.unbalance_phase_rad if unbalance_phase_rad is None else unbalance_phase_rad
        self.unbalance_moment_kg_m = require_non_negative("unbalance moment", moment, "kg m")
        self.unbalance_phase_rad = require_finite("unbalance phase", phase)
        # Eqs. 5-6 as Re(F exp(i Omega t)): F_x = m Omega^2 e^{i phi}, F_y = -i m Omega^2 e^{i phi}.
        amplitude = np.zeros(rotor.n_dof, dtype=complex)
        rotating = self.unbalance_moment_kg_m * self.omega_rad_s**2 * np.exp(1j * self.unbalance_phase_rad)
        amplitude[rotor.dof(rotor.unbalance_node, "x")] = rotating
        amplitude[rotor.dof(rotor.unbalance_node, "y")] = -1j * rotating
        self.unbalance_force = transform.T @ amplitude
        # The load of a unit complex unbalance moment (1 kg m at phase 0): Re(u F_1 exp(i Omega t)).
        if unit_unbalance_force is None:
            unit = np.zeros(rotor.n_dof, dtype=complex)
            unit[rotor.dof(rotor.unbalance_node, "x")] = self.omega_rad_s**2
            unit[rotor.dof(rotor.unbalance_node, "y")] = -1j * self.omega_rad_s**2
        else:
            unit = np.asarray(unit_unbalance_force, dtype=complex)
            if unit.shape != (rotor.n_dof,):
                raise InputError(f"unit_unbalance_force must have {rotor.n_dof} entries, got {unit.shape}")
            self.unbalance_force = transform.T @ (self.unbalance_moment_kg_m * np.exp(1j * phase) * unit)
        self.unit_unbalance_force = transform.T @ unit
        dofs = np.array([[rotor.dof(node, "x"), rotor.dof(node, "y")] for node in rotor.bearing_nodes])
        self.bearing_dofs = dofs
        # (n_bearings, 2, n): bearing (x, y) displacements from the coordinates.
        self.bearing_maps = transform[dofs, :]
        self.pedestals = pedestals
        if pedestals is not None:
            if basis is not None:
                raise InputError("pedestals need the full model (reduced=False)")
            self._append_pedestals(pedestals, len(rotor.bearing_nodes))
        self.static_loads_n = np.asarray(rotor.bearing_static_loads_n, dtype=float)
        #: (n_bearings, 2) each film's force at its equilibrium, f0, against its static load [N]
        self.static_film_forces_n = film_forces_at_equilibrium(
            self.static_loads_n, rotor.bearing_load_angles_rad
        )
        self.n_coordinates = self.transform.shape[1]
        self.n_states = 2 * self.n_coordinates
        self._mass_lu = lu_factor(self.mass)
        self.output_matrix = np.hstack(
            [self.bearing_maps.reshape(-1, self.n_coordinates), np.zeros((2 * len(dofs), self.n_coordinates))]
        )

    def _append_pedestals(self, pedestals: Pedestals, n_bearings: int) -> None:
        """Append the pedestal coordinates (x, y per bearing) and make the bearing maps journal minus
        pedestal: the film force acts between them and the probes read that difference."""
        n, extra = self.transform.shape[1], 2 * n_bearings
        mass, damping, stiffness = pedestals.matrices(n_bearings)

        def grown(matrix, block):
            out = np.zeros((n + extra, n + extra), dtype=matrix.dtype)
            out[:n, :n], out[n:, n:] = matrix, block
            return out

        none = np.zeros((extra, extra))
        self.mass = grown(self.mass, mass)
        self.stiffness = grown(self.stiffness, stiffness)
        self.damping = grown(self.damping, damping)
        self.gyroscopic = grown(self.gyroscopic, none)
        self.transform = grown(self.transform, np.eye(extra))
        pad = np.zeros(extra)
        self.static_force = np.concatenate([self.static_force, pad])
        self.unbalance_force = np.concatenate([self.unbalance_force, pad])
        self.unit_unbalance_force = np.concatenate([self.unit_unbalance_force, pad])
        maps = np.concatenate([self.bearing_maps, np.zeros((*self.bearing_maps.shape[:2], extra))], axis=2)
        for b in range(n_bearings):
            maps[b, 0, n + 2 * b] = maps[b, 1, n + 2 * b + 1] = -1.0
        self.bearing_maps = maps

    @property
    def bearing_flowrate_bounds_m3_s(self) -> np.ndarray:
        """Each bearing's flowrate range (n_bearings, 2), rows (low, high) [m^3/s]: the span its own tables
        (its synchronous one included) share."""
        groups = (self.tables,) if self.synchronous_tables is None else (self.tables, self.synchronous_tables)
        ranges = np.array([[table.flowrate_range_m3_s for table in group] for group in groups])
        return np.column_stack([ranges[:, :, 0].max(axis=0), ranges[:, :, 1].min(axis=0)])

    def bearing_states(self, flowrates_m3_s: Sequence[float]) -> list[BearingState]:
        """Interpolated equilibrium and coefficients of each bearing at its supply flowrate."""
        if len(flowrates_m3_s) != len(self.tables):
            raise InputError(
                f"flowrates: need one per bearing ({len(self.tables)}), got {len(flowrates_m3_s)}"
            )
        states = []
        for table, q in zip(self.tables, flowrates_m3_s, strict=True):
            c = table.evaluate(q)
            states.append(BearingState(np.asarray(c.eccentricity_m), c.stiffness, c.damping))
        return states

    def second_order(
        self, flowrates_m3_s: Sequence[float]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(M, D, K, f_static)`` at the flowrates.

        ``D`` and ``K`` include the bearings, ``f_static`` (n,) is the constant load (``static_force``, ``f0``
        and ``K_b e0`` terms). The harmonic unbalance load is ``self.unbalance_force`` (complex, (n,)).
        """
        damping = self.damping.copy()
        stiffness = self.stiffness.copy()
        force = self.static_force.copy()
        for p, state, f0 in zip(
            self.bearing_maps, self.bearing_states(flowrates_m3_s), self.static_film_forces_n, strict=True
        ):
            stiffness += p.T @ state.stiffness @ p
            damping += p.T @ state.damping @ p
            force += p.T @ (f0 + state.stiffness @ state.equilibrium_m)
        return self.mass, damping, stiffness, force

    def state_space(self, flowrates_m3_s: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(A, b)``: A (2n, 2n) of Eq. 9 and the input columns b (2n, 3) = B @ [f_static, F_c, F_s].

        The load is ``f_static + F_c cos(Omega t) + F_s sin(Omega t)`` with ``F_u = F_c - i F_s``.
        """
        _, damping, stiffness, force = self.second_order(flowrates_m3_s)
        n = self.n_coordinates
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -lu_solve(self._mass_lu, stiffness)
        a[n:, n:] = -lu_solve(self._mass_lu, damping)
        unbalance = self.unbalance_load(flowrates_m3_s)
        loads = np.column_stack([force, unbalance.real, -unbalance.imag])
        b = np.zeros((2 * n, 3))
        b[n:] = lu_solve(self._mass_lu, loads)
        return a, b

    def discrete_map(
        self, flowrates_m3_s: Sequence[float], dt_s: float, hold: str = "harmonic"
    ) -> tuple[np.ndarray, np.ndarray]:
        """One-step map ``s_{k+1} = A_d s_k + G w_k`` with ``w_k = [1, cos(Omega t_k), sin(Omega t_k)]``.

        ``hold="harmonic"`` integrates the loads exactly; ``hold="zoh"`` is the paper's Eq. 13 with the load
        sampled at ``t_{k+1}`` (Eq. 11) and held over the step.
        """
        a, b = self.state_space(flowrates_m3_s)
        if hold == "harmonic":
            return harmonic_input_map(a, b, self.omega_rad_s, dt_s)
        if hold == "zoh":
            a_d, b_d = zero_order_hold(a, b, dt_s)
            phase = self.omega_rad_s * dt_s
            rotate = np.array(
                [[1.0, 0.0, 0.0], [0.0, np.cos(phase), -np.sin(phase)], [0.0, np.sin(phase), np.cos(phase)]]
            )
            return a_d, b_d @ rotate
        raise InputError(f"hold must be 'harmonic' or 'zoh', got {hold!r}")

    def static_coordinates(self, flowrates_m3_s: Sequence[float]) -> np.ndarray:
        """Static coordinates (n,) under the static load and the bearing loads at the flowrates."""
        _, _, stiffness, force = self.second_order(flowrates_m3_s)
        return solve(stiffness, force)

    def unbalance_coordinates(self, flowrates_m3_s: Sequence[float]) -> np.ndarray:
        """Complex amplitude (n,) of the steady unbalance response: ``r(t) = Re(X exp(i Omega t))``."""
        _, damping, stiffness, _ = self.second_order(flowrates_m3_s)
        w = self.omega_rad_s
        return solve(stiffness - w * w * self.mass + 1j * w * damping, self.unbalance_load(flowrates_m3_s))

    def unbalance_load(self, flowrates_m3_s: Sequence[float]) -> np.ndarray:
        """The complex unbalance load (n,) of the model at the flowrates: ``unit_unbalance_load`` times the
        unbalance moment and phase (``unbalance_force`` without synchronous tables)."""
        moment = self.unbalance_moment_kg_m * np.exp(1j * self.unbalance_phase_rad)
        return moment * self.unit_unbalance_load(flowrates_m3_s)

    def unit_unbalance_load(
        self, flowrates_m3_s: Sequence[float], whirl_rad_s: float | None = None
    ) -> np.ndarray:
        """Load (n,) complex of a unit unbalance moment (1 kg m at phase 0) at the flowrates: with
        ``synchronous_tables`` the load F_eff of the module docstring, else ``unit_unbalance_force``.

        ``whirl_rad_s``: the spin speed of the 1x orbit (None: the system's). The rotor's dynamic stiffness
        (gyroscopic term included) and the bearing impedances K + i Omega C are taken at it, as the tables
        give K and C at their current conditions; the load keeps the magnitude of the system's speed
        (``m Omega_0^2`` per kg m): F_eff is linear in the unbalance force, so the load at the whirl speed is
        this times (Omega / Omega_0)^2, which the caller applies as it does to the unbalance force."""
        if self.synchronous_tables is None:
            return self.unit_unbalance_force
        whirl = self._whirl(whirl_rad_s)
        conditions = tuple(getattr(t, "conditions", ()) for t in self.tables + self.synchronous_tables)
        key = (*(float(q) for q in flowrates_m3_s), *conditions, whirl)
        if key not in self._unit_loads:
            if len(self._unit_loads) > 4096:
                self._unit_loads.clear()
            self._unit_loads[key] = self._effective_unit_load(flowrates_m3_s, whirl)
        return self._unit_loads[key]

    def _whirl(self, whirl_rad_s: float | None) -> float:
        """The 1x whirl speed [rad/s]: the system's unless given (checked > 0)."""
        if whirl_rad_s is None:
            return self.omega_rad_s
        return require_positive("whirl speed", whirl_rad_s, "rad/s")

    def _effective_unit_load(self, flowrates_m3_s: Sequence[float], whirl_rad_s: float) -> np.ndarray:
        """F_eff of a unit unbalance through the bearing dofs only: with A_ref = K - Omega^2 M + i Omega D
        at reference bearing impedances Z_ref (factorized once per whirl speed), the synchronous orbit's
        bearing displacements solve (I + H (Z_s - Z_ref)) x_b = h, H = P A_ref^-1 P^T, h = P A_ref^-1 F_1
        (a 4 x 4 solve per flowrate pair, exact for any Z_ref); then F_eff = F_1 - P^T (Z_s - Z_qs) x_b. At
        another whirl speed than the system's, x_b comes from one direct solve of the synchronous orbit."""
        z_s = self._impedance_blocks(self.synchronous_tables, flowrates_m3_s, whirl_rad_s)
        z_qs = self._impedance_blocks(self.tables, flowrates_m3_s, whirl_rad_s)
        if whirl_rad_s == self.omega_rad_s:
            return self.synchronous_unit_load(z_s, z_qs, whirl_rad_s)
        # Off the system's speed (a speed ramp: a new whirl speed every period) one direct solve of the
        # synchronous orbit is cheaper than a reference response per speed.
        w = whirl_rad_s
        select = self.bearing_maps.reshape(-1, self.n_coordinates)
        damping = self.damping + (w - self.omega_rad_s) * self.gyroscopic
        matrix = self.stiffness - w * w * self.mass + 1j * w * damping + select.T @ z_s @ select
        x_b = select @ np.linalg.solve(matrix, self.unit_unbalance_force)
        return self.unit_unbalance_force - select.T @ ((z_s - z_qs) @ x_b)

    def synchronous_unit_load(
        self, z_synchronous: np.ndarray, z_dynamics: np.ndarray, whirl_rad_s: float | None = None
    ) -> np.ndarray:
        """F_eff (n,) complex of a unit unbalance for block-diagonal bearing impedances K + i Omega C
        (2 nb, 2 nb) at the whirl speed ``whirl_rad_s`` (None: the system's): the synchronous ones of the 1x
        orbit and the ones of the model's dynamics (module docstring; magnitude as
        :meth:`unit_unbalance_load`). For models that evaluate their own coefficients (operating points)."""
        h, big_h, z_ref = self._reference_response(self._whirl(whirl_rad_s))
        x_b = np.linalg.solve(np.eye(h.size) + big_h @ (z_synchronous - z_ref), h)
        select = self.bearing_maps.reshape(-1, self.n_coordinates)
        return self.unit_unbalance_force - select.T @ ((z_synchronous - z_dynamics) @ x_b)

    def _impedance_blocks(self, tables, flowrates_m3_s: Sequence[float], whirl_rad_s: float) -> np.ndarray:
        """Block-diagonal K + i Omega C (2 nb, 2 nb) of ``tables`` at the flowrates and whirl speed."""
        nb = len(tables)
        z = np.zeros((2 * nb, 2 * nb), dtype=complex)
        for b, (table, q) in enumerate(zip(tables, flowrates_m3_s, strict=True)):
            c = table.evaluate(q)
            z[2 * b : 2 * b + 2, 2 * b : 2 * b + 2] = c.stiffness + 1j * whirl_rad_s * c.damping
        return z

    def _reference_response(self, whirl_rad_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(h, H, Z_ref) of :meth:`_effective_unit_load` at a whirl speed, at the quasi-static impedances of
        each bearing's mid-range flow (cached per whirl speed: a speed ramp asks for a new one every
        period)."""
        found = self._synchronous_references.get(whirl_rad_s)
        if found is not None:
            return found
        if len(self._synchronous_references) > 64:
            self._synchronous_references.clear()
        bounds = self.bearing_flowrate_bounds_m3_s
        w = whirl_rad_s
        z_ref = self._impedance_blocks(self.tables, 0.5 * (bounds[:, 0] + bounds[:, 1]), w)
        select = self.bearing_maps.reshape(-1, self.n_coordinates)
        damping = self.damping + (w - self.omega_rad_s) * self.gyroscopic
        matrix = self.stiffness - w * w * self.mass + 1j * w * damping + select.T @ z_ref @ select
        response = solve(matrix, np.column_stack([self.unit_unbalance_force, select.T]))
        found = self._synchronous_references[whirl_rad_s] = (
            select @ response[:, 0],
            select @ response[:, 1:],
            z_ref,
        )
        return found

    def bearing_positions(self, coordinates: np.ndarray) -> np.ndarray:
        """Bearing (x, y) displacements (n_bearings, 2) of the coordinates (real or complex)."""
        return np.einsum("bin,n->bi", self.bearing_maps, coordinates)

    def exogenous(self, time_s: float) -> np.ndarray:
        """The exogenous input ``w = [1, cos(Omega t), sin(Omega t)]`` at a time [s]."""
        phase = self.omega_rad_s * time_s
        return np.array([1.0, np.cos(phase), np.sin(phase)])
