"""Cramer-Rao lower bound on the supply flowrates (q1, q2) from the steady bearing orbits of the linear model.

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
    def bearing_flowrate_bounds_m3_s(self) -> np.ndarray: ...

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
    their own bearing's tables.
    """
    q = np.asarray(flowrates_m3_s, dtype=float)
    if q.shape != (2,):
        raise InputError(f"flowrates_m3_s: need (q1, q2), got shape {q.shape}")
    require_in_range("relative_step", relative_step, 1e-8, 0.1)
    for index, (value, (low, high)) in enumerate(zip(q, system.bearing_flowrate_bounds_m3_s, strict=True)):
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
