"""The fast transient film step: projected SOR sweeps (Ausas, Jai & Buscaglia, J. Tribol. 131, 031702, 2009).

The time step of :class:`oilwatch.models.bearing.transient.TransientFilm` is a mixed complementarity problem:
every control volume k balances

    sum_j Ap[k, j] p_j + sum_j At[k, j] theta_j + S_k theta_k = b_k,    S_k = beta V_k / dt,

with p >= 0, theta <= 1, p (1 - theta) = 0 (``b`` holds the old content and the groove's supply).
Ausas et al. solve it volume by volume: assume the volume full (theta = 1), solve its pressure from
its own balance and over-relax it; a negative pressure means the volume is cavitated (p = 0) and its
balance is solved for theta instead. Warm-started from the previous step (or the previous iterate of
the rotor coupling) the partition is already almost right and only the pressure's small change has
to be relaxed. The sweep runs downstream (the node order follows the shaft's drag), so the upwind
fill fraction is transported within one sweep.

Convergence is judged on the true residual r_k of every balance (recomputed every few sweeps), not
on the size of the last correction: the step is accepted when max |r_k| <= ``residual_tolerance``
times the Couette flow U c L / 2 AND |sum_k r_k| <= ``mass_tolerance`` times the supply flow. The
sum is exactly the step's mass-balance error (the fluxes telescope), so the accepted step meets the
same mass balance as the direct solve. The caller falls back to the active-set solve otherwise.

Mass correction (:func:`conserve_mass`): once every volume meets its tolerance, what is left of the
step's mass-balance error is removed by one uniform shift of the fill fraction of the cavitated
volumes. Their theta columns sum to S_k (the Couette fluxes telescope), so the shift
delta = sum r / sum S zeroes the error; a volume's residual moves by at most delta times its row's
fill coefficients (S_k and its Couette inflow and outflow, all of the order of S_k on the production
mesh), the error spread over thousands of volumes (tested). This is a one-dimensional coarse space
of the oil content, applied where it pays: on 240 x 72 at the plant's tolerances the residual sum
met its tolerance 1-3 cycles after the volumes met theirs (each cycle cutting the residuals about
3-fold once the partition settled, by cycle 4). The step is accepted only on a fresh residual pass.

The kernels take the step's arrays as one :class:`oilwatch.models.bearing.transient_kernels.StepArrays`.
Their hot loops index with unsigned integers: numba indexes an array with a signed one through a
negative-index wraparound, which cost about half of a residual pass on 240 x 72 (the same arithmetic).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .transient_kernels import StepArrays


@njit(cache=True)
def step_residual(k: StepArrays, p, theta, out):
    """r_k = b_k - sum_j Ap p_j - sum_j At theta_j - S_k theta_k into ``out``; returns (max |r|, sum r)."""
    indptr, indices, ap, at = k.indptr, k.indices, k.ap, k.at
    storage, rhs = k.storage, k.rhs
    worst = 0.0
    total = 0.0
    for i in range(p.size):
        flow = storage[i] * theta[i]
        for s in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint64(indices[s])
            flow += ap[s] * p[j] + at[s] * theta[j]
        r = rhs[i] - flow
        out[i] = r
        total += r
        if abs(r) > worst:
            worst = abs(r)
    return worst, total


@njit(cache=True)
def sweep_factors(k: StepArrays):
    """Per volume: 1 / Ap[k, k], the outflow At[k, k] + S_k of a full volume, its inverse, and the
    pressure that outflow needs, (At[k, k] + S_k) / Ap[k, k]."""
    diag, ap, at, storage = k.diag, k.ap, k.at, k.storage
    n = storage.size
    inverse_conductance = np.empty(n)
    outflow = np.empty(n)
    inverse_outflow = np.empty(n)
    outflow_pressure = np.empty(n)
    for i in range(n):
        d = diag[i]
        inverse_conductance[i] = 1.0 / ap[d]
        outflow[i] = at[d] + storage[i]
        inverse_outflow[i] = 1.0 / outflow[i]
        outflow_pressure[i] = outflow[i] * inverse_conductance[i]
    return inverse_conductance, outflow, inverse_outflow, outflow_pressure


@njit(cache=True)
def _row_flows(i, k: StepArrays, p, theta):
    """(rest, latest) of volume ``i`` from its CSR row: its right-hand side less the flows of the
    neighbours that are settled, summed first, and the flow of the neighbour updated just before ``i``
    (the slot left of the diagonal in the node order; 0 if there is none), which enters last."""
    indptr, indices, ap, at = k.indptr, k.indices, k.ap, k.at
    d = k.diag[i]
    first = indptr[i]
    rest = k.rhs[i]
    for s in range(first, d - 1):
        j = indices[s]
        rest -= ap[s] * p[j] + at[s] * theta[j]
    for s in range(d + 1, indptr[i + 1]):
        j = indices[s]
        rest -= ap[s] * p[j] + at[s] * theta[j]
    t = d - 1 if d > first else d
    j = indices[t]
    return rest, ((ap[t] * p[j] + at[t] * theta[j]) if t != d else 0.0)


@njit(cache=True)
def _relax(i, k: StepArrays, factors, p, theta, relaxation):
    """Ausas' projected update of volume ``i`` from its CSR row; returns b, the balance's right-hand
    side less the neighbours' flows.

    The pressure follows from the flow of the neighbour updated just before ``i`` by one multiply-add
    (p_new = base + gain b, base and gain set before it is read, the division a precomputed inverse):
    the sweep waits on that chain at every volume. The update of the textbook form, to rounding."""
    inverse_conductance, inverse_outflow, outflow_pressure = factors[0], factors[2], factors[3]
    rest, latest = _row_flows(i, k, p, theta)
    # A full volume's pressure is over-relaxed: p + w (p_full - p), p_full = b / Ap[k, k] - outflow pressure.
    factor = relaxation if theta[i] >= 1.0 else 1.0
    gain = factor * inverse_conductance[i]
    base = (1.0 - factor) * p[i] - factor * outflow_pressure[i]
    b = rest - latest
    p_new = (base + gain * rest) - gain * latest
    if p_new > 0.0:
        p[i] = p_new
        theta[i] = 1.0
    else:
        p[i] = 0.0
        theta[i] = min(b * inverse_outflow[i], 1.0)
    return b


@njit(cache=True)
def _sweep_rows(k: StepArrays, factors, p, theta, relaxation, out, keep, start, stop, p_new, theta_new):
    """Ausas' update (:func:`_relax`, the same arithmetic in the same order: bitwise) of the volumes
    ``start`` to ``stop`` - 1 from their fixed-width sweep rows. The volume updated just before
    (``i - 1``, the usual last entry of a row) is read from registers (``p_new``, ``theta_new`` on
    entry: the values of ``start - 1``), not from the array it was just stored to: the sweep waits on
    that chain at every volume. ``keep``: also the residual into ``out`` as
    :func:`projected_sweep_residual` says. Returns the last volume's (p, theta)."""
    inverse_conductance, outflow, inverse_outflow, outflow_pressure = factors
    cols, coef, rhs, ap, diag = k.sweep_cols, k.sweep_coef, k.rhs, k.ap, k.diag
    # Unsigned, like the columns (see the module docstring).
    for i in range(np.uint64(start), np.uint64(stop)):
        c0, c1, c2, c3 = cols[i, 0], cols[i, 1], cols[i, 2], cols[i, 3]
        rest = rhs[i]
        rest -= coef[i, 0] * p[c0] + coef[i, 4] * theta[c0]
        rest -= coef[i, 1] * p[c1] + coef[i, 5] * theta[c1]
        rest -= coef[i, 2] * p[c2] + coef[i, 6] * theta[c2]
        p_old, theta_old = p[i], theta[i]
        factor = relaxation if theta_old >= 1.0 else 1.0
        gain = factor * inverse_conductance[i]
        base = (1.0 - factor) * p_old - factor * outflow_pressure[i]
        if c3 == i - np.uint64(1):
            last_p, last_theta = p_new, theta_new
        else:
            last_p, last_theta = p[c3], theta[c3]
        latest = coef[i, 3] * last_p + coef[i, 7] * last_theta
        b = rest - latest
        p_new = (base + gain * rest) - gain * latest
        if p_new > 0.0:
            theta_new = 1.0
        else:
            p_new, theta_new = 0.0, min(b * inverse_outflow[i], 1.0)
        p[i] = p_new
        theta[i] = theta_new
        if keep:
            out[i] = b - ap[diag[i]] * p_new - outflow[i] * theta_new
            dp, dtheta = p_new - p_old, theta_new - theta_old
            for c in range(4):
                out[cols[i, c]] -= coef[i, c] * dp + coef[i, 8 + c] * dtheta
    return p_new, theta_new


