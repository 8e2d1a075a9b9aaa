"""The augmented map of Eqs. 14-16: the discrete rotor-bearing model whose inputs depend on the flowrates.

Two implementations of the estimator's model contract (``oilwatch.estimator.model.AugmentedModel``):

* ``ExactAugmentedModel`` evaluates the matrix exponential and its Frechet derivative at every call: exact,
  and slow (milliseconds). It is the reference for tests and for the baseline filter.
* ``GridAugmentedModel`` interpolates the same maps from a (q1, q2) grid (``flowrate_grid``): microseconds.

The state is ``s = [eta, eta_dot]`` in the system's coordinates (physical dofs, or Craig-Bampton coordinates).
Flowrates are in m^3/s; ``step`` k gives ``t_k = k dt``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cached_property

import numba
import numpy as np
from scipy.linalg import expm_frechet, pinv

from ..validation import InputError, require_positive
from .discretization import block_map, harmonic_input_block
from .flowrate_grid import FlowrateGrid
from .rotor_bearing import RotorBearingSystem

ML_MIN = 1e-6 / 60.0


class _AugmentedModelBase:
    """What both implementations share: sizes, outputs, noise mapping, static state."""

    def __init__(self, system: RotorBearingSystem, dt_s: float, hold: str) -> None:
        self.system = system
        self.dt_s = require_positive("dt_s", dt_s, "s")
        self.hold = hold
        self.n_states = system.n_states
        self.output_matrix = system.output_matrix
        n = system.n_coordinates
        self.velocity_output_matrix = np.hstack(
            [np.zeros((self.output_matrix.shape[0], n)), self.output_matrix[:, :n]]
        )
        self.bearing_flowrate_bounds_m3_s = system.bearing_flowrate_bounds_m3_s
        self.speed_hz = system.speed_hz
        self.nominal_flowrates_m3_s = system.nominal_flowrates_m3_s
        self._transform_pinv = pinv(system.transform)
        clearances = [getattr(t, "metadata", {}).get("bearing", {}).get("clearance_m") for t in system.tables]
        # the probes' physical range (estimator.channels): None when a table does not say
        self.clearance_m = max(clearances) if all(c is not None for c in clearances) else None

    def exogenous(self, step: int) -> np.ndarray:
        """``w_k = [1, cos(Omega t_k), sin(Omega t_k)]`` for ``t_k = k dt``."""
        return self.system.exogenous(step * self.dt_s)

    def physical_covariance(self, displacement_std_m: float, velocity_std_m_s: float) -> np.ndarray:
        """Covariance (2n, 2n) in the model's coordinates of independent errors on every physical dof.

        The paper gives one std for all displacement states and one for all velocity states; rotations get the
        same numerical value (in rad and rad/s), as in the paper's diagonal Q.
        """
        p = self._transform_pinv
        displacement = displacement_std_m**2 * (p @ p.T)
        n = self.system.n_coordinates
        covariance = np.zeros((2 * n, 2 * n))
        covariance[:n, :n] = displacement
        covariance[n:, n:] = displacement * (velocity_std_m_s / displacement_std_m) ** 2
        return 0.5 * (covariance + covariance.T)

    def static_state(self, flowrate_m3_s: np.ndarray) -> np.ndarray:
        """The static equilibrium state (2n,) at the flowrates: static coordinates, zero velocities."""
        state = np.zeros(self.n_states)
        state[: self.system.n_coordinates] = self.system.static_coordinates(flowrate_m3_s)
        return state


class ExactAugmentedModel(_AugmentedModelBase):
    """Augmented map with the exact exponential and its analytic flowrate Jacobian (Frechet derivative).

    The flowrate derivative of the continuous matrices comes from the coefficient tables' interpolation
    derivatives; ``expm_frechet`` carries it through the exponential.
    """

    def __init__(self, system: RotorBearingSystem, dt_s: float = 1e-3, hold: str = "harmonic") -> None:
        super().__init__(system, dt_s, hold)

    def _block(self, flowrate_m3_s: np.ndarray) -> np.ndarray:
        a, b = self.system.state_space(flowrate_m3_s)
        return harmonic_input_block(a, b, self.system.omega_rad_s)

    def transition(
        self, state: np.ndarray, flowrate_m3_s: np.ndarray, step: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s_next, df/ds, df/dq)`` at the flowrates (see ``oilwatch.estimator.model.AugmentedModel``)."""
        q = np.asarray(flowrate_m3_s, dtype=float)
        a_d, forcing = self.system.discrete_map(q, self.dt_s, self.hold)
        w = self.exogenous(step)
        flow_jacobian = np.empty((self.n_states, 2))
        for i in range(2):
            d_ad, d_forcing = self._map_derivative(q, i)
            flow_jacobian[:, i] = d_ad @ state + d_forcing @ w
        return a_d @ state + forcing @ w, a_d, flow_jacobian

    def _map_derivative(self, q: np.ndarray, index: int) -> tuple[np.ndarray, np.ndarray]:
        """d(A_d, G)/dq_index, by the Frechet derivative of the block exponential."""
        step = 1e-4 * max(abs(q[index]), ML_MIN)
        low, high = q.copy(), q.copy()
        lo_bound, hi_bound = self.bearing_flowrate_bounds_m3_s[index]
        low[index] = max(q[index] - step, lo_bound)
        high[index] = min(q[index] + step, hi_bound)
        # The continuous block is affine in the bearing coefficients, which are smooth in q: a central
        # difference of the block (not of the exponential) is exact to O(step^2) and needs no derivative API.
        d_block = (self._block(high) - self._block(low)) / (high[index] - low[index])
        block = self._block(q)
        n = self.n_states
        _, d_exp = expm_frechet(block * self.dt_s, d_block * self.dt_s)
        d_ad, d_forcing = d_exp[:n, :n], d_exp[:n, n:]
        if self.hold == "zoh":
            phase = self.system.omega_rad_s * self.dt_s
            rotate = np.array(
                [[1.0, 0.0, 0.0], [0.0, np.cos(phase), -np.sin(phase)], [0.0, np.sin(phase), np.cos(phase)]]
            )
            d_forcing = d_forcing @ rotate
        return d_ad, d_forcing


