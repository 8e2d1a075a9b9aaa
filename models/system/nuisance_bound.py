"""Cramer-Rao bound on (q1, q2) when the machine's nuisances are unknown too, with or without a baseline.

A real machine does not tell the estimator its probe zero offsets, its unbalance or its oil's effective
viscosity in each film. With those as further unknowns the measured record is, per sample and channel
(x1, y1, x2, y2)::

    y_k = o + r_s(q, f) + Re(u X(q, f) exp(i Omega t_k)) + v_k,    v_k ~ N(0, sigma^2 I_4)

with ``o`` (4,) the probe zero offsets, ``u`` the complex unbalance relative to the machine file's (1 + 0i
nominal: the response is linear in the unbalance force) and ``f = (f1, f2)`` an effective viscosity factor
per bearing (mu_eff = f mu). The parameter vector is ``theta = (q1, q2, o1..o4, Re u, Im u, f1, f2)``; the
Fisher information of N samples is ``sum_k J_k^T J_k / sigma^2`` with ``J_k = S + C cos(Omega t_k) + D
sin(Omega t_k)`` (S static, ``C - i D`` the complex sensitivity of the orbit), evaluated in closed form from
the sums of cos, sin and their products over the record (so a 600 s record costs as little as a 10 s one).
The bound on (q1, q2) with the nuisances ``n`` unknown is the inverse of the Schur complement
``F_qq - F_qn (F_nn + Pi_nn)^-1 F_nq`` (Kay 1993, Sec. 3.7 and 3.9; with a prior ``Pi`` this is the
Bayesian information of Van Trees, Sec. 2.4 of "Detection, Estimation and Modulation Theory I", 1968).

A commissioning baseline is a record of ``baseline_samples`` taken at known flowrates (default the same
truth point or nominal): the nuisance block of its Fisher information (q known) is the prior ``Pi``; the
nuisances are assumed unchanged since the baseline (drift adds ``drift_std`` per nuisance as prior
variance, in the nuisance's own unit).

The viscosity sensitivity needs the film coefficients at ``mu (1 +- d)``: they are re-solved with the
table's own bearing, load and mesh (:func:`viscosity_derivative`, two steady solves per flowrate) and
added to the interpolated table values as a first-order shift, so ``r_s`` and ``X`` keep the table's
interpolation in q. A dimensionless table (Sommerfeld scaling) can supply the same derivative without
re-solving. A system whose 1x orbit comes from synchronous tables (K, C at whirl = spin) needs the
derivative of those too (``synchronous=True``): the quasi-static derivative alone moves the free dynamics'
coefficients but not the synchronous ones that set the orbit, and so gives the orbit a viscosity
sensitivity of the wrong size and direction (on the turbine 2.96 against 7.10 um per unit factor at x1; the
bound with offsets, unbalance and factors unknown then read 0.25 % of q for 60 s instead of 1.85 %: README
bound section).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..bearing.dynamic import synchronous_coefficients
from ..bearing.equilibrium import coefficients_at, static_equilibrium
from ..bearing.geometry import JournalBearing
from ..bearing.grid import Mesh
from ..bearing.supply import SupplyFlow
from ..bearing.table import BearingCoefficients
from ..validation import InputError, require_in_range, require_positive
from .orbit_bound import DEFAULT_DT_S, M3_S_TO_ML_MIN, orbit_sensitivity
from .rotor_bearing import RotorBearingSystem

NUISANCE_GROUPS = ("offsets", "unbalance", "viscosity")
"""Nuisance groups in the order of the parameter vector after (q1, q2)."""

GROUP_SIZES = {"offsets": 4, "unbalance": 2, "viscosity": 2}

VISCOSITY_RELATIVE_STEP = 0.01
"""Relative viscosity step of the film re-solves: the held-partition solutions are smooth in mu, and 1 %
keeps the partition switches of the cavitation boundary (cell-scale ripple) out of the difference."""


def viscosity_derivative(
    table, flowrate_m3_s: float, relative_step: float = VISCOSITY_RELATIVE_STEP, synchronous: bool = False
):
    """d(e0, K, C)/d f at flowrate q for mu_eff = f mu, f = 1, by central differences of two film solves.

    ``table`` is a :class:`oilwatch.models.bearing.table.CoefficientTable`: its metadata gives the bearing,
    mesh and load it was computed for. Returns a :class:`BearingCoefficients` of derivatives (per unit of f);
    with ``synchronous`` a pair ``(quasi-static, synchronous)`` of them, K and C of the second at whirl = spin
    (from the same two equilibria).
    """
    require_in_range("relative_step", relative_step, 1e-4, 0.1)
    meta = table.metadata
    try:
        bearing = JournalBearing(**meta["bearing"])
        mesh = Mesh(**meta["mesh"])
    except (KeyError, TypeError) as error:
        raise InputError(f"coefficient table metadata lacks the bearing or mesh: {error}") from None
    supply = SupplyFlow(float(flowrate_m3_s))
    values = []
    for sign in (1.0, -1.0):
        scaled = dataclasses.replace(
            bearing, viscosity_pa_s=bearing.viscosity_pa_s * (1 + sign * relative_step)
        )
        eq = static_equilibrium(scaled, table.load_n, table.speed_hz, supply, mesh)
        stiffness, damping = coefficients_at(scaled, eq, table.speed_hz, supply, mesh)
        row = [np.asarray(eq.eccentricity_m), stiffness, damping]
        if synchronous:
            row += synchronous_coefficients(eq.film, eq.eccentricity_m, table.speed_hz, supply)
        values.append(row)
    up, down = values
    step = 2.0 * relative_step
    d = [(a - b) / step for a, b in zip(up, down, strict=True)]
    quasi_static = BearingCoefficients(d[0], d[1], d[2])
    return (quasi_static, BearingCoefficients(d[0], d[3], d[4])) if synchronous else quasi_static


class _ShiftedTable:
    """A coefficient table plus a constant first-order shift ``scale * delta`` (same range, speed, load)."""

    def __init__(self, table, delta: BearingCoefficients | None, scale: float) -> None:
        self._table, self._delta, self._scale = table, delta, scale
        self.speed_hz, self.load_n = table.speed_hz, table.load_n
        self.flowrate_range_m3_s = table.flowrate_range_m3_s

    def evaluate(self, q_m3_s: float) -> BearingCoefficients:
        value = self._table.evaluate(q_m3_s)
        if self._delta is None:
            return value
        s, d = self._scale, self._delta
        return BearingCoefficients(
            value.eccentricity_m + s * d.eccentricity_m,
            value.stiffness + s * d.stiffness,
            value.damping + s * d.damping,
        )


def _orbit(system: RotorBearingSystem, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    static = system.bearing_positions(system.static_coordinates(q)).reshape(-1)
    amplitude = system.bearing_positions(system.unbalance_coordinates(q)).reshape(-1)
    return static, amplitude


def _with_tables(system: RotorBearingSystem, tables, synchronous_tables=None) -> RotorBearingSystem:
    return RotorBearingSystem(
        system.rotor,
        tables,
        system.speed_hz,
        system.basis,
        system.unbalance_moment_kg_m,
        system.unbalance_phase_rad,
        system.nominal_flowrates_m3_s,
        synchronous_tables,
    )


@dataclass(frozen=True)
class HarmonicSensitivity:
    """Sensitivity of the steady record to p parameters: static (4, p) and complex orbit amplitude (4, p).

    ``names`` (p,) label the columns; their units are those of :func:`harmonic_sensitivity` (q as a
    fraction of its true value, offsets in um, unbalance and viscosity factors dimensionless).
    """

    names: tuple[str, ...]
    static: np.ndarray
    amplitude: np.ndarray


def harmonic_sensitivity(
    system: RotorBearingSystem,
    flowrates_m3_s: Sequence[float],
    groups: Sequence[str] = NUISANCE_GROUPS,
    viscosity_derivatives: Sequence[BearingCoefficients] | None = None,
) -> HarmonicSensitivity:
    """Columns for q1, q2 (per unit of q / q_true) and for each nuisance group asked for.

    ``viscosity_derivatives``: one d(e0, K, C)/d f per bearing at its flowrate (from
    :func:`viscosity_derivative`), needed only for the ``"viscosity"`` group; for a system with synchronous
    tables a ``(quasi-static, synchronous)`` pair per bearing (``viscosity_derivative(...,
    synchronous=True)``).
    """
    q = np.asarray(flowrates_m3_s, dtype=float)
    unknown = [g for g in groups if g not in NUISANCE_GROUPS]
    if unknown:
        raise InputError(f"nuisance groups must be among {NUISANCE_GROUPS}, got {unknown}")
    flow = orbit_sensitivity(system, q)
    names = ["q1", "q2"]
    static = [flow.static * q[None, :]]
    amplitude = [flow.amplitude * q[None, :]]
    if "offsets" in groups:
        names += [f"offset_{c}" for c in ("x1", "y1", "x2", "y2")]
        static.append(1e-6 * np.eye(4))  # per um: keeps the information matrix well scaled
        amplitude.append(np.zeros((4, 4), dtype=complex))
    if "unbalance" in groups:
        _, orbit = _orbit(system, q)
        names += ["unbalance_re", "unbalance_im"]
        static.append(np.zeros((4, 2)))
        amplitude.append(np.column_stack([orbit, 1j * orbit]))
    if "viscosity" in groups:
        if viscosity_derivatives is None or len(viscosity_derivatives) != len(system.tables):
            raise InputError("the viscosity group needs one viscosity derivative per bearing")
        synchronous = system.synchronous_tables
        for b, derivative in enumerate(viscosity_derivatives):
            if synchronous is not None and not isinstance(derivative, tuple):
                raise InputError(
                    "the system's 1x orbit comes from synchronous tables: the viscosity derivative needs "
                    "their part too (viscosity_derivative(..., synchronous=True))"
                )
            dynamics, of_orbit = derivative if isinstance(derivative, tuple) else (derivative, None)
            ends = []
            for sign in (1.0, -1.0):
                scale = sign * VISCOSITY_RELATIVE_STEP
                tables = [
                    _ShiftedTable(t, dynamics if i == b else None, scale) for i, t in enumerate(system.tables)
                ]
                shifted = None
                if synchronous is not None:
                    shifted = [
                        _ShiftedTable(t, of_orbit if i == b else None, scale)
                        for i, t in enumerate(synchronous)
                    ]
                ends.append(_orbit(_with_tables(system, tables, shifted), q))
            step = 2.0 * VISCOSITY_RELATIVE_STEP
            names.append(f"viscosity_{b + 1}")
            static.append(((ends[0][0] - ends[1][0]) / step)[:, None])
            amplitude.append(((ends[0][1] - ends[1][1]) / step)[:, None])
    return HarmonicSensitivity(tuple(names), np.hstack(static), np.hstack(amplitude))


def harmonic_fisher(
    sensitivity: HarmonicSensitivity, omega_rad_s: float, noise_std: float, n_samples: int, dt_s: float
) -> np.ndarray:
    """Fisher information (p, p) of N samples ``J_k = S + C cos + D sin`` (white noise), in closed form."""
    sigma = require_positive("noise_std", noise_std)
    times = dt_s * np.arange(int(n_samples))
    cos, sin = np.cos(omega_rad_s * times), np.sin(omega_rad_s * times)
    s, c, d = sensitivity.static, sensitivity.amplitude.real, -sensitivity.amplitude.imag
    sums = {
        "1": float(n_samples),
        "c": cos.sum(),
        "s": sin.sum(),
        "cc": (cos * cos).sum(),
        "ss": (sin * sin).sum(),
        "cs": (cos * sin).sum(),
    }
    fisher = (
        sums["1"] * s.T @ s
        + sums["c"] * (s.T @ c + c.T @ s)
        + sums["s"] * (s.T @ d + d.T @ s)
        + sums["cc"] * c.T @ c
        + sums["ss"] * d.T @ d
        + sums["cs"] * (c.T @ d + d.T @ c)
    )
    return fisher / sigma**2


@dataclass(frozen=True)
class NuisanceBound:
    """Bound on (q1, q2) in % of the true flowrates with the named nuisances unknown.

    ``std_pct`` (2,); ``nuisance_std`` maps each nuisance name to its own bound (um for offsets, fractions
    for the unbalance and viscosity factors); ``baseline`` tells whether a baseline prior was used.
    """

    flowrates_m3_s: np.ndarray
    groups: tuple[str, ...]
    n_samples: int
    baseline: bool
    std_pct: np.ndarray
    nuisance_std: dict[str, float]

    @property
    def std_ml_min(self) -> np.ndarray:
        return self.std_pct / 100.0 * self.flowrates_m3_s * M3_S_TO_ML_MIN


def _prior_from_baseline(
    baseline: HarmonicSensitivity,
    omega: float,
    sigma: float,
    n_samples: int,
    dt_s: float,
    drift_std: dict[str, float],
) -> np.ndarray:
    """Information (nuisance block) of the baseline record at known q, with drift added as variance."""
    information = harmonic_fisher(baseline, omega, sigma, n_samples, dt_s)[2:, 2:]
    covariance = np.linalg.inv(information)
    for i, name in enumerate(baseline.names[2:]):
        for prefix, std in drift_std.items():
            if name.startswith(prefix):
                covariance[i, i] += std**2
    return np.linalg.inv(covariance)


def nuisance_bound(
    system: RotorBearingSystem,
    flowrates_m3_s: Sequence[float],
    noise_std_m: float,
    n_samples: int,
    groups: Sequence[str] = NUISANCE_GROUPS,
    *,
    dt_s: float = DEFAULT_DT_S,
    viscosity_derivatives: Callable[[Sequence[float]], Sequence[BearingCoefficients]] | None = None,
    baseline_flowrates_m3_s: Sequence[float] | None = None,
    baseline_samples: int | None = None,
    drift_std: dict[str, float] | None = None,
) -> NuisanceBound:
    """Cramer-Rao bound on (q1, q2) with the nuisance ``groups`` unknown (module docstring).

    viscosity_derivatives: callable mapping the flowrates (q1, q2) to one derivative per bearing (needed for
    the ``"viscosity"`` group). baseline_flowrates_m3_s / baseline_samples: the baseline record (known
    flowrates); None: no baseline. drift_std: extra prior std per nuisance-name prefix
    (e.g. ``{"offset": 3.0}`` in um) for nuisances that drifted after the baseline.
    """
    sigma = require_positive("noise_std_m", noise_std_m, "m")
    if int(n_samples) != n_samples or n_samples < 1:
        raise InputError(f"n_samples must be an integer >= 1, got {n_samples!r}")
    q = np.asarray(flowrates_m3_s, dtype=float)
    groups = tuple(groups)

    def sensitivity_at(flows):
        derivatives = viscosity_derivatives(flows) if "viscosity" in groups else None
        return harmonic_sensitivity(system, flows, groups, derivatives)

    test = sensitivity_at(q)
    information = harmonic_fisher(test, system.omega_rad_s, sigma, n_samples, dt_s)
    use_baseline = baseline_flowrates_m3_s is not None and len(test.names) > 2
    if use_baseline:
        samples = int(n_samples if baseline_samples is None else baseline_samples)
        base = sensitivity_at(np.asarray(baseline_flowrates_m3_s, dtype=float))
        information[2:, 2:] += _prior_from_baseline(
            base, system.omega_rad_s, sigma, samples, dt_s, drift_std or {}
        )
    covariance = np.linalg.inv(information)
    std = np.sqrt(np.diag(covariance))
    nuisance = {name: float(value) for name, value in zip(test.names[2:], std[2:], strict=True)}
    return NuisanceBound(q, groups, int(n_samples), use_baseline, 100.0 * std[:2], nuisance)
