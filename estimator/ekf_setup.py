"""How :class:`oilwatch.estimator.ekf.OilFlowEKF` is set up from its model and configuration.

The model's checks (:func:`check_model`), the augmented state's layout (:class:`StateLayout`) and the
fixed arrays of the compiled step (:mod:`oilwatch.estimator.filter_arrays`): the measurement matrices, the
settings of the update, the probe screening and the summary, the process noise and the counters. Each is
built once per filter; what a reset renews (x, P, ring buffers) is the filter's own
(:meth:`oilwatch.estimator.ekf.OilFlowEKF.reset`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from oilwatch.models.validation import InputError

from . import channels
from .ekf_config import (
    CHANGE_TAIL_PROBABILITY,
    CHANGE_WINDOW_S,
    CONSISTENCY_TAIL_PROBABILITY,
    CONVERGED_DRIFT_FRACTION,
    CONVERGED_STD_FRACTION,
    GATE_SCALE_WINDOW_S,
    PROBE_DEAD_S,
    PROBE_RANGE_MARGIN_M,
    PROBE_RECOVER_S,
    PROBE_REJECTED_S,
    PROBE_STUCK_S,
    PROBE_STUCK_TOLERANCE_M,
    UNBALANCE_INCONSISTENT_STD,
    VISCOSITY_FACTOR_RANDOM_WALK_SQRT_S,
    EKFConfig,
)
from .model import AugmentedModel, has_static_state
from .step_kernel import (
    COUNT_FIRST,
    COUNT_OFFSETS,
    COUNT_UNBALANCE,
    COUNT_VISCOSITY,
    N_COUNTERS,
    N_SUMMARY_SETTINGS,
    SUMMARY_CONSISTENCY_Z,
    SUMMARY_CONVERGED_DRIFT,
    SUMMARY_CONVERGED_STD,
    SUMMARY_HELD_STD,
    SUMMARY_Q_BOUNDS,
    SUMMARY_Q_NOMINAL,
    SUMMARY_UNBALANCE_EXTRA,
    SUMMARY_UNBALANCE_WALK,
)


@dataclass(frozen=True)
class StateLayout:
    """Where each part sits in ``x = [s; q / q_nominal; o; f; u]``: ``n`` dynamic states, two flowrates,
    then the estimated nuisances (each count 0 when it is not estimated)."""

    n: int
    n_offsets: int
    n_viscosity: int
    n_unbalance: int

    @classmethod
    def for_config(cls, model: AugmentedModel, cfg: EKFConfig) -> StateLayout:
        """The layout the configuration asks for (InputError for a nuisance the model cannot carry)."""
        n_offsets = 4 if cfg.offset_prior_std_m > 0.0 or cfg.offset_baseline is not None else 0
        n_unbalance = 2 if cfg.unbalance_prior_std > 0.0 else 0
        if n_unbalance and not callable(getattr(model, "transition_with_unbalance", None)):
            raise InputError(
                "EKFConfig.unbalance_prior_std > 0 needs a model with transition_with_unbalance()"
            )
        n_viscosity = 2 if cfg.viscosity_factor_prior_std > 0.0 else 0
        if n_viscosity and not callable(getattr(model, "transition_full", None)):
            raise InputError(
                "EKFConfig.viscosity_factor_prior_std > 0 needs a model with transition_full() (one that "
                "follows the operating point: oilwatch.models.system.operating_model)"
            )
        return cls(int(model.n_states), n_offsets, n_viscosity, n_unbalance)

    @property
    def offsets(self) -> slice:
        return slice(self.n + 2, self.n + 2 + self.n_offsets)

    @property
    def viscosity(self) -> slice:
        first = self.n + 2 + self.n_offsets
        return slice(first, first + self.n_viscosity)

    @property
    def unbalance(self) -> slice:
        first = self.n + 2 + self.n_offsets + self.n_viscosity
        return slice(first, first + self.n_unbalance)

    @property
    def n_trailing(self) -> int:
        """The trailing nuisance columns of the Jacobian (viscosity factors, unbalance): see kernels."""
        return self.n_viscosity + self.n_unbalance

    @property
    def size(self) -> int:
        return self.n + 2 + self.n_offsets + self.n_trailing

    def counters(self) -> np.ndarray:
        """The int64 counters array (``COUNT_*``) with the layout's entries set, step counts at 0."""
        counters = np.zeros(N_COUNTERS, dtype=np.int64)
        counters[COUNT_FIRST] = self.n
        for index, block in ((COUNT_VISCOSITY, self.viscosity), (COUNT_UNBALANCE, self.unbalance)):
            counters[index] = block.start if block.stop > block.start else -1
        counters[COUNT_OFFSETS] = self.offsets.start if self.n_offsets else -1
        return counters


