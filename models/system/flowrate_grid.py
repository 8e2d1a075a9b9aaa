"""Fast evaluation of the discrete rotor-bearing map over the two supply flowrates.

The one-step map ``s_{k+1} = A_d(q) s_k + G(q) w_k`` (see ``discretization``) is a smooth function of the two
flowrates through the bearing coefficients, but a matrix exponential per step costs far more than the 1 ms
sampling period allows. ``FlowrateGrid`` tabulates ``A_d`` and ``G`` on a uniform (q1, q2) grid once, and
evaluates them, their derivatives and the propagated state with tensor-product Catmull-Rom (cubic Hermite)
interpolation: C1 in q, exact at the nodes, fourth-order accurate between them. One evaluation touches 16
stored matrices and runs in a compiled loop.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np

from ..catmull_rom import cell as _cell
from ..catmull_rom import extrapolate_ghosts as _extrapolate_ghosts
from ..catmull_rom import weights as _catmull_rom_weights
from ..validation import InputError

DiscreteMap = Callable[[float, float], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class FlowrateGrid:
    """Tabulated one-step maps over a uniform (q1, q2) grid, with one ghost node on each side.

    Attributes
    ----------
    q1_nodes_m3_s, q2_nodes_m3_s : grid nodes [m^3/s].
    transition : (n1 + 2, n2 + 2, n, n) ``A_d`` at the nodes, ghost layers linearly extrapolated.
    forcing : (n1 + 2, n2 + 2, n, 3) ``G`` at the nodes, same layout.
    """

    q1_nodes_m3_s: np.ndarray
    q2_nodes_m3_s: np.ndarray
    transition: np.ndarray
    forcing: np.ndarray

    @classmethod
    def build(
        cls,
        discrete_map: DiscreteMap,
        q1_nodes_m3_s: np.ndarray,
        q2_nodes_m3_s: np.ndarray,
        progress: Callable[[int], None] | None = None,
    ) -> FlowrateGrid:
        """Evaluate ``discrete_map(q1, q2) -> (A_d (n, n), G (n, 3))`` at every node of the grid."""
        q1 = np.asarray(q1_nodes_m3_s, dtype=float)
        q2 = np.asarray(q2_nodes_m3_s, dtype=float)
        for name, nodes in (("q1_nodes_m3_s", q1), ("q2_nodes_m3_s", q2)):
            steps = np.diff(nodes)
            if nodes.size < 2 or np.any(steps <= 0) or not np.allclose(steps, steps[0], rtol=1e-9):
                raise InputError(f"{name} must be at least 2 increasing, uniformly spaced nodes")
        a0, g0 = discrete_map(q1[0], q2[0])
        n = a0.shape[0]
        transition = np.zeros((q1.size + 2, q2.size + 2, n, n))
        forcing = np.zeros((q1.size + 2, q2.size + 2, n, g0.shape[1]))
        for i, q1_value in enumerate(q1):
            for j, q2_value in enumerate(q2):
                a, g = (a0, g0) if i == j == 0 else discrete_map(q1_value, q2_value)
                transition[i + 1, j + 1] = a
                forcing[i + 1, j + 1] = g
            if progress is not None:
                progress(q2.size)
        for table in (transition, forcing):
            _extrapolate_ghosts(table)
        return cls(q1, q2, transition, forcing)

    @property
    def n_states(self) -> int:
        """Size n of the state the maps act on."""
        return self.transition.shape[2]

    @property
    def bounds_m3_s(self) -> tuple[float, float, float, float]:
        """``(q1_min, q1_max, q2_min, q2_max)`` [m^3/s]."""
        return (
            self.q1_nodes_m3_s[0],
            self.q1_nodes_m3_s[-1],
            self.q2_nodes_m3_s[0],
            self.q2_nodes_m3_s[-1],
        )

    def propagate(
        self,
        state: np.ndarray,
        exogenous: np.ndarray,
        q1_m3_s: float,
        q2_m3_s: float,
        out_next: np.ndarray | None = None,
        out_transition: np.ndarray | None = None,
        out_flow_jacobian: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(s_next (n,), A_d (n, n), d s_next / d q (n, 2))`` at (q1, q2).

        ``exogenous`` is ``w_k = [1, cos(Omega t_k), sin(Omega t_k)]``. Flowrates outside the grid raise
        InputError. The ``out_*`` arrays, when given, are filled in place (no allocation in a step loop).
        """
        self.check_flowrates(q1_m3_s, q2_m3_s)
        n = self.n_states
        nxt = np.empty(n) if out_next is None else out_next
        ad = np.empty((n, n)) if out_transition is None else out_transition
        jq = np.empty((n, 2)) if out_flow_jacobian is None else out_flow_jacobian
        axes = self._axes
        interpolate_map(self.transition, self.forcing, axes, state, exogenous, q1_m3_s, q2_m3_s, nxt, ad, jq)
        return nxt, ad, jq

    def check_flowrates(self, q1_m3_s: float, q2_m3_s: float) -> None:
        """InputError unless (q1, q2) [m^3/s] lies on the grid."""
        q1_min, q1_max, q2_min, q2_max = self._limits
        if not (q1_min <= q1_m3_s <= q1_max and q2_min <= q2_m3_s <= q2_max):
            raise InputError(
                f"flowrates (q1, q2) = ({q1_m3_s * 6e7:.1f}, {q2_m3_s * 6e7:.1f}) ml/min must lie in "
                f"[{q1_min * 6e7:.1f}, {q1_max * 6e7:.1f}] x [{q2_min * 6e7:.1f}, {q2_max * 6e7:.1f}] ml/min"
            )

    @cached_property
    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(transition, forcing, axes)``: the arguments of :func:`interpolate_map` that describe the grid,
        for compiled callers that fuse the interpolation into their own step."""
        return self.transition, self.forcing, self._axes

    @cached_property
    def _limits(self) -> tuple[float, float, float, float]:
        """:attr:`bounds_m3_s` as Python floats, for the per-step range check."""
        return tuple(float(v) for v in self.bounds_m3_s)

    @cached_property
    def _axes(self) -> np.ndarray:
        """``[q1_0, h1, n1, q2_0, h2, n2]`` of the uniform axes, for the compiled interpolation."""
        q1, q2 = self.q1_nodes_m3_s, self.q2_nodes_m3_s
        return np.array([q1[0], q1[1] - q1[0], q1.size, q2[0], q2[1] - q2[0], q2.size], dtype=float)


# No fast-math: this kernel is compiled into several callers (the plain step, the operating model's
# transition, Python), and with reassociation each build's vectorization, which depends on whether the
# caller was compiled beside it or against its cached copy, moved the sums by a few ulps. The operating
# model's second-order terms amplify such differences to 4e-9 of an estimate over 1.5 s of ramps
# (tests/test_ekf_reference_trace.py failed in one test order and passed in another); in IEEE order every
# build gives the same digits, at about 5 us more per call.
@numba.njit(cache=True)
def interpolate_map(
    transition, forcing, axes, state, exogenous, q1, q2, nxt, ad, jq, second_state=None, second_next=None
):  # pragma: no cover - compiled
    """Into ``nxt``, ``ad``, ``jq``: the interpolated ``A_d s + G w``, ``A_d`` and the flowrate Jacobian at
    (q1, q2), from the grid arrays of :attr:`FlowrateGrid.kernel_arrays`; with ``second_state`` (n,), its
    ``A_d s + G w`` into ``second_next`` in the same arithmetic (the digits of a call of its own), each
    node's matrix read once for both states."""
    h1, h2 = axes[1], axes[4]
    i, t1 = _cell(q1, axes[0], h1, int(axes[2]))
    j, t2 = _cell(q2, axes[3], h2, int(axes[5]))
    wa, da = _catmull_rom_weights(t1)
    wb, db = _catmull_rom_weights(t2)
    n = state.shape[0]
    nxt[:] = 0.0
    ad[:, :] = 0.0
    jq[:, :] = 0.0
    if second_next is not None:
        second_next[:] = 0.0
    blocked = n - n % 4
    for a in range(4):
        for b in range(4):
            w = wa[a] * wb[b]
            d1 = da[a] * wb[b] / h1
            d2 = wa[a] * db[b] / h2
            node_a = transition[i + a, j + b]
            node_g = forcing[i + a, j + b]
            for r in range(n):
                for c in range(n):
                    ad[r, c] += w * node_a[r, c]
            # four rows' sums side by side (each in its own order: the digits of one row at a time), as the
            # sums' latency, not the arithmetic, bounds a row at a time
            for r in range(0, blocked, 4):
                y0, y1, y2, y3 = _four_rows(node_a, node_g, state, exogenous, r)
                _add_row(r, w * y0, d1 * y0, d2 * y0, nxt, jq)
                _add_row(r + 1, w * y1, d1 * y1, d2 * y1, nxt, jq)
                _add_row(r + 2, w * y2, d1 * y2, d2 * y2, nxt, jq)
                _add_row(r + 3, w * y3, d1 * y3, d2 * y3, nxt, jq)
                if second_state is not None:
                    y0, y1, y2, y3 = _four_rows(node_a, node_g, second_state, exogenous, r)
                    second_next[r] += w * y0
                    second_next[r + 1] += w * y1
                    second_next[r + 2] += w * y2
                    second_next[r + 3] += w * y3
            for r in range(blocked, n):
                y = row_response(node_a, node_g, r, state, exogenous)
                _add_row(r, w * y, d1 * y, d2 * y, nxt, jq)
                if second_state is not None:
                    second_next[r] += w * row_response(node_a, node_g, r, second_state, exogenous)


