"""The fast transient film step: projected SOR sweeps (Ausas, Jai & Buscaglia, J. Tribol. 131, 031702, 2009).

The time step of :class:`models.bearing.transient.TransientFilm` is a mixed complementarity problem:
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

The kernels take the step's arrays as one :class:`models.bearing.transient_kernels.StepArrays`.
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
        for s in range(indptr[i], indptr[i + 1]):
            j = indices[s]
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


@njit(cache=True, inline="always")
def _relax(i, k: StepArrays, factors, p, theta, relaxation):
    """Ausas' projected update of volume ``i``; returns b, the balance's right-hand side less the
    neighbours' flows.

    The flows of the neighbours that are settled are summed first; the neighbour updated just before
    ``i`` (the slot left of the diagonal in the node order) enters last, and the pressure follows from
    it by one multiply-add (p_new = base + gain b, base and gain set before it is read, the division a
    precomputed inverse): the sweep waits on that chain at every volume. Selects rather than branches
    keep numba's inlined code as fast as a hand-inlined loop. The update of the textbook form, to
    rounding."""
    inverse_conductance, inverse_outflow, outflow_pressure = factors[0], factors[2], factors[3]
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
    # A full volume's pressure is over-relaxed: p + w (p_full - p), p_full = b / Ap[k, k] - outflow pressure.
    factor = relaxation if theta[i] >= 1.0 else 1.0
    gain = factor * inverse_conductance[i]
    base = (1.0 - factor) * p[i] - factor * outflow_pressure[i]
    t = d - 1 if d > first else d
    j = indices[t]
    latest = (ap[t] * p[j] + at[t] * theta[j]) if t != d else 0.0
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
def projected_sweeps(k: StepArrays, factors, p, theta, relaxation, n_sweeps):
    """``n_sweeps`` projected SOR sweeps in place on ``p`` (scaled pressure) and ``theta``;
    ``factors`` from :func:`sweep_factors`."""
    for _ in range(n_sweeps):
        for i in range(p.size):
            _relax(i, k, factors, p, theta, relaxation)


@njit(cache=True)
def projected_sweep_residual(k: StepArrays, factors, p, theta, relaxation, out):
    """One projected sweep as :func:`projected_sweeps` that also leaves the residual of its result in
    ``out`` (as :func:`step_residual`, to rounding): each volume's own balance is evaluated right after
    its update, and the later updates of its neighbours are subtracted through the transposed entries
    (Ap's own, it is symmetric, and ``at_transpose``: read row-wise; about 1.5 sweeps' cost instead of a
    sweep and a residual pass). The lumped groove, the last node
    of the grid and coupled to its whole rim, is relaxed first, so that the rim sees its new pressure
    within the sweep (a cycle fewer per step on 240 x 72). Returns (max |r|, sum r)."""
    indptr, indices, diag, ap, at, at_transpose = k.indptr, k.indices, k.diag, k.ap, k.at, k.at_transpose
    outflow = factors[1]
    groove = p.size - 1
    _relax(groove, k, factors, p, theta, relaxation)
    for i in range(groove):
        p_old, theta_old = p[i], theta[i]
        b = _relax(i, k, factors, p, theta, relaxation)
        out[i] = b - ap[diag[i]] * p[i] - outflow[i] * theta[i]
        dp, dtheta = p[i] - p_old, theta[i] - theta_old
        if dp != 0.0 or dtheta != 0.0:
            for s in range(indptr[i], diag[i]):  # the columns before the diagonal: updated before i
                out[indices[s]] -= ap[s] * dp + at_transpose[s] * dtheta
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
