"""The start bank (estimator/start_bank.py): where it applies, and that it continues the chosen filter
exactly.

The record is the estimator's own operating model in its steady motion at nominal flow (as
tests/test_nuisance_start.py); the bank's filters estimate the flowrates beside offsets, unbalance and free
viscosity factors. Before the choice the bank reports the nominal start's filter, after it the filter of
the start with the smallest accumulated NIS, bit for bit as that filter run alone; on this record that is
the nominal start, the truth.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from estimator.config import OffsetBaseline
from estimator.ekf import OilFlowEKF
from estimator.start_bank import START_FRACTIONS, StartBank
from models.machine import load_machine
from models.system.factory import build_system
from models.system.operating_model import build_operating_model
from tests.test_nuisance_start import DT, _record, free_config


@pytest.fixture(scope="module")
def model():
    machine = load_machine()
    return build_operating_model(build_system(machine, reduced=True), machine, DT)


def test_the_bank_applies_only_to_free_factors_without_a_baseline():
    config = free_config()
    assert StartBank.applies(config)
    assert not StartBank.applies(dataclasses.replace(config, viscosity_factor_prior_std=0.0))
    assert not StartBank.applies(dataclasses.replace(config, flowrate_process_std_m3_s=0.0))
    assert not StartBank.applies(dataclasses.replace(config, nuisance_shadow=False))
    offsets = dict(offsets_m=(0.0,) * 4, std_m=(1e-6,) * 4)
    primed = OffsetBaseline(**offsets, viscosity_factor=(1.0, 1.0), viscosity_factor_std=(0.01, 0.01))
    assert not StartBank.applies(dataclasses.replace(config, offset_baseline=primed))
    assert StartBank.applies(dataclasses.replace(config, offset_baseline=OffsetBaseline(**offsets)))


def test_the_bank_reports_the_nominal_start_then_continues_the_least_nis_start_exactly(model):
    config = free_config()
    steps, select_s = 1400, 1.0
    record = _record(model, steps, 1.0)
    bank = StartBank(model, config, select_s=select_s)
    assert 0 < bank._settling < round(select_s / DT)
    q_bank = np.array([bank.step(record[k]).q_m3_s for k in range(steps)])
    assert bank.chosen == START_FRACTIONS.index(1.0), bank.nis
    assert bank.nis[bank.chosen] == bank.nis.min() and (np.diff(np.sort(bank.nis)) > 0).all()
    model.reset_operating_state()
    alone = OilFlowEKF(model, config).run(record).q_m3_s
    np.testing.assert_array_equal(q_bank, alone)


def test_a_start_below_nominal_wins_on_a_low_flow_record_and_continues_as_that_filter_alone(model):
    config = free_config()
    steps, select_s, fractions = 1400, 1.0, (1.0, 0.8)
    record = _record(model, steps, 0.8)
    bank = StartBank(model, config, fractions=fractions, select_s=select_s)
    q_bank = np.array([bank.step(record[k]).q_m3_s for k in range(steps)])
    assert bank.chosen == 1, bank.nis
    choice = round(select_s / DT) - 1  # the sample that completes the window reports the chosen filter
    model.reset_operating_state()
    nominal = OilFlowEKF(model, config).run(record[:choice]).q_m3_s
    np.testing.assert_array_equal(q_bank[:choice], nominal)  # the nominal start's reports until the choice
    model.reset_operating_state()
    low = dataclasses.replace(config, q_initial_m3_s=0.8 * model.nominal_flowrate_m3_s)
    np.testing.assert_array_equal(q_bank[choice:], OilFlowEKF(model, low).run(record).q_m3_s[choice:])
