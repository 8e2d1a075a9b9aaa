"""Slow-roll runout compensation of the proximity-probe signals (API 670; Bently Nevada practice).

A proximity probe reads the gap to the shaft surface under it, and that surface is neither perfectly round nor
electrically uniform: each probe adds a runout ``r(theta)`` that turns with the rotor, mostly at 1x and 2x of
the rotor angle ``theta`` measured from the keyphasor. At slow roll (a few % of the running speed) the
unbalance force, which grows as the speed squared, moves the journal by a negligible amount, so what a probe
reads at 1x and 2x there IS its runout. The field measures these slow-roll vectors once and subtracts them,
at the keyphasor phase, from every later reading ("slow-roll vector compensation").

Here each probe's runout is ``Re(V1 exp(i theta)) + Re(V2 exp(2 i theta))`` with complex vectors V1, V2 [m]
(``V = a exp(i phi)`` is the plant's ``a cos(theta + phi)``, :mod:`oilwatch.models.system.measurement`), along
the probe's own axis and in its own (possibly mis-scaled) units, as the probe reads it.

* :func:`fit_slow_roll` fits V1, V2 per probe to a slow-roll record by linear least squares on
  ``[1, t, cos theta, sin theta, cos 2 theta, sin 2 theta]`` (the constant and the slope absorb the static
  position and a slow drift), with each component's std from the residual variance (the covariance of the
  least-squares estimate, e.g. Kay 1993, *Fundamentals of Statistical Signal Processing I*, sec. 4.6).
* :class:`RunoutCompensation` is what the estimator calls on every sample: it subtracts the fitted runout at
  the sample's rotor angle (``Omega t`` at the model's speed, t from the keyphasor at t = 0). The fit's
  residual uncertainty enters the filter in two places: a vector known to std s per component leaves a
  residual of mean square s^2 per vector, added to that probe's measurement-noise variance
  (:meth:`residual_variance_m2`); and, because that residual turns with the rotor and so does not average
  out with the samples, the bias it causes in the flowrates (about 0.4 % of flow per 0.01 um of s on the
  bundled turbine, where a 60 s slow-roll record at 1 um gives s of about 0.01 um) is added to the published
  std by the information floor (:class:`oilwatch.estimator.nuisance_start.InformationFloor`) of the filter
  (on either model: the one that follows the operating point and the fixed-speed grid).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from oilwatch.models.validation import InputError, require_finite, require_non_negative

PROBES = ("x1", "y1", "x2", "y2")


@dataclass(frozen=True)
class SlowRollVectors:
    """The 1x and 2x slow-roll (runout) vectors of the four probes (x1, y1, x2, y2).

    once_m, twice_m : (4,) complex vectors [m]; once_std_m, twice_std_m : (4,) std of each real component
    [m] (the uncertainty of the slow-roll fit, or of a value typed into the machine file).
    """

    once_m: tuple[complex, complex, complex, complex]
    twice_m: tuple[complex, complex, complex, complex]
    once_std_m: tuple[float, float, float, float]
    twice_std_m: tuple[float, float, float, float]

    def __post_init__(self) -> None:
        for name in ("once_m", "twice_m", "once_std_m", "twice_std_m"):
            values = getattr(self, name)
            if len(values) != 4:
                raise InputError(f"SlowRollVectors.{name} needs 4 values (x1, y1, x2, y2), got {len(values)}")
            for value in values:
                for part in (complex(value).real, complex(value).imag):
                    require_finite(f"SlowRollVectors.{name}", part)
        for name in ("once_std_m", "twice_std_m"):
            for value in getattr(self, name):
                require_non_negative(f"SlowRollVectors.{name}", value, "m")

    def runout_m(self, rotor_angle_rad: np.ndarray | float) -> np.ndarray:
        """The runout (..., 4) [m] each probe reads at the rotor angle(s) [rad]."""
        theta = np.asarray(rotor_angle_rad, dtype=float)[..., None]
        once = np.asarray(self.once_m, dtype=complex)
        twice = np.asarray(self.twice_m, dtype=complex)
        return (once * np.exp(1j * theta)).real + (twice * np.exp(2j * theta)).real

    def residual_variance_m2(self) -> np.ndarray:
        """(4,) mean-square residual [m^2] the compensation leaves on each probe: s1^2 + s2^2."""
        return np.square(self.once_std_m) + np.square(self.twice_std_m)

    def to_document(self) -> dict:
        """The vectors in the field's units (um, degrees from the keyphasor), for baseline.json."""
        once, twice = np.asarray(self.once_m), np.asarray(self.twice_m)
        return {
            "probes": list(PROBES),
            "runout_1x_um": (np.abs(once) * 1e6).tolist(),
            "runout_1x_phase_deg": np.degrees(np.angle(once)).tolist(),
            "runout_1x_std_um": (np.asarray(self.once_std_m) * 1e6).tolist(),
            "runout_2x_um": (np.abs(twice) * 1e6).tolist(),
            "runout_2x_phase_deg": np.degrees(np.angle(twice)).tolist(),
            "runout_2x_std_um": (np.asarray(self.twice_std_m) * 1e6).tolist(),
        }

    @classmethod
    def from_document(cls, data: dict, source: str) -> SlowRollVectors:
        """The inverse of :meth:`to_document` (one-line InputError naming ``source`` and the key)."""
        values = {}
        for key in (
            "runout_1x_um",
            "runout_1x_phase_deg",
            "runout_1x_std_um",
            "runout_2x_um",
            "runout_2x_phase_deg",
            "runout_2x_std_um",
        ):
            try:
                column = np.array([float(v) for v in data[key]])
            except (KeyError, TypeError, ValueError):
                column = np.zeros(0)
            if len(column) != 4:
                raise InputError(f"{source}: runout.{key} must be a list of 4 numbers (x1, y1, x2, y2)")
            values[key] = column

        def vector(harmonic: str) -> tuple:
            amplitude = values[f"runout_{harmonic}_um"] * 1e-6
            return tuple(amplitude * np.exp(1j * np.radians(values[f"runout_{harmonic}_phase_deg"])))

        return cls(
            vector("1x"),
            vector("2x"),
            tuple(values["runout_1x_std_um"] * 1e-6),
            tuple(values["runout_2x_std_um"] * 1e-6),
        )


