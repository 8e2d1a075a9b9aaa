"""Cramer-Rao lower bound on the supply flowrates (q1, q2) identified from the bearing displacements.

The measured record is the shaft's (x, y) position in each bearing, sampled every ``dt`` for ``N`` samples,
with independent white Gaussian noise of std ``sigma`` on each of the four channels::

    y_k = h(t_k; q) + v_k,    h(t; q) = r_s(q) + Re(X(q) exp(i Omega t)),    v_k ~ N(0, sigma^2 I_4)

where ``r_s`` is the static position and ``X`` the complex unbalance orbit of the linear rotor-bearing model
(``RotorBearingSystem.static_coordinates`` / ``unbalance_coordinates`` at the bearings). The Fisher
information of the record about ``q = (q1, q2)`` is (e.g. Kay, "Fundamentals of Statistical Signal
Processing: Estimation Theory", 1993, Sec. 3.9, Eq. 3.33)::

    F = sum_k J_k^T J_k / sigma^2,    J_k = dh(t_k; q)/dq = dr_s/dq + Re(dX/dq exp(i Omega t_k))   (4 x 2)

and any unbiased estimator of q from that record has a covariance of at least ``inv(F)``; the bound on the
std of each flowrate estimate is ``sqrt(diag(inv(F)))``.

Assumptions (what the bound covers):

* The orbit is steady over the whole record (no start-up transient), and the unbalance (mass, phase) and all
  other model parameters are known exactly: only q1 and q2 are unknown.
* The noise is white, Gaussian and independent between channels, with the same std on all four.
* N is the number of samples the estimator has seen: the full record (an EKF uses every sample, including
  the part the study discards before averaging).
* The sensors' DC levels are known (absolute positions, as the paper's orbits assume). With
  ``unknown_offsets=True`` each channel gets an unknown constant offset (a proximity probe's gap voltage
  drifts), estimated jointly; the bound on q is then the Schur complement of the offsets' block, and over
  whole revolutions only the orbit (AC) part of the signal informs q.
* Velocity channels computed from the displacements (the paper's 8 measurements) add no information: they
  are a deterministic function of the same samples, so F counts only the four displacement channels.

Why it bounds any estimator: the Cramer-Rao inequality ``cov(q_hat) >= inv(F)`` holds for every unbiased
estimator that is a function of these data, whatever its algorithm (EKF, least squares, ...). It does not
cover bias: a biased estimator (an EKF's prior, a truncated average) can have a smaller error variance yet
a larger mean-square error, and model error (a filter model that differs from the truth) adds error that the
bound knows nothing about. The ratio achieved RMS error / bound therefore measures how far an estimator is
from the best possible use of the data, noise and model error together.

Sensitivities ``dr_s/dq`` and ``dX/dq`` are central differences in q with a step relative to q; the
coefficient tables are interpolated smoothly (C1), so the derivative is step-insensitive over a wide range of
steps (checked in the tests).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..validation import InputError, require_in_range, require_positive

M3_S_TO_ML_MIN = 6.0e7
"""1 m^3/s in ml/min."""

DEFAULT_DT_S = 1.0e-3
"""Sampling interval of the measured displacements [s] (1 kHz, as in the paper)."""

DEFAULT_RELATIVE_STEP = 1.0e-4
"""Central-difference step in q, relative to q."""

MAX_CONDITION = 1.0e12
"""Fisher matrices worse conditioned than this are treated as singular (q not locally identifiable)."""


class OrbitModel(Protocol):
    """What the bound needs from a rotor-bearing system (``RotorBearingSystem`` satisfies it)."""

    omega_rad_s: float

    @property
    def flowrate_bounds_m3_s(self) -> tuple[float, float]: ...

    def static_coordinates(self, flowrates_m3_s: Sequence[float]) -> np.ndarray: ...

    def unbalance_coordinates(self, flowrates_m3_s: Sequence[float]) -> np.ndarray: ...

    def bearing_positions(self, coordinates: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class OrbitSensitivity:
    """Derivatives of the steady bearing orbits with respect to (q1, q2), channels (x1, y1, x2, y2).

    ``static`` (4, 2) [m per m^3/s]: d r_s / d q. ``amplitude`` (4, 2) complex [m per m^3/s]: d X / d q.
    """

    static: np.ndarray
    amplitude: np.ndarray


@dataclass(frozen=True)
class CramerRaoBound:
    """The Cramer-Rao bound on (q1, q2) for one case.

    flowrates_m3_s (2,): the true flowrates. noise_std_m: sigma per channel [m]. n_samples, dt_s: the record.
    fisher (2, 2) [(m^3/s)^-2]: the Fisher information. covariance (2, 2) [(m^3/s)^2]: its inverse.
    """

    flowrates_m3_s: np.ndarray
    noise_std_m: float
    n_samples: int
    dt_s: float
    fisher: np.ndarray
    covariance: np.ndarray

    @property
    def std_m3_s(self) -> np.ndarray:
        """(2,) bound on the std of each flowrate estimate [m^3/s]."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def std_ml_min(self) -> np.ndarray:
        """(2,) bound on the std of each flowrate estimate [ml/min]."""
        return self.std_m3_s * M3_S_TO_ML_MIN

    @property
    def std_pct(self) -> np.ndarray:
        """(2,) bound on the std of each flowrate estimate, in % of the true flowrate."""
        return 100.0 * self.std_m3_s / self.flowrates_m3_s

    @property
    def correlation(self) -> float:
        """Correlation coefficient of the q1 and q2 errors of an efficient estimator."""
        std = self.std_m3_s
        return float(self.covariance[0, 1] / (std[0] * std[1]))


