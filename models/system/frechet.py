"""The matrix exponential and its Frechet derivatives in many directions at once.

``scipy.linalg.expm_frechet(A, E)`` evaluates the scaling-Pade-squaring algorithm of Al-Mohy & Higham (2009,
"Computing the Frechet derivative of the matrix exponential, with an application to condition number
estimation", SIAM J. Matrix Anal. Appl. 30(4), 1639-1657, Algorithm 6.4) for one direction E. The operating
model's re-centring (:mod:`oilwatch.models.system.operating_maps`) needs several directions at the same A, and
in that algorithm everything but the terms linear in E depends on A only: the degree and scaling, the powers
of A, the Pade numerator and denominator, the LU factor of the denominator and the squared exponentials.
:func:`expm_frechet_many` computes those once and carries all directions through each matrix product as one
stacked product.

For the operating model's 29 x 29 block and its 5 directions this is one call of about 0.7 ms against 2.2 ms
for five calls of scipy's, with the same digits (at degree 13, the one used there, the same products in the
same order; ``tests/test_frechet.py``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import lu_factor, lu_solve

ELL_13 = 4.74
"""Largest ``||2^-s A||_1`` for the degree-13 Pade approximant at double precision (the paper's Table 6.1)."""
ELL = ((3, 1.08e-2), (5, 2.00e-1), (7, 7.83e-1), (9, 1.78e0))
"""(degree, largest 1-norm) of the lower-degree approximants, as Table 6.1 (scipy's ``ell_table_61``)."""
PADE = {
    3: (120.0, 60.0, 12.0, 1.0),
    5: (30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0),
    7: (17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0),
    9: (
        17643225600.0,
        8821612800.0,
        2075673600.0,
        302702400.0,
        30270240.0,
        2162160.0,
        110880.0,
        3960.0,
        90.0,
        1.0,
    ),
    13: (
        64764752532480000.0,
        32382376266240000.0,
        7771770303897600.0,
        1187353796428800.0,
        129060195264000.0,
        10559470521600.0,
        670442572800.0,
        33522128640.0,
        1323241920.0,
        40840800.0,
        960960.0,
        16380.0,
        182.0,
        1.0,
    ),
}
"""Coefficients of the [m/m] Pade approximants of exp (the paper's (2.3)), constant term first."""


def expm_frechet_many(a: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(exp(A) (N, N), L(A, E_k) (K, N, N))`` for the directions ``E_k`` stacked in ``directions``: the
    algorithm and approximant selection of ``scipy.linalg.expm_frechet`` (module docstring)."""
    a = np.asarray(a, dtype=float)
    e = np.asarray(directions, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1] or e.ndim != 3 or e.shape[1:] != a.shape:
        raise ValueError(f"expected A (N, N) and directions (K, N, N), got {a.shape} and {e.shape}")
    return _scaled_pade(a, e)


def _scaled_pade(a: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 6.4 with every product that involves E done for all directions at once."""
    n = a.shape[0]
    ident = np.identity(n)
    norm = float(np.abs(a).sum(axis=0).max())
    s = 0
    for degree, ell in ELL:
        if norm <= ell:
            u, v, lu, lv = _low_degree(a, e, ident, PADE[degree])
            break
    else:
        s = max(0, math.ceil(math.log2(norm / ELL_13))) if norm > 0.0 else 0
        a = a * 2.0**-s
        e = e * 2.0**-s
        u, v, lu, lv = _degree_13(a, e, ident)
    factor = lu_factor(-u + v)
    r = lu_solve(factor, u + v)
    rhs = lu + lv + (lu - lv) @ r
    k = e.shape[0]
    # one solve for all directions: the right-hand sides side by side
    stacked = lu_solve(factor, rhs.transpose(1, 0, 2).reshape(n, k * n))
    frechet = stacked.reshape(n, k, n).transpose(1, 0, 2)
    for _ in range(s):
        frechet = r @ frechet + frechet @ r
        r = r @ r
    return r, np.ascontiguousarray(frechet)


def _low_degree(a, e, ident, b):
    """U, V, L_U, L_V of the degree-3..9 approximants (the paper's (6.11)-(6.13))."""
    powers, derivatives = [ident, a @ a], [None, a @ e + e @ a]
    while len(powers) < (len(b) + 1) // 2:
        powers.append(powers[-1] @ powers[1])
        derivatives.append(powers[-2] @ derivatives[1] + derivatives[-1] @ powers[1])
    odd = sum(b[2 * j + 1] * powers[j] for j in range(len(powers)))
    even = sum(b[2 * j] * powers[j] for j in range(len(powers)))
    d_odd = sum(b[2 * j + 1] * derivatives[j] for j in range(1, len(powers)))
    d_even = sum(b[2 * j] * derivatives[j] for j in range(1, len(powers)))
    return a @ odd, even, a @ d_odd + e @ odd, d_even


def _degree_13(a, e, ident):
    """U, V, L_U, L_V of the degree-13 approximant (the paper's (6.11)-(6.13), as in its Algorithm 6.4)."""
    b = PADE[13]
    a2 = a @ a
    m2 = a @ e + e @ a
    a4 = a2 @ a2
    m4 = a2 @ m2 + m2 @ a2
    a6 = a2 @ a4
    m6 = a4 @ m2 + m4 @ a2
    w1 = b[13] * a6 + b[11] * a4 + b[9] * a2
    w2 = b[7] * a6 + b[5] * a4 + b[3] * a2 + b[1] * ident
    z1 = b[12] * a6 + b[10] * a4 + b[8] * a2
    z2 = b[6] * a6 + b[4] * a4 + b[2] * a2 + b[0] * ident
    w = a6 @ w1 + w2
    u = a @ w
    v = a6 @ z1 + z2
    lw1 = b[13] * m6 + b[11] * m4 + b[9] * m2
    lw2 = b[7] * m6 + b[5] * m4 + b[3] * m2
    lz1 = b[12] * m6 + b[10] * m4 + b[8] * m2
    lz2 = b[6] * m6 + b[4] * m4 + b[2] * m2
    lw = a6 @ lw1 + m6 @ w1 + lw2
    lu = a @ lw + e @ w
    lv = a6 @ lz1 + m6 @ z1 + lz2
    return u, v, lu, lv
