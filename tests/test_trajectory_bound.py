"""The Cramer-Rao bound along an operating trajectory on the estimator's operating maps
(oilwatch.models.system.trajectory_bound: map_sensitivity, trajectory_information, nuisance_prior,
trajectory_bound_pct).

Checked against the full model's harmonic bound (oilwatch.models.system.nuisance_bound, an independent build:
the full-order rotor on the flowrate tables at 75 Hz), the linear nuisances' exact columns, the segments' sum,
and the behaviour information must have (more unknowns never help, a baseline only helps, a moving
operating point adds information).
"""

from __future__ import annotations

import numpy as np
import pytest

from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.nuisance_bound import nuisance_bound
from oilwatch.models.system.operating_model import build_operating_model
from oilwatch.models.system.trajectory_bound import (
    OperatingSegment,
    map_sensitivity,
    nuisance_prior,
    trajectory_bound_pct,
    trajectory_information,
)
from oilwatch.models.validation import InputError

DT = 1e-3
SIGMA = 1e-6


@pytest.fixture(scope="module")
def setup():
    machine = load_machine()
    model = build_operating_model(build_system(machine, reduced=True), machine, DT)
    q = np.array([0.8, 0.9]) * machine.lubrication.nominal_flowrates_m3_s
    mu = machine.oil.dynamic_viscosity_pa_s(machine.nominal_oil_temperature_c)
    return machine, model.maps, np.asarray(model.output_matrix), q, mu


def test_offsets_and_unbalance_bound_agrees_with_the_full_model(setup):
    machine, maps, h, q, mu = setup
    info = trajectory_information(maps, h, DT, q, [OperatingSegment(75.0, mu, 60.0)], SIGMA)
    own = trajectory_bound_pct(info, ("offsets", "unbalance"))
    full = nuisance_bound(build_system(machine, reduced=False), q, SIGMA, 60_000, ("offsets", "unbalance"))
    np.testing.assert_allclose(own, full.std_pct, rtol=0.1)


def test_segments_add_and_the_linear_columns_are_exact(setup):
    _, maps, h, q, mu = setup
    whole = trajectory_information(maps, h, DT, q, [OperatingSegment(75.0, mu, 60.0)], SIGMA)
    parts = trajectory_information(maps, h, DT, q, [OperatingSegment(75.0, mu, 5.0)] * 12, SIGMA)
    np.testing.assert_allclose(parts, whole, rtol=1e-9, atol=1e-12 * np.abs(whole).max())
    segment = OperatingSegment(75.0, mu, 1.0)
    one = map_sensitivity(maps, h, DT, q, segment)
    turned = map_sensitivity(maps, h, DT, q, segment, unbalance=2j)
    # the orbit doubles and turns with the unbalance; the unbalance columns (per unit) do not change
    np.testing.assert_allclose(turned[:, 4:], one[:, 4:], atol=1e-15)
    np.testing.assert_allclose(turned[4:8, 0] - 1j * turned[8:, 0], 2j * (one[4:8, 0] - 1j * one[8:, 0]))
    np.testing.assert_allclose(one[:4, 6:], 1e-6 * np.eye(4))
    with pytest.raises(InputError, match="unbalance"):
        map_sensitivity(maps, h, DT, q, segment, unbalance=0.0)


def test_unknowns_never_help_a_baseline_does_and_a_ramp_informs(setup):
    machine, maps, h, q, mu = setup
    constant = [OperatingSegment(75.0, mu, 5.0)] * 12
    t0 = machine.nominal_oil_temperature_c
    ramp = [
        OperatingSegment(75.0, machine.oil.dynamic_viscosity_pa_s(t0 + 10.0 * (i + 0.5) / 12), 5.0)
        for i in range(12)
    ]
    info = trajectory_information(maps, h, DT, q, constant, SIGMA)
    everything = ("offsets", "unbalance", "viscosity")
    some = trajectory_bound_pct(info, ("offsets", "unbalance"))
    free = trajectory_bound_pct(info, everything)
    assert np.all(free > some) and np.all(some > trajectory_bound_pct(info, ()))
    nominal = np.array(machine.lubrication.nominal_flowrates_m3_s)
    baseline = trajectory_information(maps, h, DT, nominal, [OperatingSegment(75.0, mu, 60.0)], SIGMA)
    primed = trajectory_bound_pct(info, everything, nuisance_prior(baseline, everything))
    drifted = trajectory_bound_pct(info, everything, nuisance_prior(baseline, everything, {"offset": 3.0}))
    assert np.all(primed < drifted) and np.all(drifted < free)
    moving = trajectory_bound_pct(trajectory_information(maps, h, DT, q, ramp, SIGMA), everything)
    assert np.all(moving < free)
    with pytest.raises(InputError, match="nuisance groups"):
        trajectory_bound_pct(info, ("temperature",))


def test_tracking_bound_without_walks_is_the_bound_with_the_prior_and_walks_only_widen_it(setup):
    from oilwatch.models.system.trajectory_bound import tracking_bound_pct

    _, maps, h, q, mu = setup
    segments = [OperatingSegment(75.0, mu * (1.0 + 0.02 * i), 5.0) for i in range(12)]
    rates = [(trajectory_information(maps, h, DT, q, [s], SIGMA) / 5.0, 5.0) for s in segments]
    everything = ("offsets", "unbalance", "viscosity")
    prior_std = np.r_[0.25, 0.25, 0.1, 0.1, 2.0, 2.0, np.full(4, 25.0)]
    still = tracking_bound_pct(rates, everything, prior_std, np.zeros(10))
    prior = np.diag(prior_std**-2.0)
    total = trajectory_information(maps, h, DT, q, segments, SIGMA)
    np.testing.assert_allclose(still, trajectory_bound_pct(total, everything, prior), rtol=1e-6)
    walks = np.r_[0.005, 0.005, 0.002, 0.002, 0.02, 0.02, np.full(4, 0.2)]
    assert np.all(tracking_bound_pct(rates, everything, prior_std, walks) > still)
