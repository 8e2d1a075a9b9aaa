"""The oil-flow EKF on the toy rotor: truth by RK4 with sub-steps, filter by its interpolated exact map.

Most tests use ``EKFConfig.recommended()`` (dynamic process noise 0.1 um and 0.1 um x Omega per step); the
paper's 10 um / 10 um/s (the defaults) make the filter conservative (NIS about 0.02 m), which the consistency
test would rightly reject.
"""

from __future__ import annotations

import numpy as np
import pytest
from fixtures.toy_model import NOMINAL_FLOWRATE_M3_S, TABLE_BOUNDS_M3_S, ToyRotor, simulate

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import ML_MIN, PROBE_REJECTED_S, EKFConfig
from oilwatch.models.validation import InputError

QN = NOMINAL_FLOWRATE_M3_S


@pytest.fixture(scope="module")
def toy():
    return ToyRotor()


@pytest.fixture(scope="module")
def constant_record(toy):
    """8 s at q = (80 %, 90 %) of nominal, sigma 1 um."""
    return simulate(toy, np.tile([0.8 * QN, 0.9 * QN], (8000, 1)), 1e-6, seed=11)


@pytest.mark.parametrize("tuned", [True, False], ids=["recommended-Q", "paper-Q"])
def test_constant_flowrates_are_identified_within_one_percent(toy, constant_record, tuned):
    config = EKFConfig.recommended() if tuned else EKFConfig()
    trace = OilFlowEKF(toy, config).run(constant_record.displacement_m)
    identified = trace.q_m3_s[5000:].mean(axis=0)
    truth = constant_record.flowrate_m3_s[0]
    assert np.abs(identified / truth - 1).max() < 0.01
    assert trace.converged[-1]
    assert trace.measurement_ok.all()


def test_nis_averages_the_number_of_measurements(toy):
    """Nominal run, recommended Q: mean NIS over 8 s within 10 % of m = 4 (its sampling std is 0.8 %; the rest
    allows for the interpolation and integration mismatch between filter and truth)."""
    record = simulate(toy, np.full((10000, 2), QN), 1e-6, seed=12)
    trace = OilFlowEKF(toy, EKFConfig.recommended()).run(record.displacement_m)
    assert (trace.n_measurements[2000:] == 4).all()
    assert trace.nis[2000:].mean() == pytest.approx(4.0, rel=0.10)
    error = trace.q_m3_s[2000:] - QN
    assert np.mean(np.abs(error) < 2 * trace.q_std_m3_s[2000:]) > 0.9


@pytest.mark.slow
def test_covariance_stays_symmetric_positive_definite_over_a_long_run(toy):
    record = simulate(toy, np.full((30000, 2), 0.85 * QN), 1e-6, seed=13)
    ekf = OilFlowEKF(toy, EKFConfig.recommended(velocity_noise="paper"))
    for k, z in enumerate(record.displacement_m):
        ekf.step(z)
        if k % 1000 == 999:
            covariance = ekf.covariance
            assert np.array_equal(covariance, covariance.T)
            scale = 1.0 / np.sqrt(np.diag(covariance))
            assert np.linalg.eigvalsh(covariance * np.outer(scale, scale)).min() > 0.0
    assert np.isfinite(ekf.covariance).all()


def test_flowrates_stay_inside_the_table(toy):
    """Truth at the table's lower edge: the estimate sits on the bound at times but never crosses it."""
    low, high = TABLE_BOUNDS_M3_S
    record = simulate(toy, np.full((4000, 2), low), 2e-6, seed=14)
    config = EKFConfig.recommended(initial_flowrate_std_m3_s=0.5 * QN)
    trace = OilFlowEKF(toy, config).run(record.displacement_m)
    assert (trace.q_m3_s >= low).all() and (trace.q_m3_s <= high).all()
    assert (trace.q_m3_s == low).any()
    assert np.abs(trace.q_m3_s[2000:] / low - 1).max() < 0.02


def test_a_nan_drops_its_channel_and_inf_samples_keep_the_state_finite(toy, constant_record):
    data = constant_record.displacement_m.copy()
    data[3000, 1] = np.nan
    data[3001:3003] = np.inf
    data[4000:4040] = np.nan  # shorter than PROBE_DEAD_S: a dropout, not a dead probe
    # gate off: this test is about bad samples only (the eight-channel modes' NIS is inflated, so a tight
    # gate would also reject a few good samples)
    config = EKFConfig.recommended(velocity_noise="paper", gate_tail_probability=0.0)
    ekf = OilFlowEKF(toy, config)
    trace = ekf.run(data)
    bad = ~np.isfinite(data).any(axis=1)
    assert (trace.measurement_ok == ~bad).all()
    assert (trace.n_measurements[bad] == 0).all()
    assert trace.n_measurements[3000] == 6  # three displacements and their three velocities
    # a channel's first good sample after a bad one has no previous sample: its displacement only
    assert trace.n_measurements[3003] == 4 and trace.n_measurements[4040] == 4
    assert trace.n_measurements[3004] == 8 and trace.n_measurements[4041] == 8
    assert not trace.probe_faulty.any()
    assert np.isfinite(ekf.dynamic_state).all() and np.isfinite(ekf.covariance).all()
    reference = OilFlowEKF(toy, config).run(constant_record.displacement_m)
    assert np.abs(trace.q_m3_s[5000:] - reference.q_m3_s[5000:]).max() < 0.005 * QN


