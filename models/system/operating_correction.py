"""The operating model's correction at a centre: its first- and second-order terms from the exact maps, and
when the centre moves (:class:`Recentring`).

:class:`oilwatch.models.system.operating_model.OperatingAugmentedModel` adds to the exact (q1, q2) grid at the
reference operating point p0 the difference ``D(q, p) = A(q, p) - A(q, p0)`` (and the same for G) expanded
about a centre ``x_c = (q_c, p_c)``, ``x = (q1, q2, speed, ln mu1, ln mu2)``, ``d = x - x_c``::

    D(x) ~ D_c + sum_i dD/dx_i d_i + sum_(i, j) in PAIRS w_ij d2D/dx_i dx_j d_i d_j,   w_ii = 1/2, w_ij = 1

The second-order terms are those of each bearing in its own flowrate and film viscosity: (q_b, q_b),
(q_b, ln mu_b), (ln mu_b, ln mu_b). A bearing's film depends on its own flowrate and viscosity only, so the
other second derivatives come from the block exponential's mixing alone. In q the reference grid carries
A's own curvature at p0, so the (q_b, q_b) term is ``d2A/dq_b2 (x_c) - d2A/dq_b2 (q_c, p0)``; the others
are A's at x_c.

Second derivatives are forward differences of the exact first derivatives (Frechet derivatives of the
block exponential, :meth:`OperatingMaps.derivatives`) at the centre and one step along the first axis
(:meth:`OperatingMaps.second_derivatives`): one more exponential per axis i, with its Frechet derivatives
along the pairs' j. The step (:data:`oilwatch.models.system.operating_maps.SECOND_STEP`: 1e-4 of q, 1e-4 in ln
mu, the first derivatives' own) balances the truncation error, half a step times the third derivative
(linear in the step), against the round-off of the first derivatives, themselves central differences of
1e-4; it keeps the truncation far below the neglected third-order term at one re-centring threshold
(75-150 steps). The bearing table
is Catmull-Rom (C1): its second derivative jumps at a table node, so a centre within a step of a node gets
one side's curvature, and a step ranging across a node gets the next piece's curvature wrong by that
jump; the expansion stays second-order accurate within a piece.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .operating_maps import AXES, OperatingMaps

FIRST_ORDER_TERMS = 6
"""Correction terms before the second-order ones: D_c and the first derivatives along the five axes."""
SECOND_ORDER_PAIRS = ((0, 0), (0, 3), (3, 3), (1, 1), (1, 4), (4, 4))
"""Axis pairs (i, j) of :data:`oilwatch.models.system.operating_maps.AXES` with second-order terms (module
docstring)."""


@dataclass(frozen=True)
class Recentring:
    """When the correction's centre moves: speed by ``speed_fraction`` of nominal, either bearing's ln mu by
    ``log_viscosity``, or either flowrate by ``flowrate_fraction`` of nominal; but not sooner than
    ``min_interval_steps`` after the previous move unless the point is ``hard_factor`` thresholds away
    (a fast flowrate transient costs a bounded number of re-centrings; the first-order terms carry it)."""

    speed_fraction: float = 0.02
    log_viscosity: float = 0.015
    flowrate_fraction: float = 0.0075
    min_interval_steps: int = 100
    hard_factor: float = 4.0


def inside(maps: OperatingMaps, q: np.ndarray, speed_hz: float, mu: np.ndarray) -> np.ndarray:
    """``q`` clipped, each bearing's into its own flowrate range at the speed and viscosities (a small margin
    in)."""
    low, high = maps.bearing_flowrate_bounds_m3_s(speed_hz, mu).T
    margin = 1e-3 * (high - low)
    return np.clip(q, low + margin, high - margin)


def fill_correction(
    maps: OperatingMaps,
    point: np.ndarray,
    reference_speed_hz: float,
    reference_viscosity_pa_s: float,
    pairs,
    corrections_a: np.ndarray,
    corrections_g: np.ndarray,
) -> None:
    """The correction's terms at the centre ``point = (q1, q2, speed, ln mu1, ln mu2)`` into
    ``corrections_a`` (6 + P, n, n) and ``corrections_g`` (6 + P, n, 3), in the kernel's order: D_c, the
    first derivatives along :data:`AXES`, then the second derivatives along ``pairs`` (module docstring).

    A flowrate outside the dimensionless table's range at p_c (or p0) is taken at its edge there."""
    mu = np.exp(point[3:5])
    mu0 = np.full(2, reference_viscosity_pa_s)
    speed = point[2]
    q_c = inside(maps, point[0:2], speed, mu)
    q_0 = inside(maps, point[0:2], reference_speed_hz, mu0)
    # the grid's own curvature in q at p0 is A's there: the correction carries the difference
    flow_pairs = [(p, pair) for p, pair in enumerate(pairs) if max(pair) < 2]
    plan_c = maps.second_order_plan(q_c, speed, mu, pairs)
    plan_0 = maps.second_order_plan(q_0, reference_speed_hz, mu0, [pair for _, pair in flow_pairs])
    answers = maps.derivatives_many(
        [(q_c, speed, mu, AXES), (q_0, reference_speed_hz, mu0, AXES[0:2])]
        + [request for request, _, _ in plan_c + plan_0]
    )
    (a_c, g_c, da_c, dg_c), (a_0, g_0, da_0, dg_0) = answers[0:2]
    ca, cg = corrections_a, corrections_g
    ca[0], cg[0] = a_c - a_0, g_c - g_0
    ca[1:3], cg[1:3] = da_c[0:2] - da_0, dg_c[0:2] - dg_0
    ca[3:6], cg[3:6] = da_c[2:5], dg_c[2:5]
    if not pairs:
        return
    first = FIRST_ORDER_TERMS
    shifted_c, shifted_0 = answers[2 : 2 + len(plan_c)], answers[2 + len(plan_c) :]
    ca[first:], cg[first:] = maps.forward_differences((da_c, dg_c), shifted_c, plan_c, len(pairs))
    if flow_pairs:
        second_a, second_g = maps.forward_differences((da_0, dg_0), shifted_0, plan_0, len(flow_pairs))
        for row, (p, _) in enumerate(flow_pairs):
            ca[first + p] -= second_a[row]
            cg[first + p] -= second_g[row]
