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
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def step_residual(indptr, indices, ap, at, storage, rhs, p, theta, out):
    """r_k = b_k - sum_j Ap p_j - sum_j At theta_j - S_k theta_k into ``out``; returns (max |r|, sum r)."""
    worst = 0.0
    total = 0.0
    for k in range(p.size):
        flow = storage[k] * theta[k]
        for s in range(indptr[k], indptr[k + 1]):
            j = indices[s]
            flow += ap[s] * p[j] + at[s] * theta[j]
        r = rhs[k] - flow
        out[k] = r
        total += r
        if abs(r) > worst:
            worst = abs(r)
    return worst, total


@njit(cache=True)
def sweep_factors(diag, ap, at, storage):
    """Per volume: 1 / Ap[k, k], the outflow At[k, k] + S_k of a full volume and its inverse."""
    n = storage.size
    inverse_conductance = np.empty(n)
    outflow = np.empty(n)
    inverse_outflow = np.empty(n)
    for k in range(n):
        d = diag[k]
        inverse_conductance[k] = 1.0 / ap[d]
        outflow[k] = at[d] + storage[k]
        inverse_outflow[k] = 1.0 / outflow[k]
    return inverse_conductance, outflow, inverse_outflow


@njit(cache=True)
def projected_sweeps(indptr, indices, diag, ap, at, factors, rhs, p, theta, relaxation, n_sweeps):
    """``n_sweeps`` projected SOR sweeps in place on ``p`` (scaled pressure) and ``theta``;
    ``factors`` from :func:`sweep_factors`."""
    inverse_conductance, outflow, inverse_outflow = factors
    for _ in range(n_sweeps):
        for k in range(p.size):
            d = diag[k]
            flow = 0.0
            for s in range(indptr[k], indptr[k + 1]):
                j = indices[s]
                flow += ap[s] * p[j] + at[s] * theta[j]
            # b: the balance's right-hand side less the neighbours' flows (the own terms added back).
            b = rhs[k] - flow + ap[d] * p[k] + at[d] * theta[k]
            p_full = (b - outflow[k]) * inverse_conductance[k]
            p_new = p[k] + relaxation * (p_full - p[k]) if theta[k] >= 1.0 else p_full
            if p_new > 0.0:
                p[k] = p_new
                theta[k] = 1.0
            else:
                p[k] = 0.0
                theta[k] = min(b * inverse_outflow[k], 1.0)


@njit(cache=True)
def sor_sweeps(
    indptr,
    indices,
    diag,
    ap,
    at,
    storage,
    rhs,
    p,
    theta,
    relaxation,
    residual_limit,
    mass_limit,
    max_sweeps,
    check_every,
):
    """Projected SOR on the step's balances, in place on ``p`` (scaled pressure) and ``theta``.

    ``ap`` multiplies the scaled pressure; residual_limit, mass_limit [m^3/s]. Returns (sweeps,
    max |r|, sum r, converged). The residual is checked before the first sweep (a converged warm
    start costs one residual pass) and then every ``check_every`` sweeps.
    """
    work = np.empty(p.size)
    worst, total = step_residual(indptr, indices, ap, at, storage, rhs, p, theta, work)
    if worst <= residual_limit and abs(total) <= mass_limit:
        return 0, worst, total, True
    factors = sweep_factors(diag, ap, at, storage)
    done = 0
    while done < max_sweeps:
        batch = min(check_every, max_sweeps - done)
        projected_sweeps(indptr, indices, diag, ap, at, factors, rhs, p, theta, relaxation, batch)
        done += batch
        worst, total = step_residual(indptr, indices, ap, at, storage, rhs, p, theta, work)
        if worst <= residual_limit and abs(total) <= mass_limit:
            return done, worst, total, True
    return max_sweeps, worst, total, False
