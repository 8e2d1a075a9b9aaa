"""The operating model's compiled transition and the one struct of arrays it reads.

:class:`oilwatch.models.system.operating_model.OperatingAugmentedModel` builds :class:`OperatingArrays` once:
the reference grid's kernel arrays, the correction's matrices (6 first-order ones and one per second-order
axis pair, :mod:`oilwatch.models.system.operating_correction`; refilled in place at each re-centring), the
pairs, the output arrays and one float array ``held`` of what the transition depends on besides its arguments
(the held operating point, the correction's centre and the re-centring thresholds; layout ``HELD_*``). A
transition is then one compiled call, :func:`operating_transition`, which also makes the per-step decisions
(whether the correction applies, whether the centre must move first) in compiled code, not Python. It is a
plain tuple, not a NamedTuple or a structref: numba types a tuple of arrays on its fast dispatch path and
caches the functions that take it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from .flowrate_grid import interpolate_map, row_response

HELD_SPEED = 0
"""The measured speed [Hz] held over the next transitions."""
HELD_LOG_MU = 1
"""ln of the oil law's viscosity [Pa s] at the measured temperature."""
HELD_REFERENCE_SPEED = 2
HELD_REFERENCE_LOG_MU = 3
HELD_CENTRE = 4
"""(q1, q2, speed, ln mu1, ln mu2) of the correction's centre: 5 entries."""
HELD_HAS_CENTRE = 9
HELD_CENTRE_STEP = 10
HELD_SCALES = 11
"""One re-centring threshold of speed [Hz], ln mu and flowrate [m^3/s]: 3 entries."""
HELD_HARD_FACTOR = 14
HELD_MIN_INTERVAL = 15
HELD_POINT = 16
"""The operating point (q1, q2, speed, ln mu1, ln mu2) of the last transition: 5 entries."""
HELD_SIZE = 21

RECENTRE = -1
GRID_ONLY = 0
CORRECTED = 1
""":func:`operating_transition`'s answers: the centre must first move to the point in ``held[HELD_POINT:]``
(nothing computed); or the transition is in the output arrays, the grid map exactly (the reference
point, no factors) or corrected."""


class OperatingArrays(NamedTuple):
    """The fields of the struct (:meth:`as_tuple` is what the compiled code gets)."""

    transition: np.ndarray
    forcing: np.ndarray
    axes: np.ndarray
    corrections_a: np.ndarray
    corrections_g: np.ndarray
    pairs: np.ndarray
    coefficients: np.ndarray
    held: np.ndarray
    next_state: np.ndarray
    state_jacobian: np.ndarray
    flow_jacobian: np.ndarray
    viscosity_jacobian: np.ndarray
    unbalance_jacobian: np.ndarray
    loaded: np.ndarray

    @classmethod
    def allocate(cls, kernel_arrays, n_states: int, pairs) -> OperatingArrays:
        """Zeroed arrays for a model of ``n_states`` on a grid's ``(transition, forcing, axes)``, with
        second-order terms along the axis ``pairs`` ((i, j) of the operating point's five entries)."""
        n = n_states
        count = 6 + len(pairs)
        return cls(
            *kernel_arrays,
            np.zeros((count, n, n)),
            np.zeros((count, n, 3)),
            np.array(pairs, dtype=np.int64).reshape(-1, 2),
            np.zeros(count),
            np.zeros(HELD_SIZE),
            np.zeros(n),
            np.zeros((n, n)),
            np.zeros((n, 2)),
            np.zeros((n, 2)),
            np.zeros((n, 2)),
            np.zeros(3),
        )

    def as_tuple(self) -> tuple[np.ndarray, ...]:
        """The plain tuple of the fields, in order (numba's fast dispatch path)."""
        return tuple(self)


