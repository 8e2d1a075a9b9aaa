"""The transient step's shared arrays: compiled assembly against the discretization, the sweep's residual."""

from __future__ import annotations

import math

import numpy as np
import pytest

from oilwatch.models.bearing.discretization import film_operator
from oilwatch.models.bearing.film import side_leakage
from oilwatch.models.bearing.geometry import JournalBearing
from oilwatch.models.bearing.grid import Mesh, film_grid
from oilwatch.models.bearing.transient_kernels import StepAssembly
from oilwatch.models.bearing.transient_sweep import (
    _relax,
    conserve_mass,
    projected_sweep_residual,
    projected_sweeps,
    step_residual,
    sweep_factors,
)

BEARING = JournalBearing(0.045, 0.070, 120e-6, 0.094, 0.0, 16.2e-3, 35e-3)
OMEGA = 2.0 * math.pi * 75.0
P_REF = 3.0e6


@pytest.mark.parametrize("half", [False, True], ids=["whole", "half"])
def test_assembly_is_the_discretization(half):
    """Ap, At and the end leakage filled in place equal film_operator's at two journal positions."""
    grid = film_grid(BEARING, Mesh(60, 16), half=half)
    assembly = StepAssembly(grid, BEARING.viscosity_pa_s, OMEGA, P_REF)
    rng = np.random.default_rng(3)
    for e in ((30e-6, -70e-6), (-5e-6, -95e-6)):
        arrays = assembly.fill(*e)
        op = film_operator(grid, e, (0.0, 0.0), OMEGA)
        np.testing.assert_allclose(
            arrays.ap, op.ap_data * P_REF, rtol=1e-12, atol=1e-14 * np.abs(arrays.ap).max()
        )
        np.testing.assert_allclose(arrays.at, op.at_data, rtol=1e-12, atol=1e-14 * np.abs(arrays.at).max())
        p = rng.random(grid.n_nodes)
        assert assembly.side_leakage(p) == pytest.approx(side_leakage(op, p * P_REF), rel=1e-12)
    nnz = grid.pattern.nnz
    slots = np.arange(nnz)
    assert np.array_equal(arrays.transpose[arrays.transpose], slots)
    rows = arrays.rows
    assert np.array_equal(rows[arrays.transpose], arrays.indices)
    assert np.array_equal(arrays.ap[arrays.transpose], arrays.ap)  # bitwise symmetric: the sweep relies on it
    assert np.array_equal(arrays.at_transpose, arrays.at[arrays.transpose])


def test_sweep_leaves_the_true_residual():
    """The residual the fused sweep keeps is the residual of its result, to rounding, over a mixed
    partition (full and cavitated volumes, some switching in the sweep)."""
    grid = film_grid(BEARING, Mesh(60, 16), half=True)
    assembly = StepAssembly(grid, BEARING.viscosity_pa_s, OMEGA, P_REF)
    arrays = assembly.fill(20e-6, -80e-6)
    rng = np.random.default_rng(7)
    n = grid.n_nodes
    arrays.storage[:] = 1e-7 * (1.0 + rng.random(n))
    arrays.rhs[:] = 1e-6 * (rng.random(n) - 0.3)
    p = rng.random(n)
    theta = np.where(p > 0.5, 1.0, rng.random(n))
    p[theta < 1.0] = 0.0
    factors = sweep_factors(arrays)
    kept = np.empty(n)
    fresh = np.empty(n)
    for relaxation in (1.0, 1.5):
        worst, total = projected_sweep_residual(arrays, factors, p, theta, relaxation, kept)
        worst_fresh, total_fresh = step_residual(arrays, p, theta, fresh)
        scale = np.abs(fresh).max()
        np.testing.assert_allclose(kept, fresh, rtol=0.0, atol=1e-12 * scale)
        assert worst == pytest.approx(worst_fresh, rel=1e-10)
        assert total == pytest.approx(total_fresh, rel=1e-9, abs=1e-12 * scale)


@pytest.mark.parametrize("half", [False, True], ids=["whole", "half"])
def test_fixed_width_sweep_is_the_csr_sweep(half):
    """The sweeps over the fixed-width rows give bitwise the iterates of Ausas' update read from the
    CSR rows in node order (the whole film has rows that do not fit: they take the CSR path)."""
    grid = film_grid(BEARING, Mesh(60, 16), half=half)
    arrays = StepAssembly(grid, BEARING.viscosity_pa_s, OMEGA, P_REF).fill(20e-6, -80e-6)
    assert (arrays.sweep_csr.size > 0) == (not half)
    rng = np.random.default_rng(13)
    n = grid.n_nodes
    arrays.storage[:] = 1e-7 * (1.0 + rng.random(n))
    arrays.rhs[:] = 1e-6 * (rng.random(n) - 0.3)
    p = rng.random(n)
    theta = np.where(p > 0.5, 1.0, rng.random(n))
    p[theta < 1.0] = 0.0
    factors = sweep_factors(arrays)
    for relaxation in (1.0, 1.3):
        expected_p, expected_theta = p.copy(), theta.copy()
        for _ in range(3):
            for i in range(n):
                _relax(i, arrays, factors, expected_p, expected_theta, relaxation)
        swept_p, swept_theta = p.copy(), theta.copy()
        projected_sweeps(arrays, factors, swept_p, swept_theta, relaxation, 3)
        assert np.array_equal(swept_p, expected_p) and np.array_equal(swept_theta, expected_theta)
        # The sweep that keeps its residual relaxes the groove first.
        expected_p, expected_theta = p.copy(), theta.copy()
        for i in (n - 1, *range(n - 1)):
            _relax(i, arrays, factors, expected_p, expected_theta, relaxation)
        kept_p, kept_theta = p.copy(), theta.copy()
        projected_sweep_residual(arrays, factors, kept_p, kept_theta, relaxation, np.empty(n))
        assert np.array_equal(kept_p, expected_p) and np.array_equal(kept_theta, expected_theta)


