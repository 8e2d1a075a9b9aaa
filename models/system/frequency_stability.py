"""Stability of the rotor on films whose coefficients depend on the whirl frequency.

A mode whirling at omega sees the film's coefficients at omega, K(omega) and C(omega)
(:mod:`oilwatch.models.bearing.dynamic`), not the quasi-static ones. Each mode's eigenvalue is therefore found
by a fixed-point iteration: start from the quasi-static (frozen-content) modes, evaluate K, C at the
mode's damped frequency Im(lambda), recompute the modes, follow the one nearest in frequency, repeat
until the frequency settles. At the instability threshold lambda = i omega exactly, so the
iteration's log decrement crosses zero at the threshold of the linearized frequency-dependent model
(away from it, using K(omega), C(omega) at the real frequency of a decaying mode is the usual
approximation). The threshold is bracketed by bisection on the speed, each speed with its own film
equilibrium.

Reference: J. W. Lund, "Review of the concept of dynamic coefficients for fluid film journal
bearings", J. Tribol. 109 (1987) 37-41 (frequency-dependent coefficients in stability analysis).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..bearing.dynamic import FilmImpedance
from ..bearing.equilibrium import coefficients_at, static_equilibrium
from ..bearing.grid import Mesh
from ..bearing.supply import SupplyFlow
from ..machine import Machine
from ..rotor.assembly import Rotor
from ..rotor.modal import damped_modes, whirl_direction
from ..rotor.supports import LinearBearing
from ..validation import InputError

WHIRL_RATIO_STARTS = (0.4, 0.45, 0.5, 0.55)
"""Whirl/spin frequency ratios from which the film's half-frequency whirl root is searched."""


@dataclass(frozen=True)
class WhirlMode:
    """A mode with its frequency-consistent film coefficients: frequency_hz, log_decrement, whirl."""

    frequency_hz: float
    log_decrement: float
    whirl: str
    iterations: int
    eigenvalue: complex | None = None


def film_impedances(machine: Machine, rotor: Rotor, speed_hz: float, flowrate_m3_s: float, mesh: Mesh):
    """(impedances, quasi-static (K, C) per bearing) at each bearing's static equilibrium at ``speed_hz``."""
    supply = SupplyFlow(flowrate_m3_s)
    cache: dict[tuple, tuple] = {}  # bearings of one geometry and load share their solve
    impedances, quasi_static = [], []
    for bearing, load in zip(machine.bearings, rotor.bearing_static_loads_n, strict=True):
        key = (bearing, round(float(load), 6))
        if key not in cache:
            eq = static_equilibrium(bearing, load, speed_hz, supply, mesh)
            cache[key] = (
                FilmImpedance(eq.film, eq.eccentricity_m, speed_hz),
                coefficients_at(bearing, eq, speed_hz, supply, mesh),
            )
        impedances.append(cache[key][0])
        quasi_static.append(cache[key][1])
    return impedances, quasi_static


def _modes(rotor, speed_hz, coefficients, n_modes):
    bearings = [
        LinearBearing(node, k, c) for node, (k, c) in zip(rotor.bearing_nodes, coefficients, strict=True)
    ]
    return damped_modes(rotor, speed_hz, bearings, n_modes)


