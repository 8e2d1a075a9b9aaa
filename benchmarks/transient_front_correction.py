"""Front corrections of the multigrid film step (issue 16, route A): cycles per bearing-step, measured.

An experiment, run by hand; it changes nothing in the library. The multigrid cycle of
:mod:`oilwatch.models.bearing.transient_multigrid` (one projected sweep, then a V-cycle on the pressurized
volumes F with the fill fraction held) is re-run here as a Python loop over the same compiled kernels,
with a correction after each V-cycle, and the cycles each bearing-step takes are counted on the
benchmark's 3 um whirl (240 x 72 mid-plane half, plant tolerances 1e-8 / 1e-7; both bearings):

- ``none``: the library's cycle (the reference count);
- ``band``: the coupled (p, theta) balance of the front band linearized at the current partition
  (dp on its full volumes, dtheta on its cavitated ones, everything else held) solved by sparse LU,
  then projected (p >= 0, 0 <= theta <= 1); the band is the full volumes next to a cavitated one and
  the cavitated volumes next to a full one, widened by ``--band-width`` layers both ways and
  ``--f-depth`` layers into F;
- ``exact-f``: Ap[F, F] dp = r[F] solved exactly in place of the V-cycle (theta held);
- ``schur``: the coupled balance of all of F and the cavitated layer C next to it, theta_C eliminated
  (S = Ap[F, F] - At[F, C] D[C, C]^-1 Ap[C, F], D = At + S_k on C), solved exactly (``--krylov 0``) or
  by ``--krylov`` FGMRES iterations preconditioned by Gauss-Seidel on Ap[F, F] around the library's
  V-cycle (``--smoother sgs``: forward, V-cycle, backward; ``forward``: forward then V-cycle), in place
  of the V-cycle on the cycles ``--only-cycles`` (default all).

    OPENBLAS_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/transient_front_correction.py
        --correction schur --krylov 3 [--steps 32] [--mesh 240 72]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import oilwatch.models.bearing.transient as transient
import oilwatch.models.bearing.transient_multigrid as multigrid
from oilwatch.models.bearing.equilibrium import static_equilibrium
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.bearing.transient_galerkin import build as build_coarse
from oilwatch.models.bearing.transient_galerkin import update as update_coarse
from oilwatch.models.bearing.transient_sweep import (
    conserve_mass,
    projected_sweep_residual,
    step_residual,
    sweep_factors,
)
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor


def _matrices(k, n):
    ap = sp.csr_matrix((k.ap, k.indices, k.indptr), shape=(n, n))
    at = sp.csr_matrix((k.at, k.indices, k.indptr), shape=(n, n))
    adjacent = sp.csr_matrix((np.ones(k.indices.size), k.indices, k.indptr), shape=(n, n))
    return ap, at, adjacent


def _grow(band, adjacent, within=None):
    grown = band | ((adjacent @ band.astype(float)) > 0)
    return grown if within is None else band | (grown & within)


def band_solve(args, k, p, theta, work, log):
    n = p.size
    _, _, adjacent = _matrices(k, n)
    full = theta >= 1.0
    band = (full & ((adjacent @ (~full).astype(float)) > 0)) | (~full & ((adjacent @ full.astype(float)) > 0))
    for _ in range(args.band_width - 1):
        band = _grow(band, adjacent)
    for _ in range(args.f_depth):
        band = _grow(band, adjacent, full)
    step_residual(k, p, theta, work)
    idx = np.flatnonzero(band)
    position = np.full(n, -1)
    position[idx] = np.arange(idx.size)
    keep = band[k.rows] & band[k.indices]
    rows, cols = k.rows[keep], k.indices[keep]
    values = np.where(full[cols], k.ap[keep], k.at[keep])
    m = sp.csr_matrix((values, (position[rows], position[cols])), shape=(idx.size, idx.size))
    m = (m + sp.diags(np.where(full[idx], 0.0, k.storage[idx]))).tocsc()
    start = time.perf_counter()
    x = spla.splu(m).solve(work[idx])
    log["lu_s"].append(time.perf_counter() - start)
    log["size"].append(idx.size)
    f = full[idx]
    p[idx] = np.where(f, np.maximum(p[idx] + x, 0.0), 0.0)
    theta[idx] = np.where(f, 1.0, np.clip(theta[idx] + x, 0.0, 1.0))


def fgmres(apply_a, apply_m, b, m):
    """m iterations of flexible GMRES from 0 (Saad, SIAM J. Sci. Comput. 14, 461, 1993)."""
    beta = np.linalg.norm(b)
    v, z, h = [b / beta], [], np.zeros((m + 1, m))
    for j in range(m):
        z.append(apply_m(v[j]))
        w = apply_a(z[j])
        for i in range(j + 1):
            h[i, j] = w @ v[i]
            w = w - h[i, j] * v[i]
        h[j + 1, j] = np.linalg.norm(w)
        v.append(w / h[j + 1, j] if h[j + 1, j] > 0.0 else w)
    e = np.zeros(m + 1)
    e[0] = beta
    y = np.linalg.lstsq(h, e, rcond=None)[0]
    return sum(yi * zi for yi, zi in zip(y, z, strict=True))


def schur_solve(args, h, k, p, theta, work, full, log):
    n = p.size
    step_residual(k, p, theta, work)
    ap, at, adjacent = _matrices(k, n)
    at = at + sp.diags(k.storage)
    f_idx = np.flatnonzero(full)
    c_idx = np.flatnonzero(~full & ((adjacent @ full.astype(float)) > 0))
    log["size"].append(c_idx.size)
    a_ff = ap[f_idx][:, f_idx].tocsr()
    at_fc, ap_cf = at[f_idx][:, c_idx].tocsr(), ap[c_idx][:, f_idx].tocsr()
    d_cc = spla.splu(at[c_idx][:, c_idx].tocsc())
    r_f, r_c = work[f_idx].copy(), work[c_idx].copy()
    rhs = r_f - at_fc @ d_cc.solve(r_c)
    if args.krylov == 0:
        schur = a_ff - at_fc @ sp.csc_matrix(d_cc.solve(ap_cf.toarray()))
        dp = spla.spsolve(sp.csc_matrix(schur), rhs)
    else:
        lower, upper = sp.tril(a_ff, format="csr"), sp.triu(a_ff, format="csr")
        fine, correction = np.zeros(n), np.zeros(n)

        def apply_s(x):
            return a_ff @ x - at_fc @ d_cc.solve(ap_cf @ x)

        def coarse(v):
            fine[:] = 0.0
            fine[f_idx] = v
            correction[:] = 0.0
            multigrid.v_cycle_correction(h, correction, fine, full, 1)
            return correction[f_idx].copy()

        def precondition(v):
            x = spla.spsolve_triangular(lower, v, lower=True)
            x = x + coarse(v - apply_s(x))
            if args.smoother == "sgs":
                x = x + spla.spsolve_triangular(upper, v - apply_s(x), lower=False)
            return x

        dp = fgmres(apply_s, precondition, rhs, args.krylov)
    dtheta = d_cc.solve(r_c - ap_cf @ dp)
    p[f_idx] = np.maximum(p[f_idx] + dp, 0.0)
    theta[c_idx] = np.clip(theta[c_idx] + dtheta, 0.0, 1.0)


def make_cycles(args, log):
    """The library's ``_cycles`` (same acceptance), with the chosen correction after the V-cycle."""

    def solve(
        correction, k, p, theta, residual_limit, mass_limit, max_cycles, relaxation=multigrid.RELAXATION
    ):
        h, n = correction.arrays, p.size
        work = np.empty(n)
        worst, total = step_residual(k, p, theta, work)
        if worst <= residual_limit and abs(total) <= mass_limit:
            return 0, worst, total, True
        factors = sweep_factors(k)
        mask = np.zeros(n, dtype=np.bool_)
        built = False
        for cycle in range(1, max_cycles + 1):
            worst, total = projected_sweep_residual(k, factors, p, theta, relaxation, work)
            if worst <= residual_limit and abs(total) <= mass_limit:
                worst, total = step_residual(k, p, theta, work)
                if worst <= residual_limit and abs(total) <= mass_limit:
                    return cycle, worst, total, True
            elif worst <= residual_limit:
                worst, total, accepted = conserve_mass(k, p, theta, work, residual_limit, mass_limit)
                if accepted:
                    return cycle, worst, total, True
            now = theta >= 1.0
            switched = np.flatnonzero(now != mask)
            mask[switched] = now[switched]
            if not built:
                build_coarse(h, k, mask)
                built = True
            elif switched.size:
                update_coarse(h, k, mask, switched.astype(np.int64), switched.size)
            chosen = args.only_cycles is None or cycle in args.only_cycles
            if args.correction == "schur" and chosen:
                schur_solve(args, h, k, p, theta, work, mask, log)
            elif args.correction == "exact-f":
                f_idx = np.flatnonzero(mask)
                ap = sp.csr_matrix((k.ap, k.indices, k.indptr), shape=(n, n))
                p[f_idx] += spla.spsolve(ap[f_idx][:, f_idx].tocsc(), work[f_idx])
            else:
                multigrid.v_cycle_correction(h, p, work, mask, correction.smoothing)
                if args.correction == "band":
                    band_solve(args, k, p, theta, work, log)
        return max_cycles, worst, total, False

    return solve


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--correction", choices=("none", "band", "exact-f", "schur"), default="none")
    parser.add_argument("--band-width", type=int, default=1)
    parser.add_argument("--f-depth", type=int, default=0)
    parser.add_argument("--krylov", type=int, default=0, help="FGMRES iterations (0: exact Schur solve)")
    parser.add_argument("--smoother", choices=("sgs", "forward"), default="sgs")
    parser.add_argument("--only-cycles", type=lambda s: [int(c) for c in s.split(",")], default=None)
    parser.add_argument("--mesh", type=int, nargs=2, default=(240, 72))
    parser.add_argument("--steps", type=int, default=16, help="measured steps after 16 warm-up steps")
    args = parser.parse_args()
    log = {"lu_s": [], "size": []}
    transient.multigrid_solve = make_cycles(args, log)  # the experiment's loop in place of the compiled one
    machine = load_machine(None)
    mesh = Mesh(*args.mesh)
    q, speed = machine.lubrication.nominal_flowrate_m3_s, machine.nominal_speed_hz
    load = float(Rotor.from_machine(machine).bearing_static_loads_n[0])
    eq = static_equilibrium(machine.bearing, load, speed, SupplyFlow(q), mesh)
    films = [
        transient.TransientFilm(machine.bearing, speed, mesh, residual_tolerance=1e-8, mass_tolerance=1e-7)
        for _ in range(2)
    ]
    states = [f.from_steady(eq.film, eq.eccentricity_m) for f in films]
    omega, dt, warmup = 2.0 * math.pi * speed, 1.0 / speed / 64, 16
    cycles, balance = [], 0.0
    for step in range(1, warmup + args.steps + 1):
        e = eq.eccentricity_m + 3e-6 * np.array(
            [math.cos(omega * step * dt) - 1.0, math.sin(omega * step * dt)]
        )
        before = states
        states = [f.step(s, e, q, dt) for f, s in zip(films, before, strict=True)]
        if step > warmup:
            cycles.extend(s.sweeps for s in states)
            balance = max(
                balance,
                *(
                    abs(transient.mass_balance_error(f, a, b))
                    for f, a, b in zip(films, before, states, strict=True)
                ),
            )
    print(
        f"{vars(args)}: cycles per bearing-step mean {np.mean(cycles):.2f}, "
        f"median {statistics.median(cycles)}, max {max(cycles)}; active set finished "
        f"{sum(f.fallbacks for f in films)}; largest mass-balance error {balance:.1e} of the supply; "
        f"force {states[0].force_n.round(3)} N"
    )
    if log["size"]:
        print(
            f"correction unknowns (band) or cavitated layer (schur): median {statistics.median(log['size'])}"
        )
    if log["lu_s"]:
        print(f"band LU factor + solve: median {statistics.median(log['lu_s']) * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
