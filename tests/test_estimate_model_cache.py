"""``oilwatch estimate`` builds its estimator model once per process, in follow mode too.

The operating model (``--operating-point follow``, the FMU's ``bearing_table = 1``) holds state between
samples: the speed and oil temperature last given, the rotor angle's anchor and the correction centre. A
filter built on it resets it to a just-built state, so the cached model must hold a just-built model's
operating state when the next record's filter starts, and give that record exactly the estimates a fresh
model gives, whatever ran on it before (here a record at 73 Hz with cooler oil, then one ramping from
73.6 Hz).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_model import build_operating_model
from oilwatch.monitoring.estimate import ESTIMATOR_DT_S, estimator_config, estimator_model

STORED = Path(__file__).parent / "data" / "ekf_reference_trace.npz"
STEPS = 300


def _filter(model):
    return OilFlowEKF(model, estimator_config(75.0, 1.0, 0.0))


def _estimates(ekf, record, speed, temperature):
    trace = ekf.run_batch(record, speed, temperature)
    return np.column_stack([trace.q_m3_s, trace.q_std_m3_s, trace.nis])


def _same_state(one: dict, other: dict) -> bool:
    return one.keys() == other.keys() and all(np.array_equal(one[k], other[k]) for k in one)


def test_the_follow_mode_model_is_built_once_and_a_record_s_estimates_ignore_what_ran_before():
    record = np.load(STORED)["constant/record"][:STEPS]
    t0 = load_machine().nominal_oil_temperature_c
    model = estimator_model(None, follow=True)
    assert estimator_model(None, follow=True) is model
    assert estimator_model(None) is not model  # the nominal model is its own entry
    before = _estimates(_filter(model), record, np.full(STEPS, 73.0), np.full(STEPS, t0 - 1.0))
    fresh_model = build_operating_model(load_system(reduced=True), load_machine(), ESTIMATOR_DT_S)
    just_built = fresh_model.get_operating_state()
    assert not _same_state(model.get_operating_state(), just_built)  # the record left its state behind
    ekf = _filter(model)
    assert _same_state(model.get_operating_state(), just_built)
    speed, temperature = 73.6 + 0.3 * np.linspace(0.0, 1.0, STEPS), np.full(STEPS, t0 - 1.0)
    cached = _estimates(ekf, record, speed, temperature)
    fresh = _estimates(_filter(fresh_model), record, speed, temperature)
    np.testing.assert_array_equal(cached, fresh)
    assert not np.array_equal(cached, before)