def test_a_spike_is_gated_on_its_own_channel_and_does_not_corrupt_the_estimate(toy, constant_record):
    clean = OilFlowEKF(toy, EKFConfig.recommended())
    spiked = OilFlowEKF(toy, EKFConfig.recommended())
    data = constant_record.displacement_m.copy()
    data[6000, 2] += 200e-6
    reference = clean.run(constant_record.displacement_m)
    trace = spiked.run(data)
    assert trace.measurement_ok[6000] and trace.n_measurements[6000] == 3  # the three others
    assert trace.n_measurements[6001] == 4
    assert not trace.probe_faulty.any()
    deviation = np.abs(trace.q_m3_s[6000:] - reference.q_m3_s[6000:]).max()
    assert deviation < 1e-3 * QN
    ungated = OilFlowEKF(toy, EKFConfig.recommended(gate_tail_probability=0.0)).run(data)
    assert np.abs(ungated.q_m3_s[6000:] - reference.q_m3_s[6000:]).max() > 10 * deviation


def test_a_change_on_every_channel_widens_the_gate_without_flagging_probes(toy, constant_record):
    data = constant_record.displacement_m.copy()
    data[5000:] += 40e-6
    trace = OilFlowEKF(toy, EKFConfig.recommended()).run(data)
    assert not trace.measurement_ok[5000]
    assert trace.measurement_ok[5000:5100].any() and trace.measurement_ok[5500:].all()
    assert not trace.probe_faulty.any()
    assert np.isfinite(trace.q_m3_s).all()


def test_a_jump_on_one_probe_flags_that_probe_and_leaves_the_estimate(toy, constant_record):
    data = constant_record.displacement_m.copy()
    data[5000:, 1] += 40e-6
    config = EKFConfig.recommended()
    trace = OilFlowEKF(toy, config).run(data)
    reference = OilFlowEKF(toy, config).run(constant_record.displacement_m)
    flagged = np.flatnonzero(trace.probe_faulty[:, 1])
    assert flagged.size and flagged[0] == 5000 + round(PROBE_REJECTED_S / 1e-3) - 1
    assert trace.probe_faulty[flagged[0] :, 1].all() and not trace.probe_faulty[:, [0, 2, 3]].any()
    assert (trace.n_measurements[flagged[0] :] == 3).all()
    std = trace.q_std_m3_s[5000:]
    assert (np.abs(trace.q_m3_s[5000:] - reference.q_m3_s[5000:]) < 2.0 * std).all()


def test_save_and_restore_continue_bit_identically(toy, constant_record):
    data = constant_record.displacement_m.copy()
    data[2600] = np.nan
    config = EKFConfig.recommended(velocity_noise="paper")
    first = OilFlowEKF(toy, config)
    first.run(data[:2500])
    saved = first.get_state()
    snapshot = {key: value.copy() for key, value in saved.items()}
    continued = first.run(data[2500:3500])
    for key, value in saved.items():  # the export is a copy, untouched by later steps
        assert np.array_equal(value, snapshot[key])

    second = OilFlowEKF(toy, config)
    second.set_state(saved)
    replay = second.run(data[2500:3500])
    first.set_state(saved)
    rewind = first.run(data[2500:3500])
    for trace in (replay, rewind):
        for name in ("q_m3_s", "q_std_m3_s", "nis", "n_measurements", "converged", "starved"):
            assert np.array_equal(getattr(trace, name), getattr(continued, name)), name
    final = second.get_state()
    assert all(np.array_equal(final[key], first.get_state()[key]) for key in final)
    last = second.current_report()
    assert last.step == 3499 and np.array_equal(last.q_m3_s, continued.q_m3_s[-1])
    assert last.nis == continued.nis[-1] and np.array_equal(last.starved, continued.starved[-1])


def test_restore_refuses_a_malformed_state(toy):
    ekf = OilFlowEKF(toy)
    state = ekf.get_state()
    state["P"] = np.eye(3)
    with pytest.raises(Exception, match="'P'"):
        ekf.set_state(state)


def test_static_initial_state_starts_at_equilibrium(toy):
    config = EKFConfig(initial_state="static", q_initial_m3_s=(500 * ML_MIN, 600 * ML_MIN))
    ekf = OilFlowEKF(toy, config)
    expected = toy.static_state(np.array([500, 600]) * ML_MIN)
    assert np.array_equal(ekf.dynamic_state, expected)