def check_model(model: AugmentedModel, config: EKFConfig) -> None:
    """InputError naming the first property of ``model`` that the filter cannot work with."""
    n = model.n_states
    if not isinstance(n, int | np.integer) or n < 1:
        raise InputError(f"model.n_states must be a positive integer, got {n!r}")
    for name in ("output_matrix", "velocity_output_matrix"):
        shape = np.shape(getattr(model, name))
        if shape != (4, n):
            raise InputError(f"model.{name} must have shape (4, {n}), got {shape}")
    if not float(model.dt_s) > 0.0:
        raise InputError(f"model.dt_s must be > 0 s, got {model.dt_s!r}")
    bounds = np.asarray(model.bearing_flowrate_bounds_m3_s, dtype=float)
    if bounds.shape != (2, 2):
        raise InputError(
            f"model.bearing_flowrate_bounds_m3_s must have shape (2, 2) (each bearing's low, high), got "
            f"{bounds.shape}"
        )
    for b, ((low, high), value) in enumerate(zip(bounds, config.q_initial_pair(), strict=True), start=1):
        if not 0.0 < low < high:
            raise InputError(
                f"model.bearing_flowrate_bounds_m3_s of bearing {b} must satisfy 0 < low < high, got {low}, "
                f"{high}"
            )
        if not low <= value <= high:
            raise InputError(
                f"EKFConfig.q_initial_m3_s of bearing {b} must lie in its table range "
                f"[{low:g}, {high:g}] m^3/s, got {value:g}"
            )
    if config.initial_state == "static" and not has_static_state(model):
        raise InputError("EKFConfig.initial_state='static' needs a model with static_state()")


def chi_square_upper_quantile(dof: int, tail_probability: float) -> float:
    """The chi-square quantile with ``dof`` (1 or 2) degrees of freedom exceeded with ``tail_probability``.

    The closed forms, not ``scipy.special.chdtri``: importing scipy.special costs the estimator FMU's start
    40 ms for two numbers. One degree: the square of the normal quantile of half the tail
    (``-inv_cdf(p / 2)``, not ``inv_cdf(1 - p / 2)``, which loses the digits of a small tail); two: the
    exponential's, ``-2 ln p``.
    """
    if dof == 1:
        return NormalDist().inv_cdf(0.5 * tail_probability) ** 2
    if dof == 2:
        return -2.0 * math.log(tail_probability)
    raise ValueError(f"chi_square_upper_quantile takes 1 or 2 degrees of freedom, got {dof}")


def channel_settings(cfg: EKFConfig, model: AugmentedModel, dt: float) -> np.ndarray:
    """The settings array of :mod:`oilwatch.estimator.channels` from the configuration and the model."""
    p = cfg.gate_tail_probability
    gate = chi_square_upper_quantile(1, p) if p > 0.0 else np.inf
    if getattr(model, "clearance_m", None) is not None:
        limit = float(model.clearance_m) + PROBE_RANGE_MARGIN_M
    else:
        limit = np.inf
    values = np.zeros(channels.N_CHANNEL_SETTINGS)
    values[channels.GATE] = gate
    values[channels.RANGE] = limit
    values[channels.DEAD_SAMPLES] = max(1, round(PROBE_DEAD_S / dt))
    values[channels.STUCK_SAMPLES] = max(2, round(PROBE_STUCK_S / dt))
    values[channels.STUCK_TOLERANCE] = PROBE_STUCK_TOLERANCE_M
    values[channels.REJECTED_SAMPLES] = max(1, round(PROBE_REJECTED_S / dt))
    values[channels.RECOVER_SAMPLES] = max(1, round(PROBE_RECOVER_S / dt))
    values[channels.POWER_ALPHA] = min(1.0, dt / GATE_SCALE_WINDOW_S)
    values[channels.BIAS_ALPHA] = min(1.0, dt / CHANGE_WINDOW_S)
    return values


