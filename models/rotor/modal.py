"""Damped modes, whirl direction and the Campbell diagram of a rotor on linear bearings.

The rotor-bearing equation M r'' + (C + C_b + Omega G) r' + (K + K_b) r = 0 is written in the
first-order form s' = A s, s = [r, r'] (the paper's Eq. 9, 2 n_dof states) and solved with a
dense eigensolver. Reference: Friswell et al., "Dynamics of Rotating Machines" (2010), ch. 3 and 6
(damped natural frequencies, logarithmic decrement, forward/backward whirl, Campbell diagrams).

Root filtering: each oscillatory mode appears as a conjugate pair; only the root with
Im(lambda) > 0 is kept. Roots with Im(lambda) <= sqrt(eps) max|lambda| are discarded: real roots
of overdamped motion and the zero roots of rigid-body motion of an unsupported rotor. They have no
frequency or log decrement; use :func:`undamped_natural_frequencies_hz` to see rigid-body modes.

Mode selection: the ``n_modes`` roots of lowest natural frequency |lambda| are returned, then
sorted by damped frequency Im(lambda). Selecting by |lambda| rather than Im(lambda) keeps out the
nearly critically damped high-order shaft modes (stiffness-proportional damping makes the damping
ratio grow with frequency), whose small Im(lambda) would otherwise pose as low-frequency modes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..validation import InputError, require_non_negative
from .assembly import Rotor
from .supports import BearingSupplier, LinearBearing, bearing_matrices, resolve_bearings


@dataclass(frozen=True, eq=False)
class Mode:
    """One damped mode at a given spin speed.

    Attributes: frequency_hz (damped natural frequency Im(lambda) / 2 pi), log_decrement
    (-2 pi Re(lambda) / Im(lambda); negative means unstable), whirl ("forward" or "backward"),
    eigenvalue lambda [rad/s], shape (n_dof,) complex displacement shape scaled so that its
    largest translational entry is 1.
    """

    frequency_hz: float
    log_decrement: float
    whirl: str
    eigenvalue: complex
    shape: np.ndarray

    @property
    def damping_ratio(self) -> float:
        """zeta = -Re(lambda) / |lambda| [-]."""
        return float(-self.eigenvalue.real / abs(self.eigenvalue))


@dataclass(frozen=True, eq=False)
class CampbellDiagram:
    """Modes over speed, each speed's modes sorted by frequency (no mode tracking).

    Attributes: speeds_hz (n_speeds,), frequencies_hz, log_decrements (n_speeds, n_modes) with
    NaN where fewer modes were found, forward (n_speeds, n_modes) bool, True for forward whirl.
    """

    speeds_hz: np.ndarray
    frequencies_hz: np.ndarray
    log_decrements: np.ndarray
    forward: np.ndarray

    def critical_speeds_hz(self, harmonic: float = 1.0) -> list[float]:
        """Speeds [Hz] where a forward-whirl frequency crosses ``harmonic`` x speed (linear interp)."""
        excess = self.frequencies_hz - harmonic * self.speeds_hz[:, None]
        out = []
        for j in range(excess.shape[1]):
            e, fwd = excess[:, j], self.forward[:, j]
            for i in np.flatnonzero((e[:-1] * e[1:] <= 0.0) & fwd[:-1] & fwd[1:]):
                if e[i] == e[i + 1]:
                    continue
                s0, s1 = self.speeds_hz[i], self.speeds_hz[i + 1]
                out.append(float(s0 + (s1 - s0) * e[i] / (e[i] - e[i + 1])))
        return sorted(set(out))


def _system_matrices(rotor: Rotor, speed_hz: float, bearings: Sequence[LinearBearing]):
    omega = 2.0 * np.pi * speed_hz
    k_b, c_b = bearing_matrices(rotor.n_dof, bearings)
    stiffness = rotor.stiffness_matrix + k_b
    damping = rotor.damping_matrix + c_b + omega * rotor.gyroscopic_matrix
    return stiffness, damping


def state_matrix(rotor: Rotor, speed_hz: float, bearings: Sequence[LinearBearing]) -> np.ndarray:
    """First-order state matrix A (2 n_dof, 2 n_dof) of Eq. 9 with the bearings included [1/s]."""
    stiffness, damping = _system_matrices(rotor, speed_hz, bearings)
    n = rotor.n_dof
    factor = scipy.linalg.cho_factor(rotor.mass_matrix)
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -scipy.linalg.cho_solve(factor, stiffness)
    a[n:, n:] = -scipy.linalg.cho_solve(factor, damping)
    return a


def whirl_direction(shape: np.ndarray) -> str:
    """'forward' if the orbit at the node of largest amplitude turns like the spin (x towards y).

    With x = Re(X e^{i w t}), y = Re(Y e^{i w t}) the orbit turns from +x towards +y when
    Im(X conj(Y)) > 0. At zero speed on isotropic bearings the x and y modes are degenerate pairs
    whose eigenvectors are arbitrary combinations: the label of each member is then arbitrary.
    """
    x, y = shape[0::4], shape[1::4]
    node = int(np.argmax(np.abs(x) ** 2 + np.abs(y) ** 2))
    return "forward" if np.imag(x[node] * np.conj(y[node])) > 0.0 else "backward"


def damped_modes(
    rotor: Rotor,
    speed_hz: float,
    bearings: Sequence[LinearBearing] | BearingSupplier = (),
    n_modes: int = 8,
) -> list[Mode]:
    """The ``n_modes`` lowest oscillatory damped modes at ``speed_hz`` [Hz], sorted by frequency.

    ``bearings`` is a list of :class:`LinearBearing` or a callable speed_hz -> list. Overdamped
    (real) and rigid-body (zero) roots are excluded; "lowest" means lowest |lambda| (see the
    module docstring).
    """
    speed_hz = require_non_negative("speed_hz", speed_hz, "Hz")
    if isinstance(n_modes, bool) or not isinstance(n_modes, int) or n_modes < 1:
        raise InputError(f"n_modes must be an integer >= 1, got {n_modes!r}")
    a = state_matrix(rotor, speed_hz, resolve_bearings(bearings, speed_hz))
    eigenvalues, vectors = scipy.linalg.eig(a, check_finite=False)
    scale = np.max(np.abs(eigenvalues))
    keep = np.flatnonzero(eigenvalues.imag > np.sqrt(np.finfo(float).eps) * scale)
    keep = keep[np.argsort(np.abs(eigenvalues[keep]))][:n_modes]
    keep = keep[np.argsort(eigenvalues.imag[keep])]
    modes = []
    translational = np.zeros(rotor.n_dof, dtype=bool)
    translational[0::4] = translational[1::4] = True
    for index in keep:
        lam = complex(eigenvalues[index])
        shape = vectors[: rotor.n_dof, index]
        peak = np.argmax(np.where(translational, np.abs(shape), 0.0))
        shape = shape / shape[peak]
        modes.append(
            Mode(
                frequency_hz=lam.imag / (2.0 * np.pi),
                log_decrement=-2.0 * np.pi * lam.real / lam.imag,
                whirl=whirl_direction(shape),
                eigenvalue=lam,
                shape=shape,
            )
        )
    return modes


def campbell_diagram(
    rotor: Rotor,
    speeds_hz: Sequence[float] | np.ndarray,
    bearings_at: Sequence[LinearBearing] | BearingSupplier = (),
    n_modes: int = 8,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> CampbellDiagram:
    """Damped modes at each speed of ``speeds_hz`` [Hz] (bearings may depend on speed).

    ``progress(done, total)`` is called after each speed (speed-dependent bearings can be slow to evaluate).
    """
    speeds = np.asarray(speeds_hz, dtype=float)
    if speeds.ndim != 1 or speeds.size == 0:
        raise InputError("speeds_hz must be a non-empty 1-D sequence of speeds in Hz")
    for s in speeds:
        require_non_negative("speed_hz", s, "Hz")
    freqs = np.full((speeds.size, n_modes), np.nan)
    logdec = np.full((speeds.size, n_modes), np.nan)
    forward = np.zeros((speeds.size, n_modes), dtype=bool)
    for i, speed in enumerate(speeds):
        for j, mode in enumerate(damped_modes(rotor, float(speed), bearings_at, n_modes)):
            freqs[i, j] = mode.frequency_hz
            logdec[i, j] = mode.log_decrement
            forward[i, j] = mode.whirl == "forward"
        if progress is not None:
            progress(i + 1, speeds.size)
    return CampbellDiagram(speeds, freqs, logdec, forward)


def undamped_natural_frequencies_hz(rotor: Rotor, bearings: Sequence[LinearBearing] = ()) -> np.ndarray:
    """Natural frequencies [Hz] of the non-spinning, undamped rotor, all n_dof, ascending.

    Uses the symmetric part of the bearing stiffness; rigid-body modes of an unsupported rotor
    appear as (numerically) zero frequencies.
    """
    k_b, _ = bearing_matrices(rotor.n_dof, bearings)
    stiffness = rotor.stiffness_matrix + 0.5 * (k_b + k_b.T)
    eigenvalues = scipy.linalg.eigh(stiffness, rotor.mass_matrix, eigvals_only=True)
    return np.sqrt(np.clip(eigenvalues, 0.0, None)) / (2.0 * np.pi)
