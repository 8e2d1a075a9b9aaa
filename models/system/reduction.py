"""Craig-Bampton reduction of the rotor, keeping the bearing dofs physical, with static correction.

The basis holds (i) one static constraint mode per bearing dof, (ii) the fixed-interface normal modes below a
cut-off frequency, and (iii) one residual-flexibility vector per interior load pattern (gravity, unbalance),
mass-orthogonalized against the kept modes. With (iii) the static response to those loads is exact for any
bearing stiffness, and the harmonic unbalance response converges quickly with the number of modes.

Because the bearing dofs stay physical, the bearing stiffness and damping, which carry the flowrate
dependence, enter the reduced matrices unchanged.

References: R. R. Craig and M. C. C. Bampton, "Coupling of substructures for dynamic analyses",
AIAA J. 6 (1968) 1313-1319; Friswell et al., Dynamics of Rotating Machines (2010),
section 6.6 (model reduction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh, solve

from ..validation import InputError, require_positive


@dataclass(frozen=True)
class ReductionBasis:
    """A reduction ``r = basis @ eta`` of the physical dofs.

    Attributes
    ----------
    basis : (n_dof, n_reduced) transformation; its first ``len(boundary_dofs)`` columns are the static
        constraint modes, so ``eta[:n_boundary]`` are the boundary dofs' physical displacements.
    boundary_dofs : indices of the kept physical dofs, in the order of the first reduced coordinates.
    mode_frequencies_hz : natural frequencies of the kept fixed-interface modes [Hz].
    n_residual_vectors : number of static-correction columns at the end of the basis.
    """

    basis: np.ndarray
    boundary_dofs: np.ndarray
    mode_frequencies_hz: np.ndarray
    n_residual_vectors: int

    @property
    def n_reduced(self) -> int:
        """Number of reduced coordinates."""
        return self.basis.shape[1]

    def project(self, matrix: np.ndarray) -> np.ndarray:
        """Return ``basis.T @ matrix @ basis`` for an (n_dof, n_dof) matrix."""
        return self.basis.T @ matrix @ self.basis


def craig_bampton(
    mass: np.ndarray,
    stiffness: np.ndarray,
    boundary_dofs: np.ndarray,
    cutoff_hz: float,
    interior_loads: np.ndarray | None = None,
) -> ReductionBasis:
    """Build the Craig-Bampton basis with static correction.

    Parameters
    ----------
    mass, stiffness : (n_dof, n_dof) symmetric matrices of the free rotor [kg], [N/m].
    boundary_dofs : indices of the dofs kept physical (the bearing x, y dofs).
    cutoff_hz : keep the fixed-interface modes whose natural frequency is below this [Hz].
    interior_loads : (n_dof, n_loads) load patterns whose static response must be exact (gravity, the
        unbalance force's x and y columns); only their interior part matters.
    """
    require_positive("cutoff_hz", cutoff_hz, "Hz")
    n_dof = mass.shape[0]
    boundary = np.asarray(boundary_dofs, dtype=int)
    if boundary.size == 0 or np.unique(boundary).size != boundary.size:
        raise InputError("boundary_dofs must be a non-empty list of distinct dof indices")
    if boundary.min() < 0 or boundary.max() >= n_dof:
        raise InputError(f"boundary_dofs must lie in [0, {n_dof - 1}]")
    interior = np.setdiff1d(np.arange(n_dof), boundary)
    k_ii = stiffness[np.ix_(interior, interior)]
    m_ii = mass[np.ix_(interior, interior)]
    constraint = -solve(k_ii, stiffness[np.ix_(interior, boundary)], assume_a="sym")

    eigenvalues, shapes = eigh(k_ii, m_ii)
    frequencies_hz = np.sqrt(np.clip(eigenvalues, 0.0, None)) / (2.0 * np.pi)
    kept = frequencies_hz < cutoff_hz
    modes = shapes[:, kept]

    residuals = np.zeros((interior.size, 0))
    if interior_loads is not None:
        flexible = solve(k_ii, np.atleast_2d(interior_loads.T).T[interior], assume_a="sym")
        # Remove what the kept modes already represent (mass-orthogonal projection), then
        # orthonormalize, dropping directions that are already spanned.
        flexible -= modes @ (modes.T @ (m_ii @ flexible))
        residuals = _mass_orthonormal_columns(flexible, m_ii)

    n_b, n_m, n_r = boundary.size, modes.shape[1], residuals.shape[1]
    basis = np.zeros((n_dof, n_b + n_m + n_r))
    basis[boundary, np.arange(n_b)] = 1.0
    basis[interior, :n_b] = constraint
    basis[interior, n_b : n_b + n_m] = modes
    basis[interior, n_b + n_m :] = residuals
    return ReductionBasis(basis, boundary, frequencies_hz[kept], n_r)


def _mass_orthonormal_columns(vectors: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Mass-orthonormalize the columns of ``vectors``, dropping numerically dependent ones."""
    kept: list[np.ndarray] = []
    for column in vectors.T:
        v = column.copy()
        for u in kept:
            v -= u * (u @ mass @ v)
        norm = np.sqrt(v @ mass @ v)
        reference = np.sqrt(column @ mass @ column)
        if reference > 0.0 and norm > 1e-8 * reference:
            kept.append(v / norm)
    return np.array(kept).T if kept else np.zeros((vectors.shape[0], 0))