class FixedPointMaps:
    """The exact one-step maps of ``system`` at its own speed and film (its flowrate tables): the two methods
    of :class:`oilwatch.models.system.operating_maps.OperatingMaps` that the estimator's information floor
    calls (:class:`oilwatch.estimator.nuisance_start.InformationFloor`), for the model on the flowrate grid,
    whose grid tabulates these maps (harmonic hold)."""

    def __init__(self, system: RotorBearingSystem, dt_s: float) -> None:
        self.system = system
        self.dt_s = require_positive("dt_s", dt_s, "s")

    def block(self, flowrates_m3_s, speed_hz: float, viscosities_pa_s) -> np.ndarray:
        """The continuous block of the map at the flowrates. ``speed_hz`` and ``viscosities_pa_s`` are
        :class:`OperatingMaps`'s arguments; a system on flowrate tables has one speed and one film, its own
        (the :attr:`GridAugmentedModel.operating_point` the floor passes back)."""
        a, b = self.system.state_space(np.asarray(flowrates_m3_s, dtype=float))
        return harmonic_input_block(a, b, self.system.omega_rad_s)

    def discrete_of_block(self, block: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(A_d, G)`` of a continuous :meth:`block`: its exponential over one step."""
        return block_map(block, self.dt_s)


class GridAugmentedModel(_AugmentedModelBase):
    """Augmented map interpolated from a (q1, q2) grid of exact maps: the estimator's fast model.

    Parameters
    ----------
    system : the rotor-bearing system (usually reduced).
    dt_s : sampling period [s].
    hold : "harmonic" (exact loads) or "zoh" (Eq. 13).
    subdivisions : grid intervals per interval of the coefficient tables. The tables interpolate with
        PCHIP, smooth between their nodes but only C1 at them, so the grid's nodes include the tables'
        nodes (when these are uniform, as ``oilwatch bearing-table`` writes them) and the interpolation
        error stays at the fourth-order level inside each table interval.
    progress : called with the number of maps computed so far, for a progress bar.
    grid : the grid these arguments give, built before (a stored copy): used instead of building it.
    """

    def __init__(
        self,
        system: RotorBearingSystem,
        dt_s: float = 1e-3,
        hold: str = "harmonic",
        subdivisions: int = 5,
        progress: Callable[[int], None] | None = None,
        grid: FlowrateGrid | None = None,
    ) -> None:
        super().__init__(system, dt_s, hold)
        if isinstance(subdivisions, bool) or not isinstance(subdivisions, int) or not 1 <= subdivisions <= 50:
            raise InputError(f"subdivisions must be an integer in [1, 50], got {subdivisions!r}")
        q1_nodes, q2_nodes = (
            np.linspace(low, high, (len(table.flowrates_m3_s) - 1) * subdivisions + 1)
            for (low, high), table in zip(self.bearing_flowrate_bounds_m3_s, system.tables, strict=True)
        )
        if grid is None:
            grid = FlowrateGrid.build(
                lambda q1, q2: system.discrete_map((q1, q2), self.dt_s, hold), q1_nodes, q2_nodes, progress
            )
        elif not (
            np.array_equal(grid.q1_nodes_m3_s, q1_nodes) and np.array_equal(grid.q2_nodes_m3_s, q2_nodes)
        ):
            raise InputError("the given flowrate grid's nodes are not this system's (a stale stored grid)")
        self.grid = grid
        # the exact maps the grid tabulates, for the estimator's consider terms (harmonic hold only)
        self.maps = FixedPointMaps(system, self.dt_s) if hold == "harmonic" else None
        n = self.n_states
        self._next = np.empty(n)
        self._transition = np.empty((n, n))
        self._flow_jacobian = np.empty((n, 2))
        self._unbalance_jacobian = np.empty((n, 2))

    def transition(
        self, state: np.ndarray, flowrate_m3_s: np.ndarray, step: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s_next, df/ds, df/dq)``; the arrays are reused on the next call."""
        return self.propagate(state, self.exogenous(step), flowrate_m3_s)

    def propagate(
        self, state: np.ndarray, exogenous: np.ndarray, flowrate_m3_s: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s_next, df/ds, df/dq)`` for a given exogenous input ``w`` (3,); arrays reused next call."""
        return self.grid.propagate(
            state,
            exogenous,
            float(flowrate_m3_s[0]),
            float(flowrate_m3_s[1]),
            self._next,
            self._transition,
            self._flow_jacobian,
        )

    @property
    def operating_point(self) -> tuple[float, float]:
        """(speed [Hz], film viscosity [Pa s]) of the grid's maps: the system's speed and its tables'."""
        viscosity = self.system.tables[0].metadata.get("bearing", {}).get("viscosity_pa_s", math.nan)
        return self.speed_hz, float(viscosity)

    def batch_transition(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
        """``(transition, forcing, axes, Omega [rad/s], dt [s])``: what a compiled loop needs to evaluate
        :meth:`transition` without calling back into Python: ``interpolate_map(transition, forcing, axes,
        s, w, q1, q2, ...)`` of :mod:`oilwatch.models.system.flowrate_grid` with ``w = [1, cos(Omega t),
        sin(Omega t)]``, ``t = step dt``."""
        return (*self.grid.kernel_arrays, float(self.system.omega_rad_s), float(self.dt_s))

    def harmonic_forcing(self, flowrate_m3_s: np.ndarray) -> np.ndarray:
        """The harmonic input columns (n, 2) of ``G`` at the grid node nearest to the flowrates."""
        return self.grid.forcing[self._node(0, flowrate_m3_s[0]), self._node(1, flowrate_m3_s[1]), :, 1:]

    def transition_with_unbalance(
        self, state: np.ndarray, flowrate_m3_s: np.ndarray, step: int, unbalance: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(s_next, df/ds, df/dq, df/du)`` for the unbalance ``u = a + i b`` relative to the machine file's.

        The unbalance load ``Re(u F exp(i Omega t))`` enters the exact map as the exogenous input
        ``[1, a cos - b sin, a sin + b cos]``, so ``s_next`` stays exact. ``df/du`` (n, 2) is
        ``G_h [cos, sin]`` and ``G_h [-sin, cos]`` with the harmonic input columns ``G_h`` of the nearest grid
        node (a Jacobian for the covariance only; the arrays are reused on the next call).
        """
        w = self.exogenous(step)
        a, b = float(unbalance[0]), float(unbalance[1])
        cosine, sine = float(w[1]), float(w[2])
        loaded = np.array([1.0, a * cosine - b * sine, a * sine + b * cosine])
        nxt, ad, jq = self.propagate(state, loaded, flowrate_m3_s)
        rotate_harmonic_columns(self.harmonic_forcing(flowrate_m3_s), cosine, sine, self._unbalance_jacobian)
        return nxt, ad, jq, self._unbalance_jacobian

    def _node(self, axis: int, q: float) -> int:
        """Index (ghost layer included) of the grid node nearest to q along one flowrate axis."""
        first, step, count = self._node_axes[axis]
        return 1 + min(max(round((float(q) - first) / step), 0), count - 1)

    @cached_property
    def _node_axes(self) -> tuple[tuple[float, float, int], tuple[float, float, int]]:
        """(first node, spacing, count) of each flowrate axis, as Python numbers."""
        return tuple(
            (float(nodes[0]), float(nodes[1] - nodes[0]), int(nodes.size))
            for nodes in (self.grid.q1_nodes_m3_s, self.grid.q2_nodes_m3_s)
        )


@numba.njit(cache=True)
def rotate_harmonic_columns(harmonic, cosine, sine, out):  # pragma: no cover - compiled
    """``out[:, 0] = G_h [cos, sin]``, ``out[:, 1] = G_h [-sin, cos]`` for the harmonic columns G_h (n, 2)."""
    for r in range(harmonic.shape[0]):
        out[r, 0] = harmonic[r, 0] * cosine + harmonic[r, 1] * sine
        out[r, 1] = harmonic[r, 1] * cosine - harmonic[r, 0] * sine