@numba.njit(cache=True)
def operating_transition(
    arrays,
    state,
    w,
    phase,
    unbalance,
    q1,
    q2,
    f1,
    f2,
    with_factors,
    step,
    second_state=None,
    second_next=None,
):  # pragma: no cover - compiled
    """The model's transition from ``state`` at flowrates (q1, q2), viscosity factors (f1, f2) (exactly 1
    unless ``with_factors``), exogenous input ``w`` (3,) (``[1, cos, sin]`` of ``phase`` written into it
    unless ``phase`` is NaN) and the unbalance (a, b) when ``unbalance`` has 2 entries, into the output
    arrays: :data:`GRID_ONLY` or :data:`CORRECTED`; or :data:`RECENTRE` (and nothing computed) when the
    centre must move first. With ``second_state`` (n,), the next state from it at the same point into
    ``second_next`` as well, in the digits of a transition of its own (the filter's prediction where the
    Jacobians are another state's, the shadow of :mod:`oilwatch.estimator.nuisance_start`; the state
    Jacobian is the same at every state).

    As the model's docstring: at the reference point without factors the grid map exactly; else the
    correction ``sum_k c_k (A_k s + G_k w)`` with ``c = (1, d, w_ij d_i d_j)``, ``d = (q - q_c, p - p_c)``,
    ``w_ii = 1/2`` and ``w_ij = 1`` over the second-order pairs (``c = 0`` at the reference point: only the
    factor Jacobian), and the centre is due to move when the point is more than
    ``hard_factor`` thresholds from it, or more than one threshold and ``min_interval`` steps after it moved.
    """
    transition, forcing, axes, ca, cg, pairs, coefficients, held, nxt, ad, jq, jf, ju, loaded = arrays
    log_mu = held[HELD_LOG_MU]
    point = held[HELD_POINT : HELD_POINT + 5]
    point[0], point[1], point[2] = q1, q2, held[HELD_SPEED]
    point[3] = log_mu + math.log(f1)
    point[4] = log_mu + math.log(f2)
    reference_log_mu = held[HELD_REFERENCE_LOG_MU]
    at_reference = (
        point[2] == held[HELD_REFERENCE_SPEED]
        and point[3] == reference_log_mu
        and point[4] == reference_log_mu
    )
    correct = with_factors or not at_reference
    if correct:
        centre = held[HELD_CENTRE : HELD_CENTRE + 5]
        if held[HELD_HAS_CENTRE] == 0.0:
            distance = math.inf
        else:
            distance = max(
                abs(point[2] - centre[2]) / held[HELD_SCALES],
                max(abs(point[3] - centre[3]), abs(point[4] - centre[4])) / held[HELD_SCALES + 1],
                max(abs(point[0] - centre[0]), abs(point[1] - centre[1])) / held[HELD_SCALES + 2],
            )
        if distance > held[HELD_HARD_FACTOR] or (
            distance > 1.0 and step - held[HELD_CENTRE_STEP] >= held[HELD_MIN_INTERVAL]
        ):
            return RECENTRE
        if at_reference:
            coefficients[:] = 0.0
        else:
            coefficients[0] = 1.0
            for k in range(5):
                coefficients[k + 1] = point[k] - centre[k]
            for p in range(pairs.shape[0]):
                i, j = pairs[p, 0], pairs[p, 1]
                weight = 0.5 if i == j else 1.0
                coefficients[6 + p] = weight * coefficients[i + 1] * coefficients[j + 1]
    if not math.isnan(phase):
        w[0], w[1], w[2] = 1.0, math.cos(phase), math.sin(phase)
    loaded[0] = w[0]
    with_unbalance = unbalance.shape[0] == 2
    if with_unbalance:
        a, b = unbalance[0], unbalance[1]
        loaded[1] = a * w[1] - b * w[2]
        loaded[2] = a * w[2] + b * w[1]
    else:
        loaded[1] = w[1]
        loaded[2] = w[2]
    interpolate_map(transition, forcing, axes, state, loaded, q1, q2, nxt, ad, jq, second_state, second_next)
    if correct:
        _apply_correction(
            ca, cg, pairs, coefficients, state, loaded, nxt, ad, jq, jf, f1, f2, second_state, second_next
        )
    if with_unbalance:
        _unbalance_jacobian(forcing, axes, ca.shape[0], cg, coefficients, not at_reference, w, q1, q2, ju)
    return CORRECTED if correct else GRID_ONLY