def test_mass_correction_zeroes_the_residual_sum():
    """conserve_mass shifts the fill of the cavitated volumes (only those, all by the same amount) so
    that the step's residuals sum to zero; each volume's residual moves by at most the shift times its
    row's fill coefficients (storage and Couette), a share of the sum."""
    grid = film_grid(BEARING, Mesh(60, 16), half=True)
    arrays = StepAssembly(grid, BEARING.viscosity_pa_s, OMEGA, P_REF).fill(20e-6, -80e-6)
    rng = np.random.default_rng(5)
    n = grid.n_nodes
    arrays.storage[:] = 1e-7 * (1.0 + rng.random(n))
    p = rng.random(n)
    theta = np.where(p > 0.5, 1.0, 0.2 + 0.6 * rng.random(n))
    p[theta < 1.0] = 0.0
    residual = np.empty(n)
    step_residual(arrays, np.zeros(n), np.zeros(n), residual)
    arrays.rhs[:] = -residual  # b = A u at u = (p, theta) plus what is added below
    flow = np.empty(n)
    step_residual(arrays, p, theta, flow)
    arrays.rhs[:] -= flow + rng.normal(0.0, 1e-12, n) + 3e-12  # residual: small noise and a common bias
    before = np.empty(n)
    _, total_before = step_residual(arrays, p, theta, before)
    moved = theta.copy()
    out = before.copy()
    worst, total, accepted = conserve_mass(arrays, p, moved, out, 1.0, 1e-9 * abs(total_before))
    cavitated = theta < 1.0
    shift = moved - theta
    assert np.all(shift[~cavitated] == 0.0)
    np.testing.assert_allclose(shift[cavitated], shift[cavitated][0], rtol=1e-9)
    assert shift[cavitated][0] == pytest.approx(total_before / arrays.storage[cavitated].sum(), rel=1e-9)
    assert abs(total) < 1e-9 * abs(total_before) and accepted
    fresh = np.empty(n)
    assert worst == pytest.approx(step_residual(arrays, p, moved, fresh)[0])
    # Each residual moves by at most delta times its row's fill-fraction coefficients (storage, Couette).
    rows = np.repeat(np.arange(n), np.diff(arrays.indptr))
    couette = np.bincount(rows, weights=np.abs(arrays.at), minlength=n)
    bound = abs(shift[cavitated][0]) * (arrays.storage * cavitated + couette)
    assert np.all(np.abs(fresh - before) <= 1.001 * bound + 1e-25)
    assert np.abs(fresh - before).max() < 0.5 * abs(total_before)


def test_incremental_coarse_operators_are_the_full_build():
    """Updating the Galerkin hierarchy for the volumes that switched state gives bitwise the coarse
    operators (and masks, coarsest inverse) of a build from scratch, over several switch rounds."""
    from oilwatch.models.bearing.transient_galerkin import build, update
    from oilwatch.models.bearing.transient_multigrid import CoarseCorrection

    grid = film_grid(BEARING, Mesh(120, 36), half=True)
    arrays = StepAssembly(grid, BEARING.viscosity_pa_s, OMEGA, P_REF).fill(20e-6, -80e-6)
    n = grid.n_nodes
    rng = np.random.default_rng(11)
    incremental, fresh = CoarseCorrection(grid).arrays, CoarseCorrection(grid).arrays
    mask = rng.random(n) < 0.6
    build(incremental, arrays, mask)
    for fraction in (0.002, 0.02, 0.3, 0.0, 1.0):
        switched = np.flatnonzero(rng.random(n) < fraction).astype(np.int64)
        mask[switched] = ~mask[switched]
        update(incremental, arrays, mask, switched, switched.size)
        build(fresh, arrays, mask)
        for level in range(len(fresh.data)):
            assert np.array_equal(incremental.data[level], fresh.data[level])
            assert np.array_equal(incremental.mask[level], fresh.mask[level])
            assert np.array_equal(incremental.count[level], fresh.count[level])
        assert np.array_equal(incremental.coarsest, fresh.coarsest)
