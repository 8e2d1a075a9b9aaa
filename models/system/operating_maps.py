"""Exact one-step maps of the rotor-bearing system at any operating point (q1, q2, speed, mu1, mu2).

``RotorBearingSystem.discrete_map`` holds one speed and the viscosity of its flowrate tables. The estimator
that follows the measured speed and oil temperature (:mod:`oilwatch.models.system.operating_model`) needs the
exact map ``s_{k+1} = A_d s_k + G w_k`` and its derivatives anywhere in the operating space, for its
re-centred corrections. :class:`OperatingMaps` assembles the continuous block of Van Loan's exponential
(:func:`oilwatch.models.system.discretization.harmonic_input_map`) from the system's rotor matrices and the
dimensionless bearing table (:mod:`oilwatch.models.bearing.operating_table`: each bearing at its own
Sommerfeld number and flowrate over its Couette flow), with

* the gyroscopic matrix at the speed (``C_s + Omega G``);
* the unbalance load at the speed, ``m e Omega^2`` (the system's unbalance force scaled by ``(Omega /
  Omega_0)^2``); for a system with synchronous tables (``RotorBearingSystem.synchronous_tables``: the
  turbine's default) the 1x load is the effective load ``F_eff`` whose response through the quasi-static
  dynamics is the synchronous orbit, from both dimensionless tables at the operating point
  (``RotorBearingSystem.synchronous_unit_load``: the rotor's dynamic stiffness and the impedances
  K + i Omega C at the operating point's speed, as the plant takes them);
* the exosystem's rotation at the speed;

and gives the derivatives of ``(A_d, G)`` along the operating axes with ``scipy.linalg.expm_frechet`` (the
block is affine in the coefficients, so a central difference of the block is exact to second order).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from ..bearing.operating_table import OperatingTable
from .discretization import block_map
from .frechet import expm_frechet_many
from .rotor_bearing import RotorBearingSystem

AXES = ("q1", "q2", "speed", "ln_mu1", "ln_mu2")
"""The operating axes, in the order of :meth:`OperatingMaps.derivatives`: flowrates [m^3/s], speed [Hz],
natural logarithms of each bearing's film viscosity."""
SLICES_KEPT = 256
"""Table slices (one per bearing, speed, viscosity and kind) kept, the least recently used dropped: a
re-centring asks for about 40, and with the viscosity factors estimated every re-centring's are new, so an
unbounded cache grows with the run (about 2 kB a slice, 100 slices per 10 s at a constant operating
point)."""
SECOND_STEP = 1e-4
"""The forward step of :meth:`OperatingMaps.second_derivatives` (relative in q and speed, absolute in ln
mu)."""