# Reassociation lets the compiler vectorize the row sums (a few ulps from the sequential sums); no other
# fast-math assumption.
@numba.njit(cache=True, fastmath={"reassoc", "contract"})
def _apply_correction(
    ca, cg, pairs, coefficients, state, w, nxt, ad, jq, jf, f1, f2, second_state=None, second_next=None
):  # pragma: no cover - compiled
    """Add ``sum_k c_k (A_k s + G_k w)`` to the map; the q and ln mu Jacobians from the derivative terms
    (a second-order term ``w_ij d_i d_j`` adds ``d_j`` times its ``A s + G w`` along axis i and ``d_i``
    along j), the latter divided by the viscosity factors (the Jacobian per unit of factor). With
    ``second_state``, its ``sum_k c_k (A_k s + G_k w)`` added to ``second_next``, its row sums written as
    the first state's (so that they vectorize alike: the digits of a call of its own)."""
    n = state.shape[0]
    for r in range(n):
        jf[r, 0] = 0.0
        jf[r, 1] = 0.0
    corrected = coefficients[0] != 0.0
    for k in range(ca.shape[0]):
        if k >= 6 and not corrected:
            break
        c = coefficients[k]
        a_k = ca[k]
        g_k = cg[k]
        if c != 0.0:
            for r in range(n):
                row = a_k[r]
                out = ad[r]
                for col in range(n):
                    out[col] += c * row[col]
        for r in range(n):
            y = row_response(a_k, g_k, r, state, w)
            if c != 0.0:
                nxt[r] += c * y
                if second_state is not None:
                    second_next[r] += c * row_response(a_k, g_k, r, second_state, w)
            if k == 1 and corrected:
                jq[r, 0] += y
            elif k == 2 and corrected:
                jq[r, 1] += y
            elif k == 4:
                jf[r, 0] += y
            elif k == 5:
                jf[r, 1] += y
            elif k >= 6 and corrected:
                i, j = pairs[k - 6, 0], pairs[k - 6, 1]
                _add_along(i, coefficients[j + 1] * y, r, jq, jf)
                if i != j:
                    _add_along(j, coefficients[i + 1] * y, r, jq, jf)
    for r in range(n):
        jf[r, 0] /= f1
        jf[r, 1] /= f2


@numba.njit(cache=True, inline="always")
def _add_along(axis, value, r, jq, jf):  # pragma: no cover - compiled
    """Add ``value`` to row r of the Jacobian along operating axis ``axis`` (q1, q2, speed: none, ln mu1,
    ln mu2)."""
    if axis < 2:
        jq[r, axis] += value
    elif axis > 2:
        jf[r, axis - 3] += value


@numba.njit(cache=True)
def _unbalance_jacobian(forcing, axes, count, cg, coefficients, harmonic, w, q1, q2, ju):  # pragma: no cover
    """``ju`` (n, 2): the unbalance Jacobian from the harmonic columns of G at the grid node nearest to the
    flowrates (ghost layer included), corrected when ``harmonic``."""
    i = 1 + min(max(round((q1 - axes[0]) / axes[1]), 0), int(axes[2]) - 1)
    j = 1 + min(max(round((q2 - axes[3]) / axes[4]), 0), int(axes[5]) - 1)
    cosine, sine = w[1], w[2]
    for r in range(ju.shape[0]):
        g1, g2 = forcing[i, j, r, 1], forcing[i, j, r, 2]
        if harmonic:
            c1 = 0.0
            c2 = 0.0
            for k in range(count):
                c1 += coefficients[k] * cg[k, r, 1]
                c2 += coefficients[k] * cg[k, r, 2]
            g1 += c1
            g2 += c2
        ju[r, 0] = g1 * cosine + g2 * sine
        ju[r, 1] = g2 * cosine - g1 * sine