def _orbit(system: OrbitModel, flowrates_m3_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Static position (4,) and complex orbit amplitude (4,) at the bearings, channels (x1, y1, x2, y2)."""
    static = system.bearing_positions(system.static_coordinates(flowrates_m3_s)).reshape(-1)
    amplitude = system.bearing_positions(system.unbalance_coordinates(flowrates_m3_s)).reshape(-1)
    return static, amplitude


def orbit_sensitivity(
    system: OrbitModel, flowrates_m3_s: Sequence[float], relative_step: float = DEFAULT_RELATIVE_STEP
) -> OrbitSensitivity:
    """Central-difference derivatives of the steady orbit with respect to each flowrate.

    flowrates_m3_s: (q1, q2) [m^3/s]; the perturbed flowrates ``q (1 +- relative_step)`` must lie inside
    the system's tables.
    """
    q = np.asarray(flowrates_m3_s, dtype=float)
    if q.shape != (2,):
        raise InputError(f"flowrates_m3_s: need (q1, q2), got shape {q.shape}")
    require_in_range("relative_step", relative_step, 1e-8, 0.1)
    low, high = system.flowrate_bounds_m3_s
    for index, value in enumerate(q):
        for sign in (-1.0, 1.0):
            require_in_range(
                f"q{index + 1} (with the difference step)",
                value * (1.0 + sign * relative_step),
                low,
                high,
                "m^3/s",
            )
    static = np.zeros((4, 2))
    amplitude = np.zeros((4, 2), dtype=complex)
    for j in range(2):
        step = relative_step * q[j]
        up, down = q.copy(), q.copy()
        up[j] += step
        down[j] -= step
        static_up, amplitude_up = _orbit(system, up)
        static_down, amplitude_down = _orbit(system, down)
        static[:, j] = (static_up - static_down) / (2.0 * step)
        amplitude[:, j] = (amplitude_up - amplitude_down) / (2.0 * step)
    return OrbitSensitivity(static, amplitude)


def record_sensitivity(
    sensitivity: OrbitSensitivity, omega_rad_s: float, dt_s: float, n_samples: int, start_s: float = 0.0
) -> np.ndarray:
    """Sensitivity of every sample of the record, J (n_samples, 4, 2) [m per m^3/s].

    ``J_k = dr_s/dq + Re(dX/dq exp(i Omega t_k))`` with ``t_k = start_s + k dt_s``.
    """
    times = start_s + dt_s * np.arange(n_samples)
    phase = np.exp(1j * omega_rad_s * times)
    return sensitivity.static[None, :, :] + (sensitivity.amplitude[None, :, :] * phase[:, None, None]).real


def fisher_information(jacobians: np.ndarray, noise_std: float) -> np.ndarray:
    """Fisher information ``sum_k J_k^T J_k / sigma^2`` (p, p) of a record under white Gaussian noise.

    jacobians: (N, m, p) sensitivity of the m channels of each of N samples to p parameters.
    noise_std: sigma, the std of every channel's noise (units of the channels).
    """
    jac = np.asarray(jacobians, dtype=float)
    if jac.ndim != 3:
        raise InputError(f"jacobians: need shape (N, m, p), got {jac.shape}")
    sigma = require_positive("noise_std", noise_std)
    return np.einsum("kmi,kmj->ij", jac, jac) / sigma**2


def cramer_rao_bound(
    system: OrbitModel,
    flowrates_m3_s: Sequence[float],
    noise_std_m: float,
    n_samples: int,
    dt_s: float = DEFAULT_DT_S,
    relative_step: float = DEFAULT_RELATIVE_STEP,
    unknown_offsets: bool = False,
) -> CramerRaoBound:
    """The Cramer-Rao bound on (q1, q2) from N samples of the four bearing displacements.

    system: the rotor-bearing model (use the full model, ``load_system(reduced=False)``, for the truth).
    flowrates_m3_s: the true (q1, q2) [m^3/s]. noise_std_m: sigma per displacement channel [m].
    n_samples: samples in the record (the estimator's whole record). dt_s: sampling interval [s].
    unknown_offsets: treat a constant offset per channel as a further unknown (nuisance) parameter.
    """
    sigma = require_positive("noise_std_m", noise_std_m, "m")
    dt = require_positive("dt_s", dt_s, "s")
    if int(n_samples) != n_samples or n_samples < 1:
        raise InputError(f"n_samples must be an integer >= 1, got {n_samples!r}")
    q = np.asarray(flowrates_m3_s, dtype=float)
    sensitivity = orbit_sensitivity(system, q, relative_step)
    jac = record_sensitivity(sensitivity, system.omega_rad_s, dt, int(n_samples))
    if unknown_offsets:
        offsets = np.broadcast_to(np.eye(jac.shape[1]), (jac.shape[0], jac.shape[1], jac.shape[1]))
        full = fisher_information(np.concatenate([jac, offsets], axis=2), sigma)
        fisher = full[:2, :2] - full[:2, 2:] @ np.linalg.solve(full[2:, 2:], full[2:, :2])
    else:
        fisher = fisher_information(jac, sigma)
    if np.linalg.cond(fisher) > MAX_CONDITION:
        raise InputError(
            f"flowrates {q * M3_S_TO_ML_MIN} ml/min: the record's Fisher information is singular, so "
            "(q1, q2) is not locally identifiable from the bearing displacements"
        )
    return CramerRaoBound(q, sigma, int(n_samples), dt, fisher, np.linalg.inv(fisher))


# ---------------------------------------------------------------------------------------------------------
# The bound along an operating trajectory, on the estimator's own operating maps
#
# With the viscosity factors free the nearly unobservable direction (a lower flow, a thicker film, a larger
# unbalance, shifted offsets) makes the bound depend on the model's viscosity sensitivity of the 1x orbit,
# and a moving operating point (a speed or oil-temperature ramp) changes the sensitivities along the record,
# so the directions the nuisances can hide in differ from segment to segment. The record is cut into
# segments short against the ramp (the ramps of the robustness report change the speed by 0.1 Hz/s and the
# viscosity by about 0.5 %/s, against the least damped mode's 72 ms): in each the response is the steady
# static position and 1x orbit of the exact map at the segment's operating point (quasi-steady), and the
# Fisher information is the sum of the segments' (Kay 1993, Sec. 3.9; the nuisances and the flowrates are
# constant over the record: a bound for constant parameters, below any filter that lets them walk).

TRAJECTORY_PARAMETERS = (
    "q1",
    "q2",
    "viscosity_1",
    "viscosity_2",
    "unbalance_re",
    "unbalance_im",
    "offset_x1",
    "offset_y1",
    "offset_x2",
    "offset_y2",
)
"""Columns of :func:`map_sensitivity`: q per unit of q / q_true, viscosity factors and the unbalance
(relative to the machine file's) per unit, offsets per um."""

_GROUP_COLUMNS = {"viscosity": (2, 3), "unbalance": (4, 5), "offsets": (6, 7, 8, 9)}
_ORBIT_WEIGHTS = np.r_[np.ones(4), np.full(8, 0.5)]  # mean of 1, cos^2, sin^2 over whole revolutions


@dataclass(frozen=True)
class OperatingSegment:
    """A stretch of record at one operating point: speed [Hz], the oil's viscosity at the measured
    temperature [Pa s] (before the factors), and its length [s]."""

    speed_hz: float
    oil_viscosity_pa_s: float
    duration_s: float


def map_response(
    maps, output_matrix, dt_s: float, flowrates_m3_s, segment: OperatingSegment, factors, unbalance
):
    """(12,) [m] steady static position (4), 1x orbit cosine (4) and sine (4) parts at the probes of the exact
    map ``maps.discrete_map`` (:class:`models.system.operating_maps.OperatingMaps`) at the segment's point:
    :func:`block_response` of :func:`map_block`."""
    block = map_block(maps, flowrates_m3_s, segment, factors)
    return block_response(maps, output_matrix, dt_s, block, segment, unbalance)


def map_block(maps, flowrates_m3_s, segment: OperatingSegment, factors) -> np.ndarray:
    """The continuous block of the exact map at the segment's point and the viscosity ``factors``."""
    mu = segment.oil_viscosity_pa_s * np.asarray(factors, dtype=float)
    return maps.block(np.asarray(flowrates_m3_s, dtype=float), segment.speed_hz, mu)


def block_response(maps, output_matrix, dt_s: float, block, segment: OperatingSegment, unbalance):
    """:func:`map_response` from the :func:`map_block` of its point."""
    a, g = maps.discrete_of_block(block)
    n = a.shape[0]
    h = np.asarray(output_matrix)
    static = h @ np.linalg.solve(np.eye(n) - a, g[:, 0])
    turn = np.exp(2j * np.pi * segment.speed_hz * dt_s)
    orbit = complex(unbalance) * (h @ np.linalg.solve(turn * np.eye(n) - a, g[:, 1] - 1j * g[:, 2]))
    return np.r_[static, orbit.real, -orbit.imag]


def map_sensitivity(
    maps,
    output_matrix,
    dt_s: float,
    flowrates_m3_s,
    segment: OperatingSegment,
    factors=(1.0, 1.0),
    unbalance: complex = 1.0,
    relative_step: float = 1e-3,
) -> np.ndarray:
    """(12, 10) d response / d :data:`TRAJECTORY_PARAMETERS` at the truth (the flowrates, viscosity
    ``factors`` and relative ``unbalance``) by central differences of the exact map (the unbalance and the
    offsets enter linearly: exact columns; the factors are differenced in absolute steps): the
    :func:`map_response` at each of :func:`sensitivity_points`, into :func:`sensitivity_columns`."""
    points = sensitivity_points(flowrates_m3_s, factors, unbalance, relative_step)
    responses = [map_response(maps, output_matrix, dt_s, flows, segment, f, unbalance) for flows, f in points]
    return sensitivity_columns(responses, unbalance, relative_step)


def sensitivity_points(flowrates_m3_s, factors, unbalance: complex, relative_step: float = 1e-3) -> list:
    """The 9 (flowrates, factors) of :func:`map_sensitivity`'s differences: the point itself, then each
    flowrate up and down by ``relative_step`` of itself, then each factor up and down by it."""
    require_in_range("relative_step", relative_step, 1e-6, 0.05)
    q = np.asarray(flowrates_m3_s, dtype=float)
    ones = np.asarray(factors, dtype=float)
    if complex(unbalance) == 0.0:
        raise InputError("unbalance: the bound needs a non-zero unbalance (the 1x orbit informs q)")
    points = [(q, ones)]
    for i in range(2):
        up, down = q.copy(), q.copy()
        up[i] *= 1.0 + relative_step
        down[i] *= 1.0 - relative_step
        points += [(up, ones), (down, ones)]
    for i in range(2):
        up, down = ones.copy(), ones.copy()
        up[i] += relative_step
        down[i] -= relative_step
        points += [(q, up), (q, down)]
    return points


def sensitivity_columns(responses, unbalance: complex, relative_step: float = 1e-3) -> np.ndarray:
    """(12, 10) :func:`map_sensitivity` from the :func:`map_response` at each of its
    :func:`sensitivity_points` (in their order)."""
    base = responses[0]
    columns = [(responses[1 + 2 * j] - responses[2 + 2 * j]) / (2.0 * relative_step) for j in range(4)]
    orbit = (base[4:8] - 1j * base[8:]) / complex(unbalance)  # the unit unbalance's orbit
    for unit in (1.0, 1j):
        turned = unit * orbit
        columns.append(np.r_[np.zeros(4), turned.real, -turned.imag])
    columns += [1e-6 * np.eye(12)[i] for i in range(4)]
    return np.column_stack(columns)


def trajectory_information(
    maps,
    output_matrix,
    dt_s: float,
    flowrates_m3_s,
    segments,
    noise_std_m: float,
    factors=(1.0, 1.0),
    unbalance: complex = 1.0,
) -> np.ndarray:
    """(10, 10) Fisher information of the record about :data:`TRAJECTORY_PARAMETERS` (notes above) at the
    true flowrates, viscosity factors and relative unbalance, summed over the ``segments``."""
    sigma = require_positive("noise_std_m", noise_std_m, "m")
    information = np.zeros((10, 10))
    for segment in segments:
        jac = map_sensitivity(maps, output_matrix, dt_s, flowrates_m3_s, segment, factors, unbalance)
        samples = require_positive("segment duration_s", segment.duration_s, "s") / dt_s
        information += samples * (jac.T * _ORBIT_WEIGHTS) @ jac / sigma**2
    return information


def parameter_columns(groups) -> list[int]:
    """Columns of :data:`TRAJECTORY_PARAMETERS` of the flowrates and the nuisance ``groups``."""
    unknown = [g for g in groups if g not in _GROUP_COLUMNS]
    if unknown:
        raise InputError(f"nuisance groups must be among {tuple(_GROUP_COLUMNS)}, got {unknown}")
    return [0, 1] + [c for g in _GROUP_COLUMNS if g in groups for c in _GROUP_COLUMNS[g]]


def nuisance_prior(information: np.ndarray, groups, drift_std: dict[str, float] | None = None) -> np.ndarray:
    """(10, 10) prior information on the nuisances from a baseline record's ``information`` at known q: its
    nuisance block of the ``groups`` (other nuisances known), with ``drift_std`` (per parameter-name prefix,
    in the parameter's unit, e.g. ``{"offset": 3.0}`` um) added as variance since the baseline."""
    columns = parameter_columns(groups)[2:]
    covariance = np.linalg.inv(information[np.ix_(columns, columns)])
    for i, c in enumerate(columns):
        for prefix, std in (drift_std or {}).items():
            if TRAJECTORY_PARAMETERS[c].startswith(prefix):
                covariance[i, i] += std**2
    prior = np.zeros((10, 10))
    prior[np.ix_(columns, columns)] = np.linalg.inv(covariance)
    return prior


def trajectory_bound_pct(information: np.ndarray, groups, prior: np.ndarray | None = None) -> np.ndarray:
    """(2,) bound on (q1, q2) [% of the true flowrates] with the nuisance ``groups`` unknown (the others
    known), from :func:`trajectory_information` plus an optional prior (:func:`nuisance_prior`)."""
    columns = parameter_columns(groups)
    total = information if prior is None else information + prior
    block = total[np.ix_(columns, columns)]
    if np.linalg.cond(block) > MAX_CONDITION:
        raise InputError("the record's Fisher information is singular: (q1, q2) is not locally identifiable")
    return 100.0 * np.sqrt(np.diag(np.linalg.inv(block))[:2])


def tracking_bound_pct(
    segment_information,
    groups,
    prior_std: np.ndarray,
    walk_std_per_sqrt_s: np.ndarray,
    step_s: float = 0.5,
) -> np.ndarray:
    """(2,) the posterior Cramer-Rao bound [% of q] on the flowrates at the END of a record whose parameters
    random-walk as a filter models them (Tichavsky, Muravchik & Nehorai, IEEE Trans. SP 46, 1998: for a
    random walk observed through a linear Gaussian map the bound's recursion is the Kalman information
    recursion with the true sensitivities).

    segment_information: ``[(information per second (10, 10), seconds), ...]`` along the record (e.g. each
    of :func:`trajectory_information`'s segments divided by its length). prior_std, walk_std_per_sqrt_s (10,)
    in the units of :data:`TRAJECTORY_PARAMETERS` (q as a fraction of the truth): the filter's initial
    stds and random-walk intensities. The nuisances outside ``groups`` are known. The dynamic states are
    taken as determined by the parameters (quasi-steady: they settle in the least damped mode's 72 ms).
    """
    columns = parameter_columns(groups)
    covariance = np.diag(np.asarray(prior_std, dtype=float)[columns] ** 2)
    walk = np.diag(np.asarray(walk_std_per_sqrt_s, dtype=float)[columns] ** 2)
    for rate, seconds in segment_information:
        block = np.asarray(rate)[np.ix_(columns, columns)]
        steps = max(1, round(seconds / step_s))
        for _ in range(steps):
            information = np.linalg.inv(covariance + walk * seconds / steps) + block * seconds / steps
            covariance = np.linalg.inv(information)
    return 100.0 * np.sqrt(np.diag(covariance)[:2])
