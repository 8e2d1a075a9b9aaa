"""The prior a commissioning baseline gives the estimator's nuisance states (probe offsets, viscosity
factors, unbalance), widened by the probes' drift since the baseline was recorded."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from oilwatch.models.validation import InputError, require_finite, require_in_range, require_positive


@dataclass(frozen=True)
class OffsetBaseline:
    """A commissioning baseline (:mod:`oilwatch.estimator.baseline`): the nuisances' estimates at a known
    healthy condition, which become the estimator's prior.

    offsets_m, std_m : (x1, y1, x2, y2) probe zero offsets and their stds [m], std > 0.
    viscosity_factor, viscosity_factor_std : (2,) each bearing's viscosity factor and its std, or None (the
        baseline did not estimate them; the prior stays 1 +- ``viscosity_factor_prior_std``).
    unbalance, unbalance_std : (re, im) the unbalance relative to the machine file's and its stds, or None.
    covariance : the joint covariance of those estimates, in the state's order (offsets [m], then the
        viscosity factors and the unbalance when given), or None (independent). A factor read from the 1x
        orbit and the offsets that then reproduce the static position are strongly correlated; keeping the
        correlation lets a later run move both together instead of reading the factor's error as flow.
    age_s : time from the baseline record to the start of the record the estimator runs on [s]; the
        offsets' prior std is widened by the drift that time allows (:meth:`offset_prior_std_m`).
    drift_m_per_day : the probes' zero drift rate bound [m / day] (the machine file's
        ``[probes] offset_drift_um_per_day``) that ``age_s`` is multiplied by.
    flowrates_m3_s : the baseline record's known flowrates (q1, q2) [m^3/s], or None (not recorded).
    static_reference_m : (x1, y1, x2, y2) the baseline record's mean probe signals [m], or None: the static
        position the flowrates' change is read from during a model mismatch
        (:mod:`oilwatch.estimator.baseline_change`).
    static_reference_speed_hz, static_reference_temperature_c : the baseline record's mean speed [Hz] and
        oil temperature [degC], or None (not measured: taken as the run's).
    """

    offsets_m: tuple[float, float, float, float]
    std_m: tuple[float, float, float, float]
    viscosity_factor: tuple[float, float] | None = None
    viscosity_factor_std: tuple[float, float] | None = None
    unbalance: tuple[float, float] | None = None
    unbalance_std: tuple[float, float] | None = None
    covariance: tuple[tuple[float, ...], ...] | None = None
    age_s: float = 0.0
    drift_m_per_day: float = 0.0
    flowrates_m3_s: tuple[float, float] | None = None
    static_reference_m: tuple[float, float, float, float] | None = None
    static_reference_speed_hz: float | None = None
    static_reference_temperature_c: float | None = None

    def __post_init__(self) -> None:
        for name in ("offsets_m", "std_m"):
            values = getattr(self, name)
            if len(values) != 4:
                raise InputError(f"OffsetBaseline.{name} needs 4 values (x1, y1, x2, y2), got {len(values)}")
            for value in values:
                require_finite(f"OffsetBaseline.{name}", value)
        for value in self.std_m:
            require_positive("OffsetBaseline.std_m", value, "m")
        for name in ("viscosity_factor", "unbalance"):
            values, std = getattr(self, name), getattr(self, f"{name}_std")
            if (values is None) != (std is None):
                raise InputError(f"OffsetBaseline.{name} and {name}_std are given together or not at all")
            if values is None:
                continue
            if len(values) != 2 or len(std) != 2:
                raise InputError(f"OffsetBaseline.{name} and {name}_std need 2 values each")
            for value in values:
                require_finite(f"OffsetBaseline.{name}", value)
            for value in std:
                require_positive(f"OffsetBaseline.{name}_std", value)
        if self.covariance is not None:
            size = 4 + 2 * (self.viscosity_factor is not None) + 2 * (self.unbalance is not None)
            matrix = np.asarray(self.covariance, dtype=float)
            if matrix.shape != (size, size) or not np.isfinite(matrix).all():
                raise InputError(
                    f"OffsetBaseline.covariance must be a finite {size} x {size} matrix, got {matrix.shape}"
                )
        if (self.static_reference_m is None) != (self.flowrates_m3_s is None):
            raise InputError("OffsetBaseline.static_reference_m and flowrates_m3_s are given together")
        if self.static_reference_m is not None:
            if len(self.static_reference_m) != 4 or len(self.flowrates_m3_s) != 2:
                raise InputError("OffsetBaseline.static_reference_m needs 4 values and flowrates_m3_s 2")
            for value in (*self.static_reference_m, *self.flowrates_m3_s):
                require_finite("OffsetBaseline.static_reference_m", value)
        require_in_range("OffsetBaseline.age_s", self.age_s, 0.0, 1e9, "s")
        require_in_range("OffsetBaseline.drift_m_per_day", self.drift_m_per_day, 0.0, 1e-3, "m/day")

    def offset_prior_std_m(self) -> np.ndarray:
        """(4,) the offsets' prior std [m]: the baseline's std and the drift since it in quadrature (a drift
        of at most ``drift_m_per_day`` over ``age_s``, of unknown sign, taken as one std)."""
        return np.sqrt(np.square(self.std_m) + self._drift_variance_m2())

    def _drift_variance_m2(self) -> float:
        return (self.drift_m_per_day * self.age_s / 86400.0) ** 2

    def prior_covariance(self, viscosity: bool, unbalance: bool) -> np.ndarray | None:
        """The joint prior covariance of a filter whose nuisance states are the offsets plus the viscosity
        factors / the unbalance as flagged, when it holds exactly the baseline's (None otherwise); the
        offsets' block widened as :meth:`offset_prior_std_m`."""
        if (
            self.covariance is None
            or viscosity != (self.viscosity_factor is not None)
            or unbalance != (self.unbalance is not None)
        ):
            return None
        matrix = np.array(self.covariance, dtype=float)
        matrix[range(4), range(4)] += self._drift_variance_m2()
        return 0.5 * (matrix + matrix.T)
