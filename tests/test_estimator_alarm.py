"""The starvation alarm: its rule on synthetic estimate sequences, then end to end on the toy rotor."""

from __future__ import annotations

import numpy as np
import pytest
from fixtures.toy_model import NOMINAL_FLOWRATE_M3_S, ToyRotor, simulate

from oilwatch.estimator.alarm import StarvationAlarm
from oilwatch.estimator.alarm_config import AlarmConfig
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig

QN = NOMINAL_FLOWRATE_M3_S
DT = 1e-3


def _feed(alarm, fractions, std_fraction=0.0):
    flags = []
    for value in fractions:
        q = np.atleast_1d(value) * QN * np.ones(2)
        flags.append(alarm.update(q, np.full(2, std_fraction * QN)))
    return np.array(flags)


def test_sets_only_after_the_hold_time():
    alarm = StarvationAlarm(AlarmConfig(hold_on_s=0.1), DT, (QN, QN))
    flags = _feed(alarm, [0.8] * 99 + [1.0] + [0.8] * 100)
    assert not flags[:199].any()  # the interruption at step 99 restarts the hold
    assert flags[199].all()


def test_upper_confidence_bound_not_the_estimate_decides():
    alarm = StarvationAlarm(AlarmConfig(hold_on_s=0.01, confidence_z=2.0), DT, (QN, QN))
    assert not _feed(alarm, [0.85] * 100, std_fraction=0.03).any()  # 0.85 + 2 x 0.03 > 0.90
    assert _feed(alarm, [0.85] * 100, std_fraction=0.02)[-1].all()  # 0.85 + 2 x 0.02 < 0.90


def test_hysteresis_keeps_the_alarm_between_the_levels():
    config = AlarmConfig(on_fraction=0.9, off_fraction=0.95, hold_on_s=0.01, hold_off_s=0.2)
    alarm = StarvationAlarm(config, DT, (QN, QN))
    assert _feed(alarm, [0.8] * 20)[-1].all()
    assert _feed(alarm, [0.93] * 1000).all()  # above the set level, below the clear level: stays
    flags = _feed(alarm, [0.97] * 250)
    assert flags[198].all() and not flags[199].any()


def test_alarm_state_round_trips():
    alarm = StarvationAlarm(AlarmConfig(), DT, (QN, QN))
    _feed(alarm, [0.8] * 100)
    other = StarvationAlarm(AlarmConfig(), DT, (QN, QN))
    other.set_state(alarm.get_state())
    assert np.array_equal(_feed(other, [0.8] * 300), _feed(alarm, [0.8] * 300))


@pytest.fixture(scope="module")
def toy():
    return ToyRotor()


def _config(sigma):
    return EKFConfig.recommended(noise_std_m=sigma)


def _sudden_drop(steps, bearings):
    """25 % sigmoid drop centred at 10 s, 10-90 % in 0.09 s, in the given bearings."""
    time = np.arange(steps) * DT
    fraction = 1.0 - 0.25 / (1.0 + np.exp(-(time - 10.0) / 0.02))
    q = np.full((steps, 2), QN)
    for b in bearings:
        q[:, b] = fraction * QN
    return q


@pytest.mark.slow
@pytest.mark.parametrize("sigma", [1e-6, 2e-6])
def test_never_fires_in_a_nominal_20_s_run(toy, sigma):
    record = simulate(toy, np.full((20000, 2), QN), sigma, seed=21)
    trace = OilFlowEKF(toy, _config(sigma)).run(record.displacement_m)
    assert not trace.starved.any()


@pytest.mark.parametrize("bearings", [(0, 1), (0,)], ids=["both", "bearing1"])
def test_fires_within_2_s_of_a_sudden_25_percent_drop(toy, bearings):
    record = simulate(toy, _sudden_drop(15000, bearings), 1e-6, seed=22)
    trace = OilFlowEKF(toy, _config(1e-6)).run(record.displacement_m)
    for b in range(2):
        fired = np.flatnonzero(trace.starved[:, b])
        if b in bearings:
            assert fired.size and 10.0 < fired[0] * DT <= 12.0
            assert trace.starved[fired[0] :, b].all()  # and it holds
        else:
            assert fired.size == 0