def physical_covariance(
    model: AugmentedModel, n: int, displacement_std: float, velocity_std: float
) -> np.ndarray:
    """The model's (n, n) covariance of the dynamic states for these stds, symmetrized."""
    if displacement_std == 0.0 and velocity_std == 0.0:
        return np.zeros((n, n))
    covariance = np.asarray(model.physical_covariance(displacement_std, velocity_std))
    if covariance.shape != (n, n):
        raise InputError(f"model.physical_covariance must return shape ({n}, {n}), got {covariance.shape}")
    return 0.5 * (covariance + covariance.T)


def step_settings(cfg: EKFConfig, dt: float, bounds_scaled: np.ndarray, q_var: np.ndarray) -> np.ndarray:
    """:func:`oilwatch.estimator.kernels.filter_step`'s settings array (filter units); ``bounds_scaled``
    (2, 2) each bearing's (low, high), ``q_var`` (2,) each bearing's flowrate process variance."""
    change_alpha = min(1.0, dt / CHANGE_WINDOW_S)
    return np.array(
        [
            1.0 / dt,
            *np.ravel(bounds_scaled),
            change_alpha / (2.0 - change_alpha),  # null variance of the fading-memory mean
            chi_square_upper_quantile(2, CHANGE_TAIL_PROBABILITY),
            *q_var,
            cfg.change_flowrate_std_fraction**2,  # internal unit: fractions of each bearing's nominal
        ]
    )


def summary_settings(
    cfg: EKFConfig, q_nominal: np.ndarray, bounds: np.ndarray, unbalance_walk: float
) -> np.ndarray:
    """The ``SUMMARY_*`` settings array of :func:`oilwatch.estimator.step_kernel.step_summary`; ``q_nominal``
    (2,) each bearing's nominal flowrate, ``bounds`` (2, 2) each bearing's flowrate range (low, high)
    [m^3/s]."""
    settings = np.zeros(N_SUMMARY_SETTINGS)
    settings[SUMMARY_Q_NOMINAL : SUMMARY_Q_NOMINAL + 2] = q_nominal
    settings[SUMMARY_Q_BOUNDS : SUMMARY_Q_BOUNDS + 4] = np.ravel(bounds)
    settings[SUMMARY_CONSISTENCY_Z] = -NormalDist().inv_cdf(CONSISTENCY_TAIL_PROBABILITY)
    settings[SUMMARY_CONVERGED_STD] = CONVERGED_STD_FRACTION
    settings[SUMMARY_CONVERGED_DRIFT] = CONVERGED_DRIFT_FRACTION
    settings[SUMMARY_UNBALANCE_WALK] = unbalance_walk
    settings[SUMMARY_UNBALANCE_EXTRA] = UNBALANCE_INCONSISTENT_STD**2
    settings[SUMMARY_HELD_STD : SUMMARY_HELD_STD + 2] = cfg.initial_flowrate_std_pair()
    return settings


def process_noise(
    model: AugmentedModel,
    cfg: EKFConfig,
    layout: StateLayout,
    dt: float,
    q_var: np.ndarray,
    unbalance_walk: float,
) -> np.ndarray:
    """Q of the augmented state: the model's physical noise, the flowrates' and the nuisances' walks."""
    n = layout.n
    noise = np.zeros((layout.size, layout.size))
    physical = physical_covariance(model, n, cfg.displacement_process_std_m, cfg.velocity_process_std_m_s)
    noise[:n, :n] = physical
    noise[n : n + 2, n : n + 2] = np.diag(q_var)
    if layout.n_offsets:
        walk = cfg.offset_random_walk_m_sqrt_s**2 * dt
        noise[layout.offsets, layout.offsets] = walk * np.eye(layout.n_offsets)
    if layout.n_unbalance:
        noise[layout.unbalance, layout.unbalance] = unbalance_walk * np.eye(2)
    if layout.n_viscosity:
        walk = VISCOSITY_FACTOR_RANDOM_WALK_SQRT_S**2 * dt
        noise[layout.viscosity, layout.viscosity] = walk * np.eye(2)
    return noise
