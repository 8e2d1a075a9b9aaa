"""Discretization of the linear rotor-bearing state space over one sampling period.

Two input models are offered for the map ``s_{k+1} = A_d s_k + (input terms)``:

* ``zero_order_hold`` is the paper's Eq. 13: the input is held at its sampled value over the period.
* ``harmonic_input_map`` integrates a constant force plus a harmonic force at the spin frequency exactly, by
  augmenting the state with the exosystem that generates ``cos`` and ``sin`` (Van Loan's block exponential).
  At 75 Hz and 1 ms the unbalance phase advances 27 deg per step, so a held input lags the true force by
  half a step and mis-states the harmonic response; the exact map removes that model error, which the
  estimator would otherwise absorb into the flowrates.

Reference: C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE Trans. Automatic
Control 23 (1978) 395-404.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from ..validation import require_positive


def zero_order_hold(
    state_matrix: np.ndarray, input_matrix: np.ndarray, dt_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(A_d, B_d)`` of Eq. 13: ``expm([[A, B], [0, 0]] dt) = [[A_d, B_d], [0, I]]``.

    Parameters
    ----------
    state_matrix : (n, n) continuous state matrix A [1/s].
    input_matrix : (n, m) continuous input matrix B.
    dt_s : sampling period [s].
    """
    dt_s = require_positive("dt_s", dt_s, "s")
    n, m = input_matrix.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n] = state_matrix
    block[:n, n:] = input_matrix
    exponential = expm(block * dt_s)
    return exponential[:n, :n], exponential[:n, n:]


def harmonic_input_map(
    state_matrix: np.ndarray, force_columns: np.ndarray, omega_rad_s: float, dt_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Exact one-step map for ``s' = A s + b0 + bc cos(w t) + bs sin(w t)``.

    Parameters
    ----------
    state_matrix : (n, n) continuous state matrix A [1/s].
    force_columns : (n, 3) the input columns ``[b0, bc, bs]`` (already multiplied by the input matrix).
    omega_rad_s : angular frequency w of the harmonic part [rad/s].
    dt_s : step [s].

    Returns
    -------
    (A_d, G) with A_d (n, n) and G (n, 3) such that, with ``w_k = [1, cos(w t_k), sin(w t_k)]``,
    ``s(t_k + dt) = A_d s(t_k) + G w_k`` exactly.
    """
    dt_s = require_positive("dt_s", dt_s, "s")
    return block_map(harmonic_input_block(state_matrix, force_columns, omega_rad_s), dt_s)


def harmonic_input_block(
    state_matrix: np.ndarray, force_columns: np.ndarray, omega_rad_s: float
) -> np.ndarray:
    """The (n + 3) square exponent of :func:`harmonic_input_map`: the state matrix, the input columns and the
    exosystem of the inputs ``d/dt [1, c, s] = [0, -w s, w c]``."""
    n = state_matrix.shape[0]
    block = np.zeros((n + 3, n + 3))
    block[:n, :n] = state_matrix
    block[:n, n:] = force_columns
    block[n + 1, n + 2] = -omega_rad_s
    block[n + 2, n + 1] = omega_rad_s
    return block


def block_map(block: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """``(A_d, G)`` of a :func:`harmonic_input_block` (any (n + 3) square one): its exponential over ``dt_s``,
    split into the state's n columns and the inputs' three."""
    n = block.shape[0] - 3
    exponential = expm(block * dt_s)
    return exponential[:n, :n], exponential[:n, n:]
