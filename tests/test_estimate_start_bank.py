"""``oilwatch estimate`` runs the product's estimator (oilwatch.estimator.factory.make_estimator): with the
viscosity factors free and no baseline for them, the start bank, exactly as the robustness runner's path runs
it.

The record is the estimator's own operating model in its steady motion at 80 % flow (as
tests/test_start_bank.py), written as a Parquet record (exact doubles) with the speed and oil temperature, so
that estimate follows the operating point. The bank's window is shortened to 1 s to keep the record short;
estimate reads it in blocks of 400 samples, so that the choice falls inside a block. The direct path is the
robustness runner's: ``make_estimator(model, config).run_batch(samples, speed, temperature)``, started as
estimate starts (the kernels warmed and reset, one missing sample one period before the first).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from oilwatch.estimator import start_bank
from oilwatch.estimator.ekf_config import ML_MIN
from oilwatch.estimator.factory import make_estimator
from oilwatch.models.machine import load_machine
from oilwatch.monitoring.estimate import EstimateOptions, EstimateRun, estimator_model
from oilwatch.records.writers import write_record
from tests.test_nuisance_start import DT, _record

STEPS = 1500


@pytest.fixture()
def short_window(monkeypatch):
    monkeypatch.setattr(start_bank, "SELECT_S", 1.0)


def _write(path, record, speed_hz, temperature_c):
    count = record.shape[0]
    columns = {"time_s": (np.arange(count) + 1) * DT}
    columns |= {f"{name}_um": record[:, i] * 1e6 for i, name in enumerate(("x1", "y1", "x2", "y2"))}
    columns |= {"speed_hz": np.full(count, speed_hz), "oil_temperature_c": np.full(count, temperature_c)}
    return write_record(path, columns)


def _estimate(path, out):
    options = EstimateOptions(viscosity_factor_prior_std=0.1, views=False, chunk_rows=400)
    run = EstimateRun(str(path), out, options)
    return run, run.run()


def _direct(config, record, speed_hz, temperature_c):
    """The robustness runner's path, started as estimate starts (module docstring)."""
    bank = make_estimator(estimator_model(None, follow=True), config)
    missing = np.full(4, np.nan)
    for sample in (np.zeros(4), np.zeros(4), missing):
        bank.step(sample, speed_hz, temperature_c)
    bank.reset()
    bank.step(missing, speed_hz, temperature_c)
    count = record.shape[0]
    samples = (record * 1e6) * 1e-6  # the record's um, read back in m as estimate conditions them
    trace = bank.run_batch(samples, np.full(count, speed_hz), np.full(count, temperature_c))
    return bank, trace


@pytest.mark.slow  # the estimate CLI and the bank run fast in test_fast_tier.py and test_start_bank.py
def test_estimate_with_free_factors_runs_the_start_bank_bit_for_bit(tmp_path, short_window):
    machine = load_machine()
    speed, temperature = machine.nominal_speed_hz, machine.nominal_oil_temperature_c
    record = _record(estimator_model(None, follow=True), STEPS, 0.8)
    path = _write(tmp_path / "free.parquet", record, speed, temperature)
    run, summary = _estimate(path, tmp_path / "out")
    bank, trace = _direct(run.filter.config, record, speed, temperature)
    assert isinstance(run.filter, start_bank.StartBank) and run.filter.chosen is not None
    ours, theirs = run.filter.get_state(), bank.get_state()
    assert ours.keys() == theirs.keys()
    for key in ours:  # the whole state after the record: every sample's update, the NIS sums, the choice
        np.testing.assert_array_equal(ours[key], theirs[key], err_msg=key)
    written = json.loads((tmp_path / "out" / "summary.json").read_text())["estimator"]["start_bank"]
    assert (
        written["chosen_start_fraction"]
        == bank.chosen_fraction
        == summary["estimator"]["start_bank"]["chosen_start_fraction"]
    )
    columns = np.genfromtxt(tmp_path / "out" / "estimates.csv", delimiter=",", names=True)
    for b in (1, 2):
        np.testing.assert_allclose(columns[f"q{b}_est_ml_min"], trace.q_m3_s[:, b - 1] / ML_MIN, atol=0.006)

    # a record that ends inside the window: the leading start's estimates, no choice, said so
    short = _write(tmp_path / "short.parquet", record[:500], speed, temperature)
    run, summary = _estimate(short, tmp_path / "short")
    assert run.filter.chosen is None and summary["estimator"]["start_bank"]["chosen_start_fraction"] is None
    assert "ended inside the selection window" in summary["estimator"]["start_bank"]["note"]
