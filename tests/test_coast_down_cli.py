"""``oilwatch coast-down`` and ``oilwatch baseline --coast-down-record``: each bearing's clearance measured
from a coast-down record, stored in the baseline, taken by the estimator's model."""

from __future__ import annotations

import json

import numpy as np
import pytest

from oilwatch.cli import main
from oilwatch.estimator.baseline import load_clearance_factors
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import locus_table_path
from oilwatch.monitoring.estimator_setup import estimator_model


@pytest.fixture(scope="module")
def coast_down(tmp_path_factory):
    """A 20 s coast-down of a plant whose bearings are 8 % tighter, probe offsets of tens of um."""
    path = tmp_path_factory.mktemp("coast_down") / "coast_down.csv"
    arguments = ["coast-down", "--duration-s", "20", "--clearance-factor", "0.92"]
    arguments += ["--offset-um", "12", "-25", "-8", "19", "--out", str(path)]
    assert main(arguments) == 0
    return path


@pytest.mark.slow
def test_the_clearance_a_coast_down_measures_is_the_plants_and_the_estimators_model_takes_it(
    coast_down, tmp_path, capsys
):
    out = tmp_path / "baseline.json"
    assert main(["baseline", "--coast-down-record", str(coast_down), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "bearing 1 clearance" in printed and "clearances only" in printed
    factors = load_clearance_factors(out)
    document = json.loads(out.read_text())
    std = np.array(document["clearance_factor_std"])
    assert np.abs(np.array(factors) / 0.92 - 1.0).max() < 0.005
    # the std carries the probes' 5 % scale-factor tolerance (a stretched centreline reads as clearance)
    assert (std > 0.01).all() and (std < 0.03).all()
    assert np.array(document["coast_down"]["residual_rms_um"]).max() < 0.2
    model = estimator_model(None, follow=True, clearance_factors=factors)
    clearance = load_machine(None).bearing.clearance_m
    tables = model.reference.system.tables
    for table, factor in zip(tables, factors, strict=True):
        assert table.metadata["bearing"]["clearance_m"] == pytest.approx(factor * clearance, rel=1e-12)


def test_the_bundled_turbines_locus_file_is_found(tmp_path):
    """The shipped loci (``oilwatch bearing-locus``) serve the bundled turbine: nothing to solve."""
    path = locus_table_path(load_machine(None))
    assert path.exists() and path.parent.name == "tables"


def test_a_record_without_a_speed_is_refused_in_one_line(tmp_path, capsys):
    record = tmp_path / "no_speed.csv"
    times = 1e-3 * np.arange(2000)
    table = np.column_stack([times, np.random.default_rng(1).normal(10.0, 1.0, (times.size, 4))])
    np.savetxt(record, table, delimiter=",", header="time_s,x1_um,y1_um,x2_um,y2_um", comments="")
    code = main(["baseline", "--coast-down-record", str(record), "--out", str(tmp_path / "b.json")])
    error = capsys.readouterr().err
    assert code == 2 and "needs the speed" in error and error.count("\n") == 1


def test_a_record_at_one_speed_is_not_a_coast_down(tmp_path, capsys):
    record = tmp_path / "steady.csv"
    times = 1e-3 * np.arange(3000)
    readings = np.random.default_rng(2).normal(10.0, 1.0, (times.size, 4))
    table = np.column_stack([times, readings, np.full(times.size, 75.0)])
    np.savetxt(record, table, delimiter=",", header="time_s,x1_um,y1_um,x2_um,y2_um,speed_hz", comments="")
    code = main(["baseline", "--coast-down-record", str(record), "--out", str(tmp_path / "b.json")])
    error = capsys.readouterr().err
    assert code == 2 and "at least 6 speeds" in error and error.count("\n") == 1
