"""The start bank (estimator/start_bank.py): where it applies, and that it continues the chosen filter
exactly.

The record is the estimator's own operating model in its steady motion at nominal flow (as
tests/test_nuisance_start.py); the bank's filters estimate the flowrates beside offsets, unbalance and free
viscosity factors. Before the choice the bank reports the leading start's filter (the nominal one's until
another's accumulated NIS is LEAD_MARGIN lower), after it the filter of the start with the smallest
accumulated NIS, bit for bit as that filter run alone.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.factory import make_estimator
from oilwatch.estimator.offset_baseline import OffsetBaseline
from oilwatch.estimator.reports import EstimateTrace
from oilwatch.estimator.start_bank import LEAD_MARGIN, PRUNE_MARGIN, START_FRACTIONS, StartBank
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.operating_model import build_operating_model
from tests.test_nuisance_start import DT, _record, free_config


@pytest.fixture(scope="module")
def model():
    machine = load_machine()
    return build_operating_model(build_system(machine, reduced=True), machine, DT)


def test_the_bank_applies_only_to_nuisances_no_baseline_primed():
    config = free_config()
    assert StartBank.applies(config)
    known_film = dataclasses.replace(config, viscosity_factor_prior_std=0.0)
    assert StartBank.applies(known_film)  # the offsets and the unbalance still free, no baseline
    assert StartBank.applies(dataclasses.replace(known_film, unbalance_prior_std=0.0))
    assert StartBank.applies(dataclasses.replace(known_film, offset_prior_std_m=0.0))
    assert not StartBank.applies(
        dataclasses.replace(known_film, offset_prior_std_m=0.0, unbalance_prior_std=0.0)
    )
    assert not StartBank.applies(dataclasses.replace(config, flowrate_process_std_m3_s=0.0))
    assert not StartBank.applies(dataclasses.replace(config, nuisance_shadow=False))
    offsets = dict(offsets_m=(0.0,) * 4, std_m=(1e-6,) * 4)
    primed = OffsetBaseline(**offsets, viscosity_factor=(1.0, 1.0), viscosity_factor_std=(0.01, 0.01))
    assert not StartBank.applies(dataclasses.replace(config, offset_baseline=primed))
    assert StartBank.applies(dataclasses.replace(config, offset_baseline=OffsetBaseline(**offsets)))
    assert not StartBank.applies(dataclasses.replace(known_film, offset_baseline=OffsetBaseline(**offsets)))


def test_the_bank_reports_the_nominal_start_then_continues_the_least_nis_start_exactly(model):
    config = free_config()
    steps, select_s = 1400, 1.0
    record = _record(model, steps, 1.0)
    bank = StartBank(model, config, select_s=select_s)
    assert 0 < bank.settling_steps < round(select_s / DT)
    q_bank = np.array([bank.step(record[k]).q_m3_s for k in range(steps)])
    assert bank.chosen == START_FRACTIONS.index(1.0), bank.nis
    running = bank.nis[np.isfinite(bank.nis)]
    assert bank.nis[bank.chosen] == bank.nis.min() and (np.diff(np.sort(running)) > 0).all()
    model.reset_operating_state()
    alone = OilFlowEKF(model, config).run(record).q_m3_s
    np.testing.assert_array_equal(q_bank, alone)


def test_a_start_below_nominal_leads_on_a_low_flow_record_and_continues_as_that_filter_alone(model):
    """The other start leads from the sample where its NIS sum (each filter's own, run alone) is LEAD_MARGIN
    below the nominal start's, before the choice; the reports are the leader's filter's, bit for bit."""
    config = free_config()
    steps, select_s, fractions = 1400, 1.0, (1.0, 0.8)
    record = _record(model, steps, 0.8)
    bank = StartBank(model, config, fractions=fractions, select_s=select_s)
    q_bank, leaders = [], []
    for k in range(steps):
        q_bank.append(bank.step(record[k]).q_m3_s)
        leaders.append(bank.leader)
    q_bank = np.array(q_bank)
    assert bank.chosen == 1, bank.nis
    model.reset_operating_state()
    nominal = OilFlowEKF(model, config).run(record)
    model.reset_operating_state()
    low = dataclasses.replace(config, q_initial_m3_s=tuple(0.8 * model.nominal_flowrates_m3_s))
    alone = OilFlowEKF(model, low).run(record)
    counted = slice(bank.settling_steps + 1, None)
    excess = np.cumsum(nominal.nis[counted]) - np.cumsum(alone.nis[counted])
    switch = bank.settling_steps + 1 + int(np.argmax(excess > LEAD_MARGIN))
    choice = round(select_s / DT) - 1  # the sample that completes the window reports the chosen filter
    assert bank.settling_steps < switch < choice and excess.max() > LEAD_MARGIN
    assert leaders[:switch] == [0] * switch and leaders[switch:] == [1] * (steps - switch)
    np.testing.assert_array_equal(q_bank[:switch], nominal.q_m3_s[:switch])
    np.testing.assert_array_equal(q_bank[switch:], alone.q_m3_s[switch:])


def test_a_start_that_trails_the_least_nis_by_the_margin_stops_and_never_leads_or_wins(model):
    """Each start's NIS sum from its filter run alone: a start stops at the first sample where its sum
    exceeds the least running one by PRUNE_MARGIN, and the bank's choice is the least sum of all, as
    without stopping."""
    config = free_config()
    steps, select_s = 1400, 1.0
    record = _record(model, steps, 0.8)
    bank = StartBank(model, config, select_s=select_s)
    stopped = []
    for k in range(steps):
        bank.step(record[k])
        stopped.append(np.isinf(bank.nis))
    stopped = np.array(stopped)
    q0 = config.for_model(model).q_initial_pair()
    alone = []
    for fraction in START_FRACTIONS:
        model.reset_operating_state()
        start = dataclasses.replace(config, q_initial_m3_s=tuple(fraction * np.asarray(q0)))
        alone.append(OilFlowEKF(model, start).run(record).nis)
    counted = slice(bank.settling_steps + 1, round(select_s / DT))
    sums = np.cumsum(np.array(alone)[:, counted], axis=1)
    expected = np.zeros(len(START_FRACTIONS), dtype=bool)
    for column in range(sums.shape[1]):
        running = np.where(expected, np.inf, sums[:, column])
        expected |= running - running.min() > PRUNE_MARGIN
        step = bank.settling_steps + 1 + column
        np.testing.assert_array_equal(stopped[step], expected, err_msg=f"sample {step}")
    assert expected.any() and not expected.all()  # some starts stop, and before the choice
    assert bank.chosen == int(np.argmin(sums[:, -1])) and not stopped[-1][bank.chosen]


FIELDS = ("q_m3_s", "q_std_m3_s", "nis", "starved", "model_consistent", "viscosity_factor", "offset_m")


def _stepped(bank, record) -> dict:
    reports, leaders = [], []
    for sample in record:
        reports.append(bank.step(sample))
        leaders.append(bank.leader)
    stepped = {name: np.array([getattr(report, name) for report in reports]) for name in FIELDS[:5]}
    return stepped | {"leader": np.array(leaders)}


@pytest.mark.slow  # a long record; the module's other tests keep it in the fast tier
def test_the_bank_s_record_entries_equal_its_steps_across_the_choice(model):
    """``run_batch`` in blocks that split the window anywhere (the choice inside a block) and ``run`` give
    what as many steps give, bit for bit, and choose the same start from the same NIS sums."""
    config = free_config()
    record = _record(model, 1400, 0.8)
    stepped = StartBank(model, config, select_s=1.0)
    expected = _stepped(stepped, record)
    assert stepped.chosen is not None
    assert len(set(expected["leader"][:999])) > 1  # the leading start changes inside a block
    assert np.isinf(stepped.nis).any()  # and some starts stop inside one
    batched = StartBank(model, config, select_s=1.0)
    out = EstimateTrace.empty(400)  # reused by every block, as oilwatch estimate does
    rows = []
    for start, stop in ((0, 1), (1, 351), (351, 751), (751, 1151), (1151, 1400)):
        batched.run_batch(record[start:stop], out=out)
        rows.append({name: getattr(out, name)[: stop - start].copy() for name in FIELDS})
    batch = {name: np.concatenate([r[name] for r in rows]) for name in FIELDS}
    whole = StartBank(model, config, select_s=1.0).run(record)
    for name in FIELDS[:5]:
        np.testing.assert_array_equal(batch[name], expected[name], err_msg=name)
        np.testing.assert_array_equal(getattr(whole, name), expected[name], err_msg=name)
    assert batched.chosen == stepped.chosen and np.array_equal(batched.nis, stepped.nis)
    assert batched.leader == stepped.leader
    np.testing.assert_array_equal(batched.viscosity_factor, stepped.viscosity_factor)


def test_the_bank_s_state_restores_bit_identically_and_reset_starts_over(model):
    """A state saved inside the window or after the choice continues bit for bit; ``reset`` runs the record
    again as a new bank (the FMU's get/setFMUstate and fmi2Reset)."""
    config = free_config()
    record = _record(model, 1400, 0.8)
    bank = StartBank(model, config, select_s=1.0)
    first = _stepped(bank, record[:600])["q_m3_s"]
    inside = bank.get_state()
    running = np.flatnonzero(np.isfinite(bank.nis))
    assert {key.partition("_")[0] for key in inside} == {"bank"} | {f"start{k}" for k in running}
    on = _stepped(bank, record[600:1200])
    after = bank.get_state()
    assert bank.chosen is not None and {key.partition("_")[0] for key in after} == {
        "bank",
        f"start{bank.chosen}",
    }
    tail = _stepped(bank, record[1200:])
    bank.set_state(inside)
    assert bank.chosen is None
    again = _stepped(bank, record[600:1200])
    bank.set_state(after)
    tail_again = _stepped(bank, record[1200:])
    for name in FIELDS[:5]:
        np.testing.assert_array_equal(again[name], on[name], err_msg=name)
        np.testing.assert_array_equal(tail_again[name], tail[name], err_msg=name)
    bank.reset()
    assert bank.chosen is None and not bank.nis.any() and bank.step_count == 0
    np.testing.assert_array_equal(_stepped(bank, record[:600])["q_m3_s"], first)


def test_the_factory_builds_the_bank_where_it_applies_and_one_filter_elsewhere(model):
    assert isinstance(make_estimator(model, free_config()), StartBank)
    known = dataclasses.replace(
        free_config(), viscosity_factor_prior_std=0.0, offset_prior_std_m=0.0, unbalance_prior_std=0.0
    )
    assert type(make_estimator(model, known)) is OilFlowEKF
