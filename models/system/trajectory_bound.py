"""Cramer-Rao bound on the flowrates along an operating trajectory, on the estimator's own operating maps.

With the viscosity factors free the nearly unobservable direction (a lower flow, a thicker film, a larger
unbalance, shifted offsets) makes the bound depend on the model's viscosity sensitivity of the 1x orbit,
and a moving operating point (a speed or oil-temperature ramp) changes the sensitivities along the record,
so the directions the nuisances can hide in differ from segment to segment. The record is cut into
segments short against the ramp (the ramps of the robustness report change the speed by 0.1 Hz/s and the
viscosity by about 0.5 %/s, against the least damped mode's 72 ms): in each the response is the steady
static position and 1x orbit of the exact map at the segment's operating point (quasi-steady), and the
Fisher information is the sum of the segments' (Kay, "Fundamentals of Statistical Signal Processing:
Estimation Theory", 1993, Sec. 3.9; the nuisances and the flowrates are constant over the record: a bound for
constant parameters, below any filter that lets them walk).

Beside that constant-parameter bound, :func:`tracking_bound_pct` is the posterior bound at the end of a
record whose parameters random-walk as a filter models them. The steady-orbit bound with only the
flowrates (and optionally the probes' offsets) unknown is :mod:`oilwatch.models.system.orbit_bound`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..validation import InputError, require_in_range, require_positive
from .orbit_bound import MAX_CONDITION

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
ORBIT_WEIGHTS = np.r_[np.ones(4), np.full(8, 0.5)]
"""The information per sample of a response's static rows and of each 1x part (the mean of 1, cos^2 and
sin^2 over whole revolutions)."""


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
    map ``maps.discrete_map`` (:class:`oilwatch.models.system.operating_maps.OperatingMaps`) at the segment's
    point:
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
    columns = [(responses[1 + 2 * j] - responses[2 + 2 * j]) / (2.0 * relative_step) for j in range(4)]
    return np.column_stack([*columns, nuisance_columns(responses[0], unbalance)])


def nuisance_columns(response, unbalance: complex) -> np.ndarray:
    """(12, 6) the unbalance's and the offsets' columns of :func:`map_sensitivity` (they enter linearly:
    exact from the :func:`map_response` at the point itself)."""
    orbit = (response[4:8] - 1j * response[8:]) / complex(unbalance)  # the unit unbalance's orbit
    columns = [np.r_[np.zeros(4), turned.real, -turned.imag] for turned in (orbit, 1j * orbit)]
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
        information += samples * (jac.T * ORBIT_WEIGHTS) @ jac / sigma**2
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