@njit(cache=True)
def _relax_kept(i, k: StepArrays, factors, p, theta, relaxation, out):
    """:func:`_relax` of volume ``i`` that also keeps the residual in ``out`` (its own balance, and
    through the transposed entries those of the columns left of the diagonal, updated before it)."""
    indptr, indices, diag, ap, at_transpose = k.indptr, k.indices, k.diag, k.ap, k.at_transpose
    p_old, theta_old = p[i], theta[i]
    b = _relax(i, k, factors, p, theta, relaxation)
    out[i] = b - ap[diag[i]] * p[i] - factors[1][i] * theta[i]
    dp, dtheta = p[i] - p_old, theta[i] - theta_old
    if dp != 0.0 or dtheta != 0.0:
        for s in range(indptr[i], diag[i]):
            out[indices[s]] -= ap[s] * dp + at_transpose[s] * dtheta


@njit(cache=True)
def _sweep_land(k: StepArrays, factors, p, theta, relaxation, out, keep):
    """One sweep of every volume but the groove, in node order: the fixed-width rows by
    :func:`_sweep_rows`, the rare row that does not fit (``sweep_csr``) from its CSR row."""
    p_new, theta_new = 0.0, 0.0
    start = 0
    for i in k.sweep_csr:
        last = (p_new, theta_new)
        p_new, theta_new = _sweep_rows(k, factors, p, theta, relaxation, out, keep, start, i, *last)
        if keep:
            _relax_kept(i, k, factors, p, theta, relaxation, out)
        else:
            _relax(i, k, factors, p, theta, relaxation)
        p_new, theta_new = p[i], theta[i]
        start = i + 1
    _sweep_rows(k, factors, p, theta, relaxation, out, keep, start, p.size - 1, p_new, theta_new)


