"""Each robustness row's bound is the bound of its own configuration (oilwatch/robustness/bounds.py)."""

from __future__ import annotations

import dataclasses

import numpy as np

from oilwatch.models.machine import load_machine
from oilwatch.models.system.trajectory_bound import trajectory_bound_pct, trajectory_information
from oilwatch.robustness import case_by_name
from oilwatch.robustness.bounds import CaseBounds, configuration_label, free_groups
from oilwatch.robustness.runner import REPORT_SETTINGS

SETTINGS = REPORT_SETTINGS


def test_the_free_nuisances_baseline_drift_and_ramp_of_each_case_are_its_estimators():
    assert free_groups(case_by_name("temperature-ramp"), SETTINGS) == ("offsets", "unbalance", "viscosity")
    assert free_groups(case_by_name("temperature-ramp-known-film"), SETTINGS) == ("offsets", "unbalance")
    assert free_groups(case_by_name("none"), {**SETTINGS, "offset_prior_um": 0.0}) == ("unbalance",)
    assert configuration_label(case_by_name("offsets-drift"), SETTINGS) == (
        "offsets+unbalance, baseline, drift 3 um"
    )
    assert "along the ramp" in configuration_label(case_by_name("speed-ramp"), SETTINGS)


def test_a_ramp_informs_the_factors_and_a_baseline_removes_most_of_their_cost():
    bounds = CaseBounds(load_machine(), SETTINGS, 1e-3)
    ramp = case_by_name("temperature-ramp")
    still = dataclasses.replace(ramp, name="constant-free-factors", temperature_rise_c=0.0)
    point = (80.0, 90.0)
    moving, constant = bounds.bound_pct(ramp, point), bounds.bound_pct(still, point)
    primed = bounds.bound_pct(case_by_name("temperature-ramp-baseline"), point)
    assert np.all(primed < moving) and np.all(moving < constant)
    # the segments are short enough: halving them moves the ramp's bound by under 1 %
    maps, h = bounds.operating_maps()
    q = np.array(point) / 100.0 * load_machine().lubrication.nominal_flowrates_m3_s
    groups = ("offsets", "unbalance", "viscosity")
    coarse, fine = (
        trajectory_bound_pct(trajectory_information(maps, h, 1e-3, q, bounds.segments(ramp, n), 1e-6), groups)
        for n in (12, 24)
    )
    np.testing.assert_allclose(coarse, fine, rtol=0.01)
