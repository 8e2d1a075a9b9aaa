"""Tensor-product Catmull-Rom (cubic Hermite) interpolation on uniform grids with ghost nodes.

A uniform grid of nodes is padded with one ghost node on each side, filled by linear extrapolation; the
interpolant in each cell is the cubic Hermite whose node slopes are the central differences of the
neighbouring values (Catmull & Rom 1974; Keys 1981): C1, exact at the nodes, fourth-order accurate
between them for smooth data, and linear in the data (so derivatives of the interpolant are the
derivatives of a fixed linear combination of node values). Used over the two flowrates
(``oilwatch.models.system.flowrate_grid``) and over (Sommerfeld number, flowrate)
(``oilwatch.models.bearing.operating_table``).
"""

from __future__ import annotations

import numba
import numpy as np


def extrapolate_ghosts(table: np.ndarray, axes: int = 2) -> None:
    """Fill the ghost layers of a (n1 + 2, [n2 + 2,] ...) table by linear extrapolation, in place."""
    table[0] = 2.0 * table[1] - table[2]
    table[-1] = 2.0 * table[-2] - table[-3]
    if axes == 2:
        table[:, 0] = 2.0 * table[:, 1] - table[:, 2]
        table[:, -1] = 2.0 * table[:, -2] - table[:, -3]


@numba.njit(cache=True)
def weights(t: float) -> tuple[np.ndarray, np.ndarray]:
    """Weights and their t-derivatives of the four stencil nodes for local coordinate t in [0, 1]."""
    t2 = t * t
    t3 = t2 * t
    values = np.array(
        [
            0.5 * (-t3 + 2.0 * t2 - t),
            0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
            0.5 * (-3.0 * t3 + 4.0 * t2 + t),
            0.5 * (t3 - t2),
        ]
    )
    slopes = np.array(
        [
            0.5 * (-3.0 * t2 + 4.0 * t - 1.0),
            0.5 * (9.0 * t2 - 10.0 * t),
            0.5 * (-9.0 * t2 + 8.0 * t + 1.0),
            0.5 * (3.0 * t2 - 2.0 * t),
        ]
    )
    return values, slopes


@numba.njit(cache=True)
def cell(x: float, x0: float, h: float, n_nodes: int) -> tuple[int, float]:
    """Index of the cell holding x (0 .. n_nodes - 2) and the local coordinate in it."""
    u = (x - x0) / h
    i = min(max(int(np.floor(u)), 0), n_nodes - 2)
    return i, u - i
