"""The study's in-process case (plant model + EKF, no FMI) on a short record."""

from __future__ import annotations

import numpy as np

from oilwatch.study import Case, get_case_model


def test_direct_case_identifies_constant_flowrates_within_a_few_bounds():
    model = get_case_model("direct")
    case = Case(90.0, 80.0, 1.0, seed=2, duration_s=2.0, discard_s=1.0)
    result = model.run_case(case)
    bound = np.asarray(model.crlb(case))
    assert result.n_averaged == 1001
    errors = np.array([result.q1_est_ml_min - case.q1_ml_min, result.q2_est_ml_min - case.q2_ml_min])
    np.testing.assert_allclose(
        100.0 * errors / [case.q1_ml_min, case.q2_ml_min], [result.q1_err_pct, result.q2_err_pct]
    )
    # The bound covers the whole 2 s record; the estimate averages the second half after convergence.
    assert np.all(np.abs(errors) < 10.0 * bound), (errors, bound)
    assert np.all(np.abs([result.q1_err_pct, result.q2_err_pct]) < 0.5)
    assert 0.0 < result.q1_std_ml_min < 10.0 and 0.0 < result.q2_std_ml_min < 10.0
    assert model.run_case(case).q1_est_ml_min == result.q1_est_ml_min


def test_with_the_nuisances_unknown_the_filters_std_widens():
    case = Case(90.0, 80.0, 1.0, seed=2, duration_s=2.0, discard_s=1.0)
    known = get_case_model("direct").run_case(case)
    unknown = get_case_model("direct-nuisances").run_case(case)
    # the offsets make the static position uninformative: the filter's std must widen (whether it covers
    # the error is the robustness report's business, on 60 s records: 2 s is still the transient)
    for b in (1, 2):
        std_known, std_unknown = getattr(known, f"q{b}_std_ml_min"), getattr(unknown, f"q{b}_std_ml_min")
        assert std_unknown > 1.5 * std_known