@njit(cache=True)
def projected_sweeps(k: StepArrays, factors, p, theta, relaxation, n_sweeps):
    """``n_sweeps`` projected SOR sweeps in place on ``p`` (scaled pressure) and ``theta``;
    ``factors`` from :func:`sweep_factors`. The land volumes in node order, then the groove."""
    for _ in range(n_sweeps):
        _sweep_land(k, factors, p, theta, relaxation, p, False)  # no residual kept: ``out`` is not written
        _relax(p.size - 1, k, factors, p, theta, relaxation)


@njit(cache=True)
def projected_sweep_residual(k: StepArrays, factors, p, theta, relaxation, out):
    """One projected sweep as :func:`projected_sweeps` that also leaves the residual of its result in
    ``out`` (as :func:`step_residual`, to rounding): each volume's own balance is evaluated right after
    its update, and the later updates of its neighbours are subtracted through the transposed entries
    (Ap's own, it is symmetric, and ``at_transpose``; about 1.5 sweeps' cost instead of a sweep and a
    residual pass). A row's entries right of the diagonal get the same subtraction, harmlessly: their
    residual is written when they are updated, later in the sweep. The lumped groove, the last node
    of the grid and coupled to its whole rim, is relaxed first, so that the rim sees its new pressure
    within the sweep (a cycle fewer per step on 240 x 72). Returns (max |r|, sum r)."""
    indptr, indices, ap, at = k.indptr, k.indices, k.ap, k.at
    groove = p.size - 1
    _relax(groove, k, factors, p, theta, relaxation)
    _sweep_land(k, factors, p, theta, relaxation, out, True)
    flow = k.storage[groove] * theta[groove]
    for s in range(indptr[groove], indptr[groove + 1]):
        j = indices[s]
        flow += ap[s] * p[j] + at[s] * theta[j]
    out[groove] = k.rhs[groove] - flow
    worst = 0.0
    total = 0.0
    for i in range(p.size):
        total += out[i]
        if abs(out[i]) > worst:
            worst = abs(out[i])
    return worst, total


@njit(cache=True)
def conserve_mass(k: StepArrays, p, theta, out, residual_limit, mass_limit):
    """The mass correction (see the module docstring) of an iterate whose volumes all meet
    ``residual_limit``: theta += sum r / sum S on the cavitated volumes (kept in [0, 1]), then a fresh
    residual into ``out``. Returns (max |r|, sum r, accepted). ``out`` holds the iterate's residual
    on entry."""
    total = 0.0
    storage = 0.0
    for i in range(theta.size):
        total += out[i]
        if theta[i] < 1.0:
            storage += k.storage[i]
    if storage <= 0.0:
        return np.abs(out).max(), total, False
    delta = total / storage
    for i in range(theta.size):
        if theta[i] < 1.0:
            theta[i] = min(max(theta[i] + delta, 0.0), 1.0)
    worst, total = step_residual(k, p, theta, out)
    return worst, total, worst <= residual_limit and abs(total) <= mass_limit


@njit(cache=True)
def sor_sweeps(k: StepArrays, p, theta, relaxation, residual_limit, mass_limit, max_sweeps, check_every):
    """Projected SOR on the step's balances, in place on ``p`` (scaled pressure) and ``theta``.

    residual_limit, mass_limit [m^3/s]. Returns (sweeps, max |r|, sum r, converged). The residual is
    checked before the first sweep (a converged warm start costs one residual pass) and then every
    ``check_every`` sweeps; when only the mass balance fails, :func:`conserve_mass` is tried.
    """
    work = np.empty(p.size)
    worst, total = step_residual(k, p, theta, work)
    if worst <= residual_limit and abs(total) <= mass_limit:
        return 0, worst, total, True
    factors = sweep_factors(k)
    done = 0
    while done < max_sweeps:
        batch = min(check_every, max_sweeps - done)
        projected_sweeps(k, factors, p, theta, relaxation, batch)
        done += batch
        worst, total = step_residual(k, p, theta, work)
        if worst <= residual_limit and abs(total) <= mass_limit:
            return done, worst, total, True
        if worst <= residual_limit:
            worst, total, accepted = conserve_mass(k, p, theta, work, residual_limit, mass_limit)
            if accepted:
                return done, worst, total, True
    return max_sweeps, worst, total, False