@numba.njit(cache=True, inline="always")
def _four_rows(node_a, node_g, state, exogenous, r):  # pragma: no cover - compiled
    """Rows r .. r + 3 of ``A s + G w`` of one node, each summed in column order."""
    y0, y1, y2, y3 = _four_sums(node_a, state, r, 0.0, 0.0, 0.0, 0.0)
    return _four_sums(node_g, exogenous, r, y0, y1, y2, y3)


@numba.njit(cache=True, inline="always")
def _four_sums(matrix, vector, r, y0, y1, y2, y3):  # pragma: no cover - compiled
    """``y0 .. y3`` plus rows r .. r + 3 of ``matrix @ vector``, each in column order."""
    for c in range(vector.shape[0]):
        v = vector[c]
        y0 += matrix[r, c] * v
        y1 += matrix[r + 1, c] * v
        y2 += matrix[r + 2, c] * v
        y3 += matrix[r + 3, c] * v
    return y0, y1, y2, y3


@numba.njit(cache=True, inline="always")
def row_response(node_a, node_g, r, state, exogenous):  # pragma: no cover - compiled
    """Row r of ``A s + G w``, summed in column order (inlined: a caller's fast-math flags vectorize its
    sums)."""
    y = 0.0
    for c in range(state.shape[0]):
        y += node_a[r, c] * state[c]
    for c in range(exogenous.shape[0]):
        y += node_g[r, c] * exogenous[c]
    return y


@numba.njit(cache=True, inline="always")
def _add_row(r, next_term, q1_term, q2_term, nxt, jq):  # pragma: no cover - compiled
    """One node's terms of row r of the next state and of the flowrate Jacobian."""
    nxt[r] += next_term
    jq[r, 0] += q1_term
    jq[r, 1] += q2_term
