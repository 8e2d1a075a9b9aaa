"""The study's parts without Dask: grid, record reduction, storage, summary statistics, CLI input errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from oilwatch.cli import main
from oilwatch.models.validation import InputError
from oilwatch.study import Case, SyntheticCase, grid_percents, make_cases, reduce_record
from oilwatch.study.cases import CaseFailure
from oilwatch.study.storage import COLUMNS, CaseStore, check_manifest
from oilwatch.study.summary import noise_level_summary, summarize


def test_paper_grid_has_676_cases_per_noise_level_with_unique_stable_ids():
    cases = make_cases([1.0, 2.0], grid_step_pct=1.0)
    assert len(cases) == 2 * 26 * 26
    ids = [case.case_id for case in cases]
    assert len(set(ids)) == len(ids)
    assert Case(98.0, 85.0, 1.0).case_id == "n1_q1-98_q2-85_s0"
    assert grid_percents(1.0)[[0, -1]].tolist() == [100.0, 75.0]
    assert grid_percents(12.5).tolist() == [100.0, 87.5, 75.0]
    seeds = {case.rng_seed for case in cases}
    assert len(seeds) == len(cases) and Case(98.0, 85.0, 1.0).rng_seed == Case(98.0, 85.0, 1.0).rng_seed
    assert math.isclose(Case(75.0, 100.0, 1.0).q1_ml_min, 447.225)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"noise_um": [-1.0]}, "--noise-um"),
        ({"noise_um": [1.0, 1.0]}, "--noise-um"),
        ({"noise_um": [1.0], "grid_step_pct": 3.0}, "--grid-step-pct"),
        ({"noise_um": [1.0], "grid_step_pct": 0.0}, "--grid-step-pct"),
        ({"noise_um": [1.0], "n_seeds": 0}, "--seeds"),
        ({"noise_um": [1.0], "duration_s": 4.0}, "--discard-s"),
    ],
)
def test_bad_grid_input_names_the_argument(kwargs, name):
    with pytest.raises(InputError, match=name):
        make_cases(**kwargs)


def test_reduce_record_averages_after_the_discarded_part():
    case = Case(100.0, 80.0, 1.0, duration_s=2.0, discard_s=1.0)
    times = 1e-3 * np.arange(1, 2001)
    estimates = np.where(times[:, None] < 1.0, 900.0, [600.0, 480.0]) + np.where(
        np.arange(2000)[:, None] % 2 == 0, 1.0, -1.0
    )
    stds = np.full((2000, 2), 3.0)
    result = reduce_record(case, times, estimates, stds, wall_s=0.5)
    assert result.n_averaged == 1001
    # 1001 samples from t = 1.000 s on: alternating +1/-1 starting at index 999 (odd, -1) -> mean -1/1001.
    np.testing.assert_allclose(
        [result.q1_est_ml_min, result.q2_est_ml_min], np.array([600.0, 480.0]) - 1 / 1001
    )
    np.testing.assert_allclose(result.q1_err_pct, 100.0 * (600.0 - 1 / 1001 - 596.3) / 596.3)
    np.testing.assert_allclose(result.q2_err_pct, 100.0 * (480.0 - 1 / 1001 - 477.04) / 477.04)
    assert result.q1_std_ml_min == 3.0
    bad = estimates.copy()
    bad[-1, 0] = np.nan
    with pytest.raises(CaseFailure, match="not finite"):
        reduce_record(case, times, bad, stds, wall_s=0.5)


def test_synthetic_case_is_deterministic():
    case = Case(90.0, 80.0, 2.0, seed=3)
    assert SyntheticCase()(case).q1_est_ml_min == SyntheticCase()(case).q1_est_ml_min
    assert SyntheticCase()(case).q1_est_ml_min != SyntheticCase()(Case(90.0, 80.0, 2.0, seed=4)).q1_est_ml_min


def _row(case: Case, err1: float, err2: float, crlb=(float("nan"), float("nan"))) -> dict:
    truth = np.array([case.q1_ml_min, case.q2_ml_min])
    estimate = truth * (1.0 + np.array([err1, err2]) / 100.0)
    return {
        "case_id": case.case_id,
        "noise_um": case.noise_um,
        "q1_pct": case.q1_pct,
        "q2_pct": case.q2_pct,
        "seed": case.seed,
        "q1_true_ml_min": truth[0],
        "q2_true_ml_min": truth[1],
        "q1_est_ml_min": estimate[0],
        "q2_est_ml_min": estimate[1],
        "q1_err_pct": err1,
        "q2_err_pct": err2,
        "q1_std_ml_min": 1.0,
        "q2_std_ml_min": 1.0,
        "q1_spread_ml_min": 1.0,
        "q2_spread_ml_min": 1.0,
        "n_averaged": 5000,
        "wall_s": 1.0,
        "worker": "w",
        "crlb_q1_ml_min": crlb[0],
        "crlb_q2_ml_min": crlb[1],
    }


def test_summary_statistics_match_a_hand_computation():
    cases = [Case(100.0, 100.0, 1.0), Case(100.0, 75.0, 1.0), Case(75.0, 100.0, 1.0)]
    errors = [(1.0, -2.0), (-0.5, 3.0), (0.25, 0.0)]
    rows = [_row(case, *err) for case, err in zip(cases, errors, strict=True)]
    level = noise_level_summary(rows, 1.0, n_expected=4)
    # |errors|: 1, 2, 0.5, 3, 0.25, 0 -> sum 6.75, mean 1.125; sample variance
    # ((-0.125)^2 + 0.875^2 + (-0.625)^2 + 1.875^2 + (-0.875)^2 + (-1.125)^2) / 5 = 6.71875 / 5.
    assert level["mean_err_pct"] == pytest.approx(1.125)
    assert level["std_err_pct"] == pytest.approx(math.sqrt(6.71875 / 5.0))
    assert level["max_err_pct"] == 3.0
    assert level["worst_case"] == {
        "case_id": "n1_q1-100_q2-75_s0",
        "q1_pct": 100.0,
        "q2_pct": 75.0,
        "seed": 0,
        "bearing": 2,
        "err_pct": 3.0,
    }
    assert level["mean_err_pct_b1"] == pytest.approx(1.75 / 3) and level["mean_err_pct_b2"] == pytest.approx(
        5 / 3
    )
    assert level["n_cases"] == 3 and not level["complete"]
    assert level["paper"]["mean_err_pct"] == 1.82 and level["paper"]["max_err_pct"] == 5.06
    assert level["target"]["pass_mean"] is False and level["target"]["pass_max"] is False
    assert level["mean_crlb_ratio"] is None


def test_crlb_ratio_and_targets_by_hand():
    cases = [Case(100.0, 100.0, 2.0), Case(80.0, 80.0, 2.0)]
    rows = [_row(cases[0], 0.5, -1.0, crlb=(1.0, 2.0)), _row(cases[1], 1.5, 0.5, crlb=(2.0, 1.0))]
    level = noise_level_summary(rows, 2.0, n_expected=2)
    z1 = [0.005 * 596.3 / 1.0, 0.015 * 477.04 / 2.0]
    z2 = [-0.01 * 596.3 / 2.0, 0.005 * 477.04 / 1.0]
    ratio1, ratio2 = math.sqrt((z1[0] ** 2 + z1[1] ** 2) / 2), math.sqrt((z2[0] ** 2 + z2[1] ** 2) / 2)
    assert level["crlb_ratio_b1"] == pytest.approx(ratio1)
    assert level["mean_crlb_ratio"] == pytest.approx((ratio1 + ratio2) / 2)
    assert level["target"] == {
        "mean_err_pct": 1.8,
        "max_err_pct": 5.0,
        "pass_mean": True,
        "pass_max": True,
        "pass": True,
    }
    assert level["paper"]["mean_err_pct"] == 3.54


def test_summary_ignores_rows_of_other_grids_and_lists_failures():
    cases = make_cases([1.0], grid_step_pct=25.0)
    rows = {case.case_id: _row(case, 1.0, 1.0) for case in cases}
    stray = Case(90.0, 90.0, 1.0)
    rows[stray.case_id] = _row(stray, 50.0, 50.0)
    summary = summarize(rows, cases, [{"case_id": "x", "error": "boom"}], {"case_model": "synthetic"})
    assert summary["noise_levels"][0]["max_err_pct"] == 1.0 and summary["noise_levels"][0]["n_cases"] == 4
    assert summary["failed_cases"] == [{"case_id": "x", "error": "boom"}] and summary["complete"]
    json.dumps(summary)


def test_torn_last_line_is_dropped_and_cut_off(tmp_path):
    store = CaseStore(tmp_path / "cases.csv")
    cases = make_cases([1.0], grid_step_pct=25.0)
    for case in cases[:3]:
        store.append(SyntheticCase()(case).as_row())
    store.close()
    with open(store.path, "a") as handle:
        handle.write(cases[3].case_id + ",1.0,75")
    rows = CaseStore(store.path).load()
    assert sorted(rows) == sorted(case.case_id for case in cases[:3])
    assert store.path.read_text().endswith("\n")
    again = CaseStore(store.path)
    again.append(SyntheticCase()(cases[3]).as_row())
    again.close()
    loaded = CaseStore(store.path).load()
    assert len(loaded) == 4
    # Values read back exactly (floats are written with repr); the synthetic case has no bound (NaN).
    first, expected = loaded[cases[0].case_id], SyntheticCase()(cases[0]).as_row()
    for name in COLUMNS:
        if name.startswith("crlb"):
            assert math.isnan(first[name]) and math.isnan(expected[name])
        elif name != "wall_s":
            assert first[name] == expected[name], name


def test_store_refuses_a_foreign_csv_and_manifest_guards_settings(tmp_path):
    (tmp_path / "cases.csv").write_text("a,b\n1,2\n")
    with pytest.raises(InputError, match="--out"):
        CaseStore(tmp_path / "cases.csv").load()
    settings = {"case_model": "synthetic", "duration_s": 10.0, "discard_s": 5.0}
    check_manifest(tmp_path, settings)
    with pytest.raises(InputError, match="--discard-s"):
        check_manifest(tmp_path, settings | {"discard_s": 4.0})
    with pytest.raises(InputError, match="--case"):
        check_manifest(tmp_path, settings | {"case_model": "cosim"})


@pytest.mark.parametrize(
    ("argv", "name"),
    [
        (["--noise-um", "-1"], "--noise-um"),
        (["--grid-step-pct", "7"], "--grid-step-pct"),
        (["--scheduler", "localhost"], "--scheduler"),
        (["--workers", "0"], "--workers"),
        (["--case", "nonsense"], "--case"),
    ],
)
def test_cli_bad_input_is_a_one_line_error(argv, name, tmp_path, capsys):
    code = main(["study", "--case", "synthetic", "--out", str(tmp_path / "out"), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2 and name in err and len(err.splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_bias_and_the_filters_confidence_by_hand():
    # std 1 ml/min: 0.168 % of 596.3 and 0.224 % of 447.2; errors (0.3, -0.1) % and (0.5, 0.2) %
    cases = [Case(100.0, 100.0, 1.0), Case(75.0, 75.0, 1.0)]
    rows = [_row(cases[0], 0.3, -0.1), _row(cases[1], 0.5, 0.2)]
    level = noise_level_summary(rows, 1.0, n_expected=2)
    assert level["bias_pct_b1"] == pytest.approx(0.4) and level["bias_pct_b2"] == pytest.approx(0.05)
    std_pct = [100.0 / cases[0].q1_ml_min, 100.0 / cases[1].q1_ml_min]
    assert level["mean_std_pct"] == pytest.approx(sum(std_pct) / 2)
    # within +-2 std: 0.3 <= 0.335 yes, 0.1 yes, 0.5 > 0.447 no, 0.2 yes
    assert level["within_2std_fraction"] == pytest.approx(0.75)
