"""Frequency-dependent film coefficients: the small-signal response of the transient p-theta film.

About a steady film (journal at e0, partition and unknowns p0, theta0), a small harmonic journal
motion ``e = e0 + de exp(s t)`` moves the unknowns by ``du exp(s t)`` on the held partition
(full volumes: dp, cavitated ones: d theta). Linearizing the transient balance of
:mod:`oilwatch.models.bearing.transient`, ``d(V theta)/dt + Ap p + At theta = q``, gives one complex sparse
system per frequency:

    [Ap | At + s diag(V0) on the theta columns] du = -(dAp/de p0 + dAt/de theta0) de - s theta0 w.de

``w.de`` is dV/de (the same quadrature as the force). The film force changes by ``dF = w^T dp``;
the impedance is ``Z(s) = -dF/de`` (2 x 2 complex) and at ``s = i omega`` the coefficients are
K(omega) = Re Z, C(omega) = Im Z / omega (Lund's convention, F = F0 - K de - C de_dot).

The fluid-fraction transport is in the theta columns: in the cavitated zone the content lags the
journal. Limits (tested): at omega -> 0, K is the held-partition stiffness of
:func:`oilwatch.models.bearing.equilibrium.coefficients_at`; as omega -> infinity the cavitated content
freezes and C tends to the ``squeeze="full-film"`` damping. Neither quasi-static choice is the
response at a finite whirl frequency; this is.

``symbol`` maps omega to s: ``"continuous"`` s = i omega (the semi-discrete film, dt -> 0) or the
BDF symbol of the time stepper with step dt, ``(beta - sum a_i z^-(i+1)) / dt`` with
z = exp(i omega dt): then Z is the exact small-signal response of the discrete transient equations
(what a transient run with that step reproduces).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..validation import InputError, require_non_negative
from .discretization import film_operator
from .equilibrium import DISPLACEMENT_STEP_RATIO, on_flooded_threshold
from .film import FilmSolution, _reference_pressure
from .transient import BDF, TransientFilm


def bdf_symbol(omega_rad_s: float, dt_s: float | None = None, order: int = 2) -> complex:
    """The Laplace variable s that the time stepper applies to exp(i omega t) (i omega if dt is None)."""
    if dt_s is None:
        return 1j * omega_rad_s
    beta, history = BDF[order]
    z = np.exp(1j * omega_rad_s * dt_s)
    return complex((beta + sum(a * z ** -(i + 1) for i, a in enumerate(history))) / dt_s)


class FilmImpedance:
    """Impedance Z(omega) of the steady film ``film`` of a journal at ``eccentricity_m``.

    ``speed_hz`` is the spin speed of the film [Hz]; the film must come from ``solve_film`` (a
    flow-fed groove: its supply is constant under the motion).
    """

    def __init__(self, film: FilmSolution, eccentricity_m, speed_hz: float):
        grid = film.grid
        self.grid = grid
        self.film = film
        bearing = grid.bearing
        self.omega_spin = 2.0 * math.pi * speed_hz
        e0 = np.asarray(eccentricity_m, dtype=float)
        op = film_operator(grid, tuple(e0), (0.0, 0.0), self.omega_spin)
        self.p_ref = _reference_pressure(op)
        transient = TransientFilm(bearing, speed_hz, grid.mesh, symmetric=False)
        self.volume0 = transient.gap_volume_m3(e0)
        n = grid.n_nodes
        p0 = np.zeros(n)
        theta0 = np.zeros(n)
        p0[grid.node_of_cell] = film.pressure_pa
        theta0[grid.node_of_cell] = film.fill_fraction
        self.theta0 = theta0
        slots = grid.slots
        rows, cols = slots["rows"], slots["columns"]
        full = film.full
        self.full = full
        self.wx, self.wy = op.wx, op.wy
        step = DISPLACEMENT_STEP_RATIO * bearing.clearance_m
        forcing = []
        for j in range(2):
            de = np.zeros(2)
            de[j] = step
            plus = film_operator(grid, tuple(e0 + de), (0.0, 0.0), self.omega_spin)
            minus = film_operator(grid, tuple(e0 - de), (0.0, 0.0), self.omega_spin)
            dap = (plus.ap_data - minus.ap_data) / (2.0 * step)
            dat = (plus.at_data - minus.at_data) / (2.0 * step)
            forcing.append(-np.bincount(rows, weights=dap * p0[cols] + dat * theta0[cols], minlength=n))
        self._forcing = np.column_stack(forcing)
        self._dvolume = np.column_stack([op.wx, op.wy])
        self._data = np.where(full[cols], op.ap_data * self.p_ref, op.at_data)
        self._diag = slots["diag"]
        self._memo: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    def impedance(self, s: complex) -> np.ndarray:
        """Z(s) (2, 2) complex [N/m] for the Laplace variable ``s`` [1/s]."""
        grid = self.grid
        n = grid.n_nodes
        data = self._data.astype(complex)
        data[self._diag] += s * self.volume0 * ~self.full
        rhs = self._forcing - s * self.theta0[:, None] * self._dvolume
        mt = sp.csc_matrix((data, grid.pattern.indices, grid.pattern.indptr), shape=(n, n))
        lu = splu(mt, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        du = lu.solve(rhs.astype(complex), trans="T")
        dp = np.where(self.full[:, None], du * self.p_ref, 0.0)
        return -np.array([self.wx @ dp, self.wy @ dp])

    def coefficients(self, omega_rad_s: float, dt_s: float | None = None, order: int = 2):
        """(K, C) (2, 2) real at whirl frequency ``omega_rad_s`` [rad/s] > 0 (see :func:`bdf_symbol`)."""
        omega = require_non_negative("whirl frequency omega_rad_s", omega_rad_s, "rad/s")
        if omega == 0.0:
            raise InputError("whirl frequency omega_rad_s must be > 0 (use the stiffness at omega -> 0)")
        key = (omega, dt_s, order)
        if key not in self._memo:
            z = self.impedance(bdf_symbol(omega, dt_s, order))
            self._memo[key] = (z.real.copy(), z.imag / omega)
        return self._memo[key]


def synchronous_coefficients(film, eccentricity_m, speed_hz: float, supply) -> tuple[np.ndarray, np.ndarray]:
    """K(Omega), C(Omega) of a steady film at whirl frequency = spin speed ``speed_hz`` [Hz].

    On the flooded threshold (:func:`~oilwatch.models.bearing.equilibrium.on_flooded_threshold`) the mean of
    the starved and flooded one-sided impedances (:func:`synchronous_one_sided`), as the quasi-static
    coefficients take there.
    """
    if not on_flooded_threshold(film, supply, speed_hz):
        return FilmImpedance(film, eccentricity_m, speed_hz).coefficients(2.0 * math.pi * speed_hz)
    sides = synchronous_one_sided(film, eccentricity_m, speed_hz)
    return tuple(0.5 * (sides["starved"][k] + sides["flooded"][k]) for k in range(2))


def synchronous_one_sided(film, eccentricity_m, speed_hz: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{"starved": (K, C), "flooded": (K, C)} at whirl frequency = spin speed: the two one-sided limits of a
    film on the flooded threshold, its groove taken cavitated (theta_g free) or full (p_g free)."""
    omega = 2.0 * math.pi * speed_hz
    g = film.grid.groove_node
    sides = {}
    for side, flooded in (("starved", False), ("flooded", True)):
        full = film.full.copy()
        full[g] = flooded
        branch = dataclasses.replace(film, full=full)
        sides[side] = FilmImpedance(branch, eccentricity_m, speed_hz).coefficients(omega)
    return sides