def whirl_modes(
    rotor: Rotor,
    speed_hz: float,
    impedances,
    quasi_static,
    n_modes: int = 6,
    tolerance_hz: float = 1e-4,
    max_iterations: int = 60,
    dt_s: float | None = None,
) -> list[WhirlMode]:
    """The subsynchronous modes among the ``n_modes`` lowest, each iterated to its own whirl frequency
    (see the module docstring) and followed by whirl direction and frequency.

    ``dt_s``: evaluate the films' discrete-time response of a transient run with that step instead of
    the continuous one.
    """
    start = [m for m in _modes(rotor, speed_hz, quasi_static, n_modes) if m.frequency_hz < speed_hz]
    out = []
    for mode in start:
        f = mode.frequency_hz
        for iteration in range(1, max_iterations + 1):
            coefficients = [z.coefficients(2.0 * np.pi * f, dt_s) for z in impedances]
            modes = [m for m in _modes(rotor, speed_hz, coefficients, n_modes) if m.whirl == mode.whirl]
            nearest = min(modes, key=lambda m, f=f: abs(m.frequency_hz - f))
            if abs(nearest.frequency_hz - f) < tolerance_hz:
                out.append(WhirlMode(nearest.frequency_hz, nearest.log_decrement, nearest.whirl, iteration))
                break
            # Damped fixed point: the plain one can oscillate where K(omega) varies fast.
            f = 0.5 * (f + nearest.frequency_hz)
        else:
            raise RuntimeError(
                f"whirl frequency iteration did not converge at {speed_hz:g} Hz from {mode.frequency_hz:g} Hz"
            )
    return out


def film_roots(
    rotor: Rotor,
    speed_hz: float,
    impedances,
    quasi_static,
    n_modes: int = 6,
    tolerance: float = 1e-9,
    max_iterations: int = 40,
) -> list[WhirlMode]:
    """Roots lambda of det(M l^2 + D l + K + sum_b P_b^T Z_b(l) P_b) = 0 near the subsynchronous modes.

    The exact eigenvalues of the rotor on the linearized transient films (Z analytic in s, see
    :mod:`oilwatch.models.bearing.dynamic`), each found from a quasi-static mode by successive linearization:
    Z(l) ~ Z(l_k) + (l - l_k) Z'(l_k), a quadratic eigenproblem with complex coefficient matrices
    whose root nearest l_k is l_{k+1} (Newton-like, converges in a few steps). At the threshold the
    root is i omega, where it coincides with the real-frequency iteration of :func:`whirl_modes`.
    """
    n = rotor.n_dof
    omega = 2.0 * np.pi * speed_hz
    mass_inv = np.linalg.inv(rotor.mass_matrix)
    damping0 = rotor.damping_matrix + omega * rotor.gyroscopic_matrix
    blocks = [slice(4 * (node - 1), 4 * (node - 1) + 2) for node in rotor.bearing_nodes]
    start = [m for m in _modes(rotor, speed_hz, quasi_static, n_modes) if m.frequency_hz < speed_hz]

    def linearized(lam, weight):
        """State matrix with Z(l) ~ Z(lam) + (l - lam) Z'(lam), blended with the quasi-static films."""
        stiffness = rotor.stiffness_matrix.astype(complex)
        damping = damping0.astype(complex)
        step = 1e-6 * abs(lam)
        for z, (k_qs, c_qs), block in zip(impedances, quasi_static, blocks, strict=True):
            z0 = z.impedance(lam)
            slope = (z.impedance(lam + step) - z.impedance(lam - step)) / (2.0 * step)
            stiffness[block, block] += weight * (z0 - lam * slope) + (1.0 - weight) * k_qs
            damping[block, block] += weight * slope + (1.0 - weight) * c_qs
        a = np.zeros((2 * n, 2 * n), dtype=complex)
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -mass_inv @ stiffness
        a[n:, n:] = -mass_inv @ damping
        return a

    def follow(lam, shape, weights):
        """Iterate one root from (lam, shape) through the homotopy weights; None if it is lost."""
        iteration = 0
        for weight in weights:
            for _ in range(max_iterations):
                iteration += 1
                eigenvalues, vectors = np.linalg.eig(linearized(lam, weight))
                near = np.flatnonzero(np.abs(eigenvalues - lam) < 0.3 * abs(lam))
                if near.size == 0:  # a heavily damped start whose root left the neighbourhood
                    return None
                if shape is None:
                    pick = near[np.argmin(np.abs(eigenvalues[near] - lam))]
                else:
                    disp = vectors[:n, near]
                    mac = np.abs(shape.conj() @ disp) ** 2 / (
                        np.linalg.norm(shape) ** 2 * np.linalg.norm(disp, axis=0) ** 2
                    )
                    pick = near[np.argmax(mac)]
                new = complex(eigenvalues[pick])
                converged = abs(new - lam) < tolerance * abs(lam)
                lam, shape = new, vectors[:n, pick]
                if converged:
                    break
            else:
                return None
        return lam, shape, iteration

    found = []
    # Rotor modes, from the quasi-static films by homotopy, followed by their shapes (MAC) ...
    for mode in start:
        found.append(follow(mode.eigenvalue, mode.shape, (0.25, 0.5, 0.75, 1.0)))
    # ... and the film's own half-frequency whirl root, which has no quasi-static counterpart.
    for ratio in WHIRL_RATIO_STARTS:
        f0 = 2.0 * np.pi * ratio * speed_hz
        found.append(follow(complex(-0.01 * f0, f0), None, (1.0,)))
    out: list[WhirlMode] = []
    for item in found:
        if item is None or item[0].imag <= 0.0:
            continue
        lam, shape, iteration = item
        if any(abs(lam - m.eigenvalue) < 1e-6 * abs(lam) for m in out):
            continue
        out.append(
            WhirlMode(
                lam.imag / (2.0 * np.pi),
                -2.0 * np.pi * lam.real / lam.imag,
                whirl_direction(shape),
                iteration,
                lam,
            )
        )
    return sorted(out, key=lambda m: m.frequency_hz)