def test_first_sample_time_aligns_the_unbalance_phase(toy, constant_record):
    """A record starting at t = dt: declared, the filter is as good as from t = 0; ignored, the one-step
    (27 deg) unbalance phase error shows in the NIS and the estimate."""
    data = constant_record.displacement_m[1:]
    truth = constant_record.flowrate_m3_s[0]
    aligned = OilFlowEKF(toy, EKFConfig.recommended(first_sample_time_s=1e-3)).run(data)
    shifted = OilFlowEKF(toy, EKFConfig.recommended()).run(data)
    assert np.abs(aligned.q_m3_s[5000:].mean(axis=0) / truth - 1).max() < 0.01
    assert aligned.nis[2000:].mean() == pytest.approx(4.0, rel=0.1)
    assert shifted.nis[2000:].mean() > 2 * aligned.nis[2000:].mean()
    with pytest.raises(InputError, match="first_sample_time_s"):
        OilFlowEKF(toy, EKFConfig(first_sample_time_s=0.5e-3))


class _MixedCoordinates:
    """The toy in coordinates u = T s (T random, well conditioned), as a reduced model's would be."""

    def __init__(self, toy, seed=0):
        rng = np.random.default_rng(seed)
        scale = np.diag([1e5] * 4 + [1e2] * 4)  # O(1) coordinates: what a modal basis might give
        self.t = (np.eye(8) + 0.3 * rng.standard_normal((8, 8))) @ scale
        self.t_inv = np.linalg.inv(self.t)
        self.toy = toy
        self.n_states, self.dt_s = 8, toy.dt_s
        self.bearing_flowrate_bounds_m3_s = toy.bearing_flowrate_bounds_m3_s
        self.nominal_flowrates_m3_s, self.speed_hz = toy.nominal_flowrates_m3_s, toy.speed_hz
        self.output_matrix = toy.output_matrix @ self.t_inv
        self.velocity_output_matrix = toy.velocity_output_matrix @ self.t_inv

    def transition(self, state, flowrate_m3_s, step):
        nxt, state_jac, flow_jac = self.toy.transition(self.t_inv @ state, flowrate_m3_s, step)
        return self.t @ nxt, self.t @ state_jac @ self.t_inv, self.t @ flow_jac

    def physical_covariance(self, displacement_std_m, velocity_std_m_s):
        return self.t @ self.toy.physical_covariance(displacement_std_m, velocity_std_m_s) @ self.t.T


def test_estimates_do_not_depend_on_the_models_coordinates(toy, constant_record):
    """The protocol's physical_covariance makes Q and P0 follow the model's coordinates: the same filter on
    mixed, rescaled coordinates gives the same flowrates (to round-off)."""
    data = constant_record.displacement_m[:3000]
    config = EKFConfig.recommended()
    plain = OilFlowEKF(toy, config).run(data)
    mixed = OilFlowEKF(_MixedCoordinates(toy), config).run(data)
    np.testing.assert_allclose(mixed.q_m3_s, plain.q_m3_s, rtol=1e-7)
    np.testing.assert_allclose(mixed.nis, plain.nis, rtol=1e-5, atol=1e-8)


def test_probes_mounted_at_an_angle_are_read_along_their_axes(toy, constant_record):
    angle = np.radians(45.0)
    c, s = np.cos(angle), np.sin(angle)
    data = constant_record.displacement_m.copy()
    for x, y in ((0, 1), (2, 3)):
        data[:, x], data[:, y] = (
            c * constant_record.displacement_m[:, x] + s * constant_record.displacement_m[:, y],
            -s * constant_record.displacement_m[:, x] + c * constant_record.displacement_m[:, y],
        )
    truth = constant_record.flowrate_m3_s[0]
    mounted = OilFlowEKF(toy, EKFConfig.recommended(probe_angle_deg=45.0)).run(data)
    assert np.abs(mounted.q_m3_s[5000:].mean(axis=0) / truth - 1).max() < 0.01
    assert not mounted.probe_faulty.any()
    ignored = OilFlowEKF(toy, EKFConfig.recommended()).run(data)
    assert np.abs(ignored.q_m3_s[5000:].mean(axis=0) / truth - 1).max() > 0.05


@pytest.mark.parametrize("tail", [0.05, 1e-3, 1e-6, 1e-12])
def test_the_gate_and_change_quantiles_are_the_chi_square_distributions(tail):
    """Closed forms instead of scipy.special (an FMU's start-up), against scipy.special's inverses."""
    from scipy.special import chdtri

    from oilwatch.estimator.ekf_setup import chi_square_upper_quantile

    for dof in (1, 2):
        assert chi_square_upper_quantile(dof, tail) == pytest.approx(chdtri(dof, tail), rel=1e-13)
    with pytest.raises(ValueError, match="1 or 2 degrees of freedom"):
        chi_square_upper_quantile(3, tail)