class OperatingMaps:
    """Exact maps of ``system`` (reduced or full) with its bearings on the dimensionless ``table``.

    ``system`` supplies the rotor (mass, stiffness, structural damping, gyroscopic matrix, static load,
    unbalance force at its own speed), the bearing dofs and each bearing's static load; its flowrate
    tables are not used. ``table``: one dimensionless table for every bearing, or one per bearing (bearings
    of another clearance: :meth:`OperatingTable.with_clearance`). ``synchronous_table``: likewise, the
    table of the synchronous coefficients, for the 1x load of a system with synchronous tables (None: the
    unbalance force itself).
    """

    def __init__(
        self,
        system: RotorBearingSystem,
        table: OperatingTable | tuple[OperatingTable, ...],
        dt_s: float,
        synchronous_table: OperatingTable | tuple[OperatingTable, ...] | None = None,
    ) -> None:
        count = len(system.static_loads_n)
        self.system = system
        self.tables = _per_bearing(table, count)
        self.synchronous_tables = (
            None if synchronous_table is None else _per_bearing(synchronous_table, count)
        )
        self.dt_s = float(dt_s)
        n = system.n_coordinates
        self._n = n
        self._structural_damping = system.damping - system.omega_rad_s * system.gyroscopic
        self._reference_omega = system.omega_rad_s
        self._loads = system.static_loads_n
        self._film_forces = system.static_film_forces_n
        self._mass_lu = lu_factor(system.mass)
        self._slices: dict[tuple[int, float, float, bool], object] = {}  # least recently used first
        # M^-1 of what the block's rows are linear in, once: the rotor's stiffness, structural damping,
        # gyroscopic matrix and static load, and each bearing's map P_b^T (a block is then small products)
        mass_lu = self._mass_lu
        self._minv_stiffness = lu_solve(mass_lu, system.stiffness)
        self._minv_damping = lu_solve(mass_lu, self._structural_damping)
        self._minv_gyroscopic = lu_solve(mass_lu, system.gyroscopic)
        self._minv_static = lu_solve(mass_lu, system.static_force)
        self._minv_map_stack = np.array([lu_solve(mass_lu, p.T) for p in system.bearing_maps])
        self._minv = lu_solve(mass_lu, np.eye(n))
        self._select = system.bearing_maps.reshape(-1, n)

    def _slice(self, bearing: int, speed_hz: float, viscosity_pa_s: float, synchronous: bool = False):
        key = (bearing, speed_hz, viscosity_pa_s, synchronous)
        slices = self._slices
        found = slices.pop(key, None)
        if found is None:
            table = (self.synchronous_tables if synchronous else self.tables)[bearing]
            found = table.at(speed_hz, viscosity_pa_s, self._loads[bearing])
            if len(slices) >= SLICES_KEPT:
                del slices[next(iter(slices))]
        slices[key] = found  # the most recently used last: a dict keeps insertion order
        return found

    @property
    def slice_count(self) -> int:
        """Table slices held (at most :data:`SLICES_KEPT`)."""
        return len(self._slices)

    def bearing_flowrate_bounds_m3_s(self, speed_hz: float, viscosities_pa_s) -> np.ndarray:
        """Each bearing's flowrate range (n_bearings, 2), rows (low, high) [m^3/s]: the span its own table
        slices (quasi-static and synchronous) cover at the speed and at every bearing's viscosity.

        Every bearing's viscosity, not only its own: bearings of one table then keep the one range they had
        when the bearings shared a range, and with it the corrections (:mod:`operating_correction` places
        the centre and the side of the second differences by it) while their viscosity factors move apart."""
        kinds = (False,) if self.synchronous_tables is None else (False, True)
        bounds = []
        for b in range(len(self.tables)):
            ranges = [
                self._slice(b, speed_hz, mu, kind).flowrate_range_m3_s
                for mu in viscosities_pa_s
                for kind in kinds
            ]
            lows, highs = zip(*ranges, strict=True)
            bounds.append((max(lows), min(highs)))
        return np.array(bounds)

    def block(self, flowrates_m3_s, speed_hz: float, viscosities_pa_s) -> np.ndarray:
        """The continuous block (2n + 3, 2n + 3) of the exact map at the operating point (:meth:`blocks`)."""
        return self.blocks([(flowrates_m3_s, speed_hz, viscosities_pa_s)])[0]

    def blocks(self, points) -> np.ndarray:
        """The continuous blocks (P, 2n + 3, 2n + 3) of the exact maps at the operating points
        ``(flowrates (2,), speed [Hz], viscosities (2,))``.

        Their rows ``M^-1 [-K, -C, loads]`` are sums of the rotor's part (precomputed) and each bearing's
        ``M^-1 P_b^T (k_b, c_b, load_b + k_b e_b)`` (``P_b`` its 2 x n map); the points' table rows are read
        one slice at a time (a re-centring's points share most slices), and the sums are stacked products."""
        sys = self.system
        n = self._n
        nb = len(self._loads)
        count = len(points)
        omega = np.array([2.0 * math.pi * float(speed) for _, speed, _ in points])
        rows, synchronous = self._table_rows(points)  # (P, nb, 10) each
        e, k, c = (
            rows[..., 0:2],
            rows[..., 2:6].reshape(count, nb, 2, 2),
            rows[..., 6:10].reshape(count, nb, 2, 2),
        )
        maps = sys.bearing_maps  # (nb, 2, n)
        minv_maps = self._minv_map_stack  # (nb, n, 2)
        stiffness = self._minv_stiffness + np.einsum("bia,pbac,bcj->pij", minv_maps, k, maps)
        damping = (
            self._minv_damping
            + omega[:, None, None] * self._minv_gyroscopic
            + np.einsum("bia,pbac,bcj->pij", minv_maps, c, maps)
        )
        loads = self._film_forces + np.einsum("pbac,pbc->pba", k, e)
        force = self._minv_static + np.einsum("bia,pba->pi", minv_maps, loads)
        unbalance = self._unbalance_forces(synchronous, omega, k, c)  # (P, n) complex
        block = np.zeros((count, 2 * n + 3, 2 * n + 3))
        block[:, :n, n : 2 * n] = np.eye(n)
        block[:, n : 2 * n, :n] = -stiffness
        block[:, n : 2 * n, n : 2 * n] = -damping
        block[:, n : 2 * n, 2 * n] = force
        harmonic = np.stack([unbalance.real, -unbalance.imag], axis=2)  # (P, n, 2)
        block[:, n : 2 * n, 2 * n + 1 :] = (
            (self._minv @ harmonic.transpose(1, 0, 2).reshape(n, 2 * count))
            .reshape(n, count, 2)
            .transpose(1, 0, 2)
        )
        block[:, 2 * n + 1, 2 * n + 2] = -omega
        block[:, 2 * n + 2, 2 * n + 1] = omega
        return block

    def _table_rows(self, points) -> tuple[np.ndarray, np.ndarray | None]:
        """The quasi-static and (with a synchronous table, else None) synchronous table rows (P, nb, 10) of
        each bearing at each point, one ``rows`` call per table slice."""
        wanted: dict[tuple, tuple[list[int], list[float]]] = {}
        for p, (flowrates, speed, viscosities) in enumerate(points):
            for b, (q, mu) in enumerate(zip(flowrates, viscosities, strict=True)):
                where = wanted.setdefault((b, float(speed), float(mu)), ([], []))
                where[0].append(p)
                where[1].append(float(q))
        kinds = (False,) if self.synchronous_tables is None else (False, True)
        rows = np.empty((len(kinds), len(points), len(self._loads), 10))
        for (b, speed, mu), (ps, qs) in wanted.items():
            flowrates = np.array(qs)
            for kind in kinds:
                table = self._slice(b, speed, mu, kind)
                # the estimator's flowrates are bounded to the table's range at its reference point; where
                # the speed, the oil or a viscosity factor moved the flooded threshold, a bound estimate (or
                # a difference step from it) is taken at the table's edge: the film saturates there
                low, high = table.flowrate_range_m3_s
                rows[int(kind), ps, b] = table.rows(np.clip(flowrates, low, high))
        return rows[0], (rows[1] if len(kinds) == 2 else None)

    def _unbalance_forces(self, synchronous, omega: np.ndarray, k: np.ndarray, c: np.ndarray) -> np.ndarray:
        """The 1x load (P, n) complex at each point: the system's unbalance force, or with the synchronous
        table's rows (P, nb, 10) the effective load of the synchronous orbit (module docstring), times
        (Omega / Omega_0)^2.

        The orbit is one stacked direct solve of ``(K - w^2 M + i w (C_s + w G) + P^T Z_s P) x = F_1`` for
        all points (the orbit ``RotorBearingSystem.synchronous_unit_load`` finds through its reference
        response, exact for any reference), then ``F_eff = F_1 - P^T (Z_s - Z_qs) P x``."""
        sys = self.system
        scale = (omega / self._reference_omega) ** 2
        if synchronous is None:
            return scale[:, None] * sys.unbalance_force[None, :]
        count, nb = synchronous.shape[0], synchronous.shape[1]
        k_s = synchronous[..., 2:6].reshape(count, nb, 2, 2)
        c_s = synchronous[..., 6:10].reshape(count, nb, 2, 2)
        whirl = omega[:, None, None]
        z_dynamics = np.zeros((count, 2 * nb, 2 * nb), dtype=complex)
        z_synchronous = np.zeros((count, 2 * nb, 2 * nb), dtype=complex)
        for b in range(nb):
            pair = slice(2 * b, 2 * b + 2)
            z_dynamics[:, pair, pair] = k[:, b] + 1j * whirl * c[:, b]
            z_synchronous[:, pair, pair] = k_s[:, b] + 1j * whirl * c_s[:, b]
        select = self._select  # (2 nb, n)
        matrix = (
            sys.stiffness
            - whirl**2 * sys.mass
            + 1j * whirl * (self._structural_damping + whirl * sys.gyroscopic)
            + select.T @ z_synchronous @ select
        )
        force = sys.unit_unbalance_force
        orbit = np.linalg.solve(matrix, np.broadcast_to(force[:, None], (count, self._n, 1)))[..., 0]
        bearings = orbit @ select.T  # (P, 2 nb)
        difference = ((z_synchronous - z_dynamics) @ bearings[..., None])[..., 0]
        moment = sys.unbalance_moment_kg_m * np.exp(1j * sys.unbalance_phase_rad)
        return (scale * moment)[:, None] * (force[None, :] - difference @ select)

    def discrete_map(
        self, flowrates_m3_s, speed_hz: float, viscosities_pa_s
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(A_d (2n, 2n), G (2n, 3))`` at the operating point (harmonic hold)."""
        return self.discrete_of_block(self.block(flowrates_m3_s, speed_hz, viscosities_pa_s))

    def discrete_of_block(self, block: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(A_d, G)`` of a continuous :meth:`block`: its exponential over one step."""
        return block_map(block, self.dt_s)

    def derivatives(
        self, flowrates_m3_s, speed_hz: float, viscosities_pa_s, axes=AXES
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A_d, G, dA_d (len(axes), 2n, 2n), dG (len(axes), 2n, 3))`` at the operating point.

        Derivatives are per m^3/s (q1, q2), per Hz (speed) and per unit of ln(mu_b): the Frechet
        derivatives of the exponential in the central differences of the block along each axis, all at once
        (:func:`oilwatch.models.system.frechet.expm_frechet_many`).
        """
        return self.derivatives_many([(flowrates_m3_s, speed_hz, viscosities_pa_s, axes)])[0]

    def derivatives_many(self, requests) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """:meth:`derivatives` of each request ``(flowrates, speed, viscosities, axes)``, the blocks of all
        requests assembled in one stacked :meth:`blocks` call, one exponential per request."""
        m = 2 * self._n
        points, layout = [], []
        for flowrates_m3_s, speed_hz, viscosities_pa_s, axes in requests:
            q = np.array(flowrates_m3_s, dtype=float)
            mu = np.array(viscosities_pa_s, dtype=float)
            shifted = [self.shifted_point(axis, q, speed_hz, mu, sign) for axis in axes for sign in (+1, -1)]
            widths = [high[3] - low[3] for high, low in zip(shifted[0::2], shifted[1::2], strict=True)]
            layout.append((len(points), np.array(widths)))
            points += [(q, speed_hz, mu)] + [point[:3] for point in shifted]
        blocks = self.blocks(points)
        answers = []
        for start, widths in layout:
            own = blocks[start : start + 1 + 2 * len(widths)]
            directions = (own[1::2] - own[2::2]) * (self.dt_s / widths)[:, None, None]
            exponential, frechet = expm_frechet_many(own[0] * self.dt_s, directions)
            answers.append((exponential[:m, :m], exponential[:m, m:], frechet[:, :m, :m], frechet[:, :m, m:]))
        return answers

    def second_order_plan(self, flowrates_m3_s, speed_hz: float, viscosities_pa_s, pairs, step=SECOND_STEP):
        """What :meth:`second_derivatives` differences: per distinct first axis i of the axis ``pairs``
        ``(i, j)`` of :data:`AXES`, ``(request, width, [(pair index, j)])``, the request (for
        :meth:`derivatives_many`) at the point one ``step`` along i (relative for flowrates and speed,
        absolute in ln mu; a flowrate towards the middle of its bearing's range) along that i's axes j."""
        q = np.array(flowrates_m3_s, dtype=float)
        mu = np.array(viscosities_pa_s, dtype=float)
        plan = []
        for i in sorted({pair[0] for pair in pairs}):
            wanted = [(p, j) for p, (k, j) in enumerate(pairs) if k == i]
            sign = 1
            if i < 2:
                low, high = self.bearing_flowrate_bounds_m3_s(speed_hz, mu)[i]
                sign = 1 if q[i] < 0.5 * (low + high) else -1
            q_s, speed_s, mu_s, coordinate = self.shifted_point(AXES[i], q, speed_hz, mu, sign, step)
            width = coordinate - self._coordinate(i, q, speed_hz, mu)
            plan.append(((q_s, speed_s, mu_s, tuple(AXES[j] for _, j in wanted)), width, wanted))
        return plan

    @staticmethod
    def forward_differences(first, shifted, plan, count: int) -> tuple[np.ndarray, np.ndarray]:
        """``(d2A_d (count, 2n, 2n), d2G (count, 2n, 3))`` from ``first = (dA_d, dG)`` at the point (row j
        along ``AXES[j]``) and the :meth:`derivatives_many` answers ``shifted`` to a
        :meth:`second_order_plan`."""
        d_a, d_g = first
        second_a = np.empty((count, *d_a.shape[1:]))
        second_g = np.empty((count, *d_g.shape[1:]))
        for (_, _, d_a_s, d_g_s), (_, width, wanted) in zip(shifted, plan, strict=True):
            for row, (p, j) in enumerate(wanted):
                second_a[p] = (d_a_s[row] - d_a[j]) / width
                second_g[p] = (d_g_s[row] - d_g[j]) / width
        return second_a, second_g

    def second_derivatives(
        self, flowrates_m3_s, speed_hz: float, viscosities_pa_s, pairs, first, step: float = SECOND_STEP
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(d2A_d (P, 2n, 2n), d2G (P, 2n, 3))`` along the axis pairs ``(i, j)`` of :data:`AXES` at the
        operating point, given ``first = (dA_d, dG)`` there (row j along ``AXES[j]``): forward differences
        of the exact first derivatives at the point and one step along i (:meth:`second_order_plan`). Why
        forward and this step: :mod:`oilwatch.models.system.operating_correction`."""
        plan = self.second_order_plan(flowrates_m3_s, speed_hz, viscosities_pa_s, pairs, step)
        shifted = self.derivatives_many([request for request, _, _ in plan])
        return self.forward_differences(first, shifted, plan, len(pairs))

    @staticmethod
    def _coordinate(i: int, q: np.ndarray, speed_hz: float, mu: np.ndarray) -> float:
        """The point's own value along axis ``AXES[i]``."""
        return float(q[i]) if i < 2 else speed_hz if i == 2 else math.log(mu[i - 3])

    @staticmethod
    def shifted_point(
        axis: str, q: np.ndarray, speed_hz: float, mu: np.ndarray, sign: int, step: float = 1e-4
    ):
        """(q, speed, mu, coordinate) one small step along an axis (coordinate: the axis' own value)."""
        q, mu = q.copy(), mu.copy()
        if axis in ("q1", "q2"):
            i = AXES.index(axis)
            q[i] *= 1.0 + sign * step
            return q, speed_hz, mu, q[i]
        if axis == "speed":
            speed = speed_hz * (1.0 + sign * step)
            return q, speed, mu, speed
        i = AXES.index(axis) - 3
        log_mu = math.log(mu[i]) + sign * step
        mu[i] = math.exp(log_mu)
        return q, speed_hz, mu, log_mu


def _per_bearing(table, count: int) -> tuple[OperatingTable, ...]:
    """One table per bearing: ``table`` for each, or the given sequence of ``count``."""
    if isinstance(table, OperatingTable):
        return (table,) * count
    tables = tuple(table)
    if len(tables) != count:
        raise ValueError(f"need one dimensionless table per bearing ({count}), got {len(tables)}")
    return tables
