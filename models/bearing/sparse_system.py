"""The film's sparse linear systems: imposing the groove pressure and the direct solve.

Every film problem of :mod:`oilwatch.models.bearing.film` (steady active-set iterations, held-partition
re-solves, squeeze responses) assembles its matrix as CSR data on the grid's fixed sparsity pattern; these two
functions finish and solve it.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from .grid import FilmGrid


def fix_groove_pressure(grid: FilmGrid, data: np.ndarray, rhs: np.ndarray, value: float) -> None:
    """Impose the groove unknown = ``value`` in place, eliminating it from rows and column alike.

    Removing the column too keeps the matrix column diagonally dominant, so elimination needs no
    pivoting.
    """
    slots = grid.slots
    g = grid.groove_node
    g_column = slots["columns"] == g
    rhs -= np.bincount(slots["rows"], weights=data * g_column, minlength=grid.n_nodes) * value
    data[g_column] = 0.0
    data[grid.pattern.indptr[g] : grid.pattern.indptr[g + 1]] = 0.0
    data[slots["diag"][g]] = 1.0
    rhs[g] = value


def sparse_solve(grid: FilmGrid, data: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve M u = rhs for M given as CSR data on ``grid.pattern``.

    The CSR arrays of M are the CSC arrays of M^T: SuperLU factorizes M^T and solves the transposed
    system. M is column diagonally dominant (each column is a Poiseuille Laplacian column or an
    upwind Couette column, both with column sums >= 0), so diagonal pivots are stable.
    """
    n = grid.n_nodes
    mt = sp.csc_matrix((data, grid.pattern.indices, grid.pattern.indptr), shape=(n, n))
    lu = splu(
        mt,
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.0,
        options={"SymmetricMode": True},
    )
    return lu.solve(rhs, trans="T")
