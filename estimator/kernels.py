"""Numba kernels of the EKF hot path: covariance propagation and the Joseph-form measurement update.

:func:`filter_step` is one sample's predict and update in place; :mod:`oilwatch.estimator.step_kernel` wraps
it with the summary and the alarm into the one compiled call per sample. The covariance prediction's two large
products go to BLAS through ``np.dot``; the update's thin (m <= 8) products are loops. No matrix is ever
inverted: the gain comes from a hand-written Cholesky factorization of the (at most 8 x 8) innovation
covariance and triangular solves.

Reference: Y. Bar-Shalom, X. R. Li, T. Kirubarajan, "Estimation with Applications to Tracking and Navigation",
Wiley 2001, sections 5.2 (Joseph form) and 5.4 (NIS consistency test).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .channels import BIAS, LAST_ACCEPTED, POWER, PREVIOUS_ACCEPTED, gate_channels, screen_channels
from .filter_arrays import FilterArrays

UPDATE_ACCEPTED = 0
UPDATE_GATED = 1
UPDATE_NOT_POSITIVE = 2
UPDATE_SKIPPED = 3


@njit(cache=True)
def predict_covariance(
    covariance: np.ndarray,
    state_jacobian: np.ndarray,
    flowrate_jacobian: np.ndarray,
    flowrate_scale: np.ndarray,
    unbalance_jacobian: np.ndarray,
    process_noise: np.ndarray,
    augmented_jacobian: np.ndarray,
    work: np.ndarray,
) -> None:
    """In place ``P <- J P J^T + Q`` (Eq. 20), symmetrized; J = [[df/ds, df/dq c, 0, df/du], [0, I]].

    The state is ``[s (n), q (2), probe offsets (0 or 4), unbalance (0 or 2)]``, the nuisances random walks.

    covariance : (N, N) P. state_jacobian : (n, n). flowrate_jacobian : (n, 2) per model flowrate unit;
    flowrate_scale c (2,), each bearing's, converts its column to the filter's unit. unbalance_jacobian :
    (n, 0 or 2), the last columns.
    process_noise : (N, N) Q. augmented_jacobian, work : (N, N) scratch.

    Only the first n rows of J differ from the identity, so with ``T = J[:n] P`` (n, N) the result is
    ``P[:n, :n] = T J[:n]^T``, ``P[:n, n:] = T[:, n:]`` (and its transpose), ``P[n:, n:]`` unchanged: two
    products of n x n x N instead of two of N^3.
    """
    n = state_jacobian.shape[0]
    size = covariance.shape[0]
    n_unbalance = unbalance_jacobian.shape[1]
    top = augmented_jacobian[:n]  # J[:n], contiguous rows
    for i in range(n):
        for j in range(n):
            top[i, j] = state_jacobian[i, j]
        for j in range(n, n + 2):
            top[i, j] = flowrate_jacobian[i, j - n] * flowrate_scale[j - n]
        for j in range(n + 2, size - n_unbalance):
            top[i, j] = 0.0
        for j in range(n_unbalance):
            top[i, size - n_unbalance + j] = unbalance_jacobian[i, j]
    product = work[:n]  # T = J[:n] P, (n, N)
    np.dot(top, covariance, product)
    block = np.empty((n, n))
    np.dot(product, top.T, block)
    for i in range(n):
        covariance[i, i] = block[i, i] + process_noise[i, i]
        for j in range(i):
            value = 0.5 * (block[i, j] + block[j, i]) + process_noise[i, j]
            covariance[i, j] = value
            covariance[j, i] = value
        for j in range(n, size):
            value = product[i, j] + process_noise[i, j]
            covariance[i, j] = value
            covariance[j, i] = value
    for i in range(n, size):
        covariance[i, i] += process_noise[i, i]
        for j in range(n, i):
            value = 0.5 * (covariance[i, j] + covariance[j, i]) + process_noise[i, j]
            covariance[i, j] = value
            covariance[j, i] = value


@njit(cache=True)
def _cholesky_lower(matrix: np.ndarray) -> bool:
    """In-place lower Cholesky factor of a small SPD matrix; False if it is not positive definite."""
    m = matrix.shape[0]
    for j in range(m):
        diagonal = matrix[j, j]
        for k in range(j):
            diagonal -= matrix[j, k] * matrix[j, k]
        if not diagonal > 0.0:
            return False
        root = np.sqrt(diagonal)
        matrix[j, j] = root
        for i in range(j + 1, m):
            value = matrix[i, j]
            for k in range(j):
                value -= matrix[i, k] * matrix[j, k]
            matrix[i, j] = value / root
        for i in range(j):
            matrix[i, j] = 0.0
    return True


@njit(cache=True)
def _solve_lower_inplace(lower: np.ndarray, rhs: np.ndarray) -> None:
    """In place ``rhs <- L^-1 rhs`` for rhs (m, k)."""
    m = lower.shape[0]
    for i in range(m):
        for k in range(i):
            factor = lower[i, k]
            for c in range(rhs.shape[1]):
                rhs[i, c] -= factor * rhs[k, c]
        inverse = 1.0 / lower[i, i]
        for c in range(rhs.shape[1]):
            rhs[i, c] *= inverse


@njit(cache=True)
def _solve_upper_transposed_inplace(lower: np.ndarray, rhs: np.ndarray) -> None:
    """In place ``rhs <- L^-T rhs`` for rhs (m, k)."""
    m = lower.shape[0]
    for i in range(m - 1, -1, -1):
        for k in range(i + 1, m):
            factor = lower[k, i]
            for c in range(rhs.shape[1]):
                rhs[i, c] -= factor * rhs[k, c]
        inverse = 1.0 / lower[i, i]
        for c in range(rhs.shape[1]):
            rhs[i, c] *= inverse


@njit(cache=True)
def update(
    state: np.ndarray,
    covariance: np.ndarray,
    observation: np.ndarray,
    measurement: np.ndarray,
    measurement_noise: np.ndarray,
    gate_threshold: float,
) -> tuple[int, float]:
    """Kalman update (Eqs. 22-24) in Joseph form, gated on the NIS, in place.

    state : (N,) x. covariance : (N, N) P. observation : (m, N) H_a. measurement : (m,) z.
    measurement_noise : (m, m) R. gate_threshold : the update is refused when the NIS exceeds it.

    Returns ``(status, nis)`` with status UPDATE_ACCEPTED, UPDATE_GATED (x and P untouched) or
    UPDATE_NOT_POSITIVE (the innovation covariance lost definiteness; x and P untouched).
    """
    return update_with_cross(
        state,
        covariance,
        observation,
        np.dot(observation, covariance),
        measurement,
        measurement_noise,
        gate_threshold,
    )


@njit(cache=True, fastmath={"reassoc", "contract"})
def update_with_cross(
    state: np.ndarray,
    covariance: np.ndarray,
    observation: np.ndarray,
    cross: np.ndarray,
    measurement: np.ndarray,
    measurement_noise: np.ndarray,
    gate_threshold: float,
) -> tuple[int, float]:
    """:func:`update` with ``cross = H P`` (m, N) already computed.

    The Joseph form ``P+ = (I - K H) P (I - K H)^T + K R K^T`` is evaluated as
    ``A = P - K (H P)``, ``P+ = A + (K R - A H^T) K^T``, which costs O(m N^2) instead of O(N^3); the second
    term vanishes in exact arithmetic for the optimal gain and is what makes the form insensitive to gain
    errors. The products are loops over contiguous rows (m <= 8 is too thin for BLAS to pay); reassociation
    lets the compiler vectorize them (a few ulps from sequential sums).
    """
    m = observation.shape[0]
    size = state.shape[0]
    innovation_cov = np.empty((m, m))
    for i in range(m):
        for j in range(i + 1):
            value = 0.0
            for c in range(size):
                value += cross[i, c] * observation[j, c]
            innovation_cov[i, j] = value
    for i in range(m):  # symmetric: the lower triangle, mirrored
        for j in range(i):
            value = innovation_cov[i, j] + 0.5 * (measurement_noise[i, j] + measurement_noise[j, i])
            innovation_cov[i, j] = value
            innovation_cov[j, i] = value
        innovation_cov[i, i] += measurement_noise[i, i]
    whitened = np.empty((m, 1))
    for i in range(m):
        value = measurement[i]
        for c in range(size):
            value -= observation[i, c] * state[c]
        whitened[i, 0] = value
    lower = innovation_cov
    if not _cholesky_lower(lower):
        return UPDATE_NOT_POSITIVE, np.inf
    _solve_lower_inplace(lower, whitened)
    nis = 0.0
    for i in range(m):
        nis += whitened[i, 0] * whitened[i, 0]
    if nis > gate_threshold:
        return UPDATE_GATED, nis
    _solve_upper_transposed_inplace(lower, whitened)  # S^-1 y
    gain_t = cross.copy()  # becomes K^T = S^-1 H P, (m, N)
    _solve_lower_inplace(lower, gain_t)
    _solve_upper_transposed_inplace(lower, gain_t)
    for i in range(m):
        weight = whitened[i, 0]
        for j in range(size):
            state[j] += cross[i, j] * weight
    # A = P - K (H P), in place in P
    for i in range(size):
        row = covariance[i]
        for k in range(m):
            gain = gain_t[k, i]
            cross_row = cross[k]
            for j in range(size):
                row[j] -= gain * cross_row[j]
    # residual = K R - A H^T, (N, m)
    residual = np.empty((size, m))
    for i in range(size):
        row = covariance[i]
        for k in range(m):
            value = 0.0
            for c in range(m):
                value += gain_t[c, i] * measurement_noise[c, k]
            h_row = observation[k]
            for j in range(size):
                value -= row[j] * h_row[j]
            residual[i, k] = value
    # P+ = A + residual K^T
    for i in range(size):
        row = covariance[i]
        for k in range(m):
            weight = residual[i, k]
            gain_row = gain_t[k]
            for j in range(size):
                row[j] += weight * gain_row[j]
    for i in range(size):
        for j in range(i):
            value = 0.5 * (covariance[i, j] + covariance[j, i])
            covariance[i, j] = value
            covariance[j, i] = value
    return UPDATE_ACCEPTED, nis


@njit(cache=True)
def project_flowrates(state: np.ndarray, covariance: np.ndarray, bounds: np.ndarray, first: int = -1) -> None:
    """Project the two flowrate entries (``first``, ``first + 1``; -1: the last two) each onto its bearing's
    range in the P^-1 metric; ``bounds`` (4,) (low1, high1, low2, high2).

    For the active set A: ``x <- x - P[:, A] P[A, A]^-1 (x_A - bound_A)`` (Simon & Chia 2002), which moves the
    correlated dynamic states with the flowrates; then the active entries are set exactly to their bounds.
    """
    size = state.shape[0]
    if first < 0:
        first = size - 2  # the flowrates are the last two entries
    excess = np.zeros(2)
    active = np.zeros(2, dtype=np.bool_)
    for b in range(2):
        value = state[first + b]
        low, high = bounds[2 * b], bounds[2 * b + 1]
        if value < low:
            excess[b], active[b] = value - low, True
        elif value > high:
            excess[b], active[b] = value - high, True
    if not (active[0] or active[1]):
        return
    if active[0] and active[1]:
        p00 = covariance[first, first]
        p01 = covariance[first, first + 1]
        p11 = covariance[first + 1, first + 1]
        determinant = p00 * p11 - p01 * p01
        weight0 = (p11 * excess[0] - p01 * excess[1]) / determinant
        weight1 = (p00 * excess[1] - p01 * excess[0]) / determinant
        for i in range(size):
            state[i] -= covariance[i, first] * weight0 + covariance[i, first + 1] * weight1
    else:
        b = 0 if active[0] else 1
        weight = excess[b] / covariance[first + b, first + b]
        for i in range(size):
            state[i] -= covariance[i, first + b] * weight
    for b in range(2):
        state[first + b] = min(max(state[first + b], bounds[2 * b]), bounds[2 * b + 1])


@njit(cache=True)
def filter_step(
    a: FilterArrays,
    predict: bool,
    next_state: np.ndarray,
    state_jacobian: np.ndarray,
    flowrate_jacobian: np.ndarray,
    flowrate_scale: np.ndarray,
    displacement: np.ndarray,
) -> tuple[int, float, int, int]:
    """One complete EKF step after the model's transition, in place: the hot path in one compiled call.

    a : the filter's arrays (:class:`oilwatch.estimator.filter_arrays.FilterArrays`; this step reads and
    advances those up to ``changing``). predict : whether ``next_state`` and the Jacobians are to be applied
    (False on the first sample); the flowrate columns of the Jacobian are per ``flowrate_scale`` (2,), each
    bearing's nominal flowrate [m^3/s].
    displacement : (4,) sample [m]; non-finite entries drop their channels. ``a.settings`` : [1/dt, each
    bearing's flowrate low and high (low1, high1, low2, high2), change-test null variance, change-test
    threshold, each bearing's flowrate process variance (two), extra variance while changing] (filter units).
    ``a.accepted`` : (4,) bool out, the displacement channels used. ``a.changing`` : (2,) bool out, the change
    test of :func:`detect_change`.

    Every screened channel that passes its own gate is used (:mod:`oilwatch.estimator.channels`); a
    differentiated velocity channel only when its displacement channel was accepted in this and the previous
    sample. Returns ``(status, nis, rows used, channels rejected by the gate)``; status is one of the UPDATE_*
    constants (UPDATE_SKIPPED when no channel was usable, UPDATE_GATED when all usable ones were rejected).
    """
    state, covariance, process_noise, settings = a.state, a.covariance, a.process_noise, a.settings
    health, health_values, channel_settings = a.health, a.health_values, a.channel_settings
    observation4, noise4, observation8, noise8 = a.observation4, a.noise4, a.observation8, a.noise8
    accepted, stacked = a.accepted, a.stacked
    n = state_jacobian.shape[0]
    if predict:
        for i in range(n):
            state[i] = next_state[i]
        predict_covariance(
            covariance,
            state_jacobian,
            flowrate_jacobian,
            flowrate_scale,
            a.trailing_jacobian,
            process_noise,
            a.augmented_jacobian,
            a.work,
        )
    usable = np.zeros(4, dtype=np.bool_)
    screen_channels(displacement, health, health_values, channel_settings, usable)
    cross4 = np.dot(observation4, covariance)
    innovation = np.zeros(4)
    variance = np.ones(4)
    for i in range(4):
        if usable[i]:
            innovation[i] = displacement[i] - np.dot(observation4[i], state)
            variance[i] = np.dot(cross4[i], observation4[i]) + noise4[i, i]
    rejected = gate_channels(innovation, variance, health, health_values, channel_settings, usable, accepted)
    rows = np.zeros(8, dtype=np.int64)
    m = 0
    for i in range(4):
        if accepted[i]:
            rows[m] = i
            stacked[m] = displacement[i]
            m += 1
    eight = observation8.shape[0] == 8
    m4 = m
    if eight:
        for i in range(4):
            if accepted[i] and health[i, PREVIOUS_ACCEPTED] == 1:
                rows[m] = 4 + i
                stacked[m] = (displacement[i] - health_values[i, LAST_ACCEPTED]) * settings[0]
                m += 1
    for i in range(4):
        health[i, PREVIOUS_ACCEPTED] = 1 if accepted[i] else 0
        if accepted[i]:
            health_values[i, LAST_ACCEPTED] = displacement[i]
    detect_change(state, n, health_values, process_noise, settings, a.changing)
    if m == 0:
        return (UPDATE_GATED if rejected > 0 else UPDATE_SKIPPED), 0.0, 0, rejected
    index = rows[:m]
    measured = stacked[:m].copy()
    if eight:
        observation = observation8[index]
        noise = noise8[index][:, index]
        cross = cross4[index[:m4]] if m == m4 else np.dot(observation, covariance)
    else:
        observation = observation4[index]
        noise = noise4[index][:, index]
        cross = cross4[index]
    status, nis = update_with_cross(state, covariance, observation, cross, measured, noise, np.inf)
    if status == UPDATE_ACCEPTED:
        project_flowrates(state, covariance, settings[1:5], n)
        return status, nis, m, rejected
    return status, nis, 0, rejected


@njit(cache=True)
def detect_change(
    state: np.ndarray,
    first: int,
    health_values: np.ndarray,
    process_noise: np.ndarray,
    settings: np.ndarray,
    changing: np.ndarray,
) -> None:
    """The per-bearing mean-innovation test (:mod:`oilwatch.estimator.ekf`); sets the flowrate process noise
    of the next prediction in ``process_noise`` and the flags ``changing`` (2,); the flowrates are
    ``state[first : first + 2]``.

    Each channel's mean is compared with its null spread scaled by the channel's observed innovation power
    (at least 1), so that a measurement noise larger than configured widens the test rather than firing it.
    A flowrate held on its table's bound gets no extra noise: the bias there is the bound's.
    """
    for b in range(2):
        statistic = 0.0
        for i in (2 * b, 2 * b + 1):
            statistic += health_values[i, BIAS] ** 2 / max(1.0, health_values[i, POWER])
        q = state[first + b]
        fires = statistic / settings[5] > settings[6] and settings[1 + 2 * b] < q < settings[2 + 2 * b]
        changing[b] = fires
        process_noise[first + b, first + b] = settings[7 + b] + (settings[9] if fires else 0.0)