def fit_slow_roll(times_s: np.ndarray, signals_m: np.ndarray, rotor_angle_rad: np.ndarray) -> SlowRollVectors:
    """The slow-roll vectors (module docstring) of a record: times (K,) [s], probe signals (K, 4) [m] along
    each probe's axis, rotor angle from the keyphasor (K,) [rad]. Non-finite samples of a probe are left out
    of its fit; a probe needs at least two revolutions of finite samples."""
    times = np.asarray(times_s, dtype=float)
    signals = np.asarray(signals_m, dtype=float)
    theta = np.asarray(rotor_angle_rad, dtype=float)
    if signals.ndim != 2 or signals.shape[1] != 4 or len(times) != len(signals) or len(theta) != len(signals):
        raise InputError("a slow-roll record needs times (K,), signals (K, 4) and rotor angles (K,)")
    span = times - times.mean()
    basis = np.column_stack(
        [np.ones_like(times), span, np.cos(theta), np.sin(theta), np.cos(2 * theta), np.sin(2 * theta)]
    )
    once, twice, once_std, twice_std = [], [], [], []
    for k, name in enumerate(PROBES):
        valid = np.isfinite(signals[:, k]) & np.isfinite(theta)
        turns = (theta[valid].max() - theta[valid].min()) / (2.0 * math.pi) if valid.any() else 0.0
        if valid.sum() <= basis.shape[1] or turns < 2.0:
            raise InputError(
                f"slow-roll record: probe {name} has {turns:.1f} revolution(s) of finite samples; at least 2 "
                "are needed to fit its 1x and 2x vectors"
            )
        a, z = basis[valid], signals[valid, k]
        coefficients, *_ = np.linalg.lstsq(a, z, rcond=None)
        residual = z - a @ coefficients
        variance = residual @ residual / (len(z) - a.shape[1])
        covariance = variance * np.linalg.inv(a.T @ a)
        # c cos(theta) + s sin(theta) = Re(V exp(i theta)) with V = c - i s
        once.append(complex(coefficients[2], -coefficients[3]))
        twice.append(complex(coefficients[4], -coefficients[5]))
        once_std.append(math.sqrt(0.5 * (covariance[2, 2] + covariance[3, 3])))
        twice_std.append(math.sqrt(0.5 * (covariance[4, 4] + covariance[5, 5])))
    return SlowRollVectors(tuple(once), tuple(twice), tuple(once_std), tuple(twice_std))


class RunoutCompensation:
    """Subtracts the slow-roll runout from each sample the estimator gets (module docstring).

    vectors : the slow-roll vectors, or None (no compensation: the samples pass unchanged).
    omega_rad_s : the rotor speed; dt_s : the sample period; first_sample_time_s : the time of sample 0
    (t = 0 at the keyphasor, as the model's unbalance phase).
    """

    def __init__(
        self, vectors: SlowRollVectors | None, omega_rad_s: float, dt_s: float, first_sample_time_s: float
    ) -> None:
        self.vectors = vectors
        self._omega = float(omega_rad_s)
        self._dt = float(dt_s)
        self._t0 = float(first_sample_time_s)

    @classmethod
    def for_model(
        cls, vectors: SlowRollVectors | None, model, first_sample_time_s: float
    ) -> RunoutCompensation:
        """The compensation at the model's speed (``model.speed_hz``) and period (``model.dt_s``)."""
        if vectors is None:
            return cls(None, 0.0, model.dt_s, first_sample_time_s)
        speed = getattr(model, "speed_hz", None)
        if speed is None:
            raise InputError("EKFConfig.runout needs a model with speed_hz (the rotor angle of each sample)")
        return cls(vectors, 2.0 * math.pi * speed, model.dt_s, first_sample_time_s)

    def residual_covariance_m2(self) -> np.ndarray:
        """(4, 4) extra measurement-noise covariance [m^2] of the displacement channels (zeros without)."""
        if self.vectors is None:
            return np.zeros((4, 4))
        return np.diag(self.vectors.residual_variance_m2())

    def compensate(
        self, displacement_m: np.ndarray, step: int, rotor_angle_rad: float | None = None
    ) -> np.ndarray:
        """Sample ``step`` (4,) [m] minus the runout at its rotor angle (the input itself without vectors):
        ``rotor_angle_rad`` when given (the keyphasor's, or the integral of the measured speed), else
        ``Omega t`` at the constant speed."""
        if self.vectors is None:
            return displacement_m
        theta = self._omega * (self._t0 + step * self._dt) if rotor_angle_rad is None else rotor_angle_rad
        return displacement_m - self.vectors.runout_m(theta)


def runout_of_probes(probes) -> SlowRollVectors | None:
    """The runout vectors the machine file's ``[probes]`` gives (``oilwatch.models.probes.Probes.runout``), or
    None."""
    if probes.runout is None:
        return None
    return SlowRollVectors.from_document(probes.runout, "machine file [probes]")