def least_stable(modes: list[WhirlMode]) -> WhirlMode:
    """The mode of smallest log decrement."""
    return min(modes, key=lambda m: m.log_decrement)


def frequency_dependent_threshold(
    machine: Machine,
    rotor: Rotor,
    flowrate_m3_s: float,
    mesh: Mesh,
    low_hz: float,
    high_hz: float,
    tolerance_hz: float = 0.05,
    dt_s: float | None = None,
    progress=None,
    method: str = "roots",
) -> dict:
    """Instability threshold [Hz] of the frequency-dependent linear model, bisected in [low, high].

    ``method``: "roots" (:func:`film_roots`, the exact eigenvalues) or "real-frequency"
    (:func:`whirl_modes`; ``dt_s`` applies to it). Returns threshold_hz, whirl_frequency_hz at the
    threshold, method, and the evaluated (speed, least log decrement, its frequency) triples.
    """
    if method not in ("roots", "real-frequency"):
        raise InputError(f"method must be 'roots' or 'real-frequency', got {method!r}")
    evaluated = []

    def least(speed):
        impedances, quasi = film_impedances(machine, rotor, speed, flowrate_m3_s, mesh)
        if method == "roots":
            mode = least_stable(film_roots(rotor, speed, impedances, quasi))
        else:
            mode = least_stable(whirl_modes(rotor, speed, impedances, quasi, dt_s=dt_s))
        evaluated.append((float(speed), mode.log_decrement, mode.frequency_hz))
        if progress is not None:
            progress(speed, mode)
        return mode

    lo, hi = least(low_hz), least(high_hz)
    if lo.log_decrement <= 0.0 or hi.log_decrement > 0.0:
        raise InputError(
            f"the threshold is not bracketed by [{low_hz:g}, {high_hz:g}] Hz (least log decrements "
            f"{lo.log_decrement:.3g}, {hi.log_decrement:.3g})"
        )
    a, b = low_hz, high_hz
    la, lb = lo.log_decrement, hi.log_decrement
    fb = hi.frequency_hz
    while b - a > tolerance_hz:
        mid = 0.5 * (a + b)
        mode = least(mid)
        if mode.log_decrement > 0.0:
            a, la = mid, mode.log_decrement
        else:
            b, lb, fb = mid, mode.log_decrement, mode.frequency_hz
    threshold = a + (b - a) * la / (la - lb)
    return {
        "threshold_hz": float(threshold),
        "whirl_frequency_hz": float(fb),
        "method": method,
        "evaluated": evaluated,
    }
