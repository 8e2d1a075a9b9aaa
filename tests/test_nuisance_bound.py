"""Cramer-Rao bound with the machine's nuisances unknown (oilwatch.models.system.nuisance_bound).

Checked against the plain bound of :mod:`oilwatch.models.system.orbit_bound` (all known, offsets unknown),
the per-sample Fisher sum, the Sommerfeld scaling of the film (viscosity = inverse load) and the behaviour a
prior must have (a baseline only helps; drift takes the help away).
"""

from __future__ import annotations

import dataclasses
import itertools
from types import SimpleNamespace

import numpy as np
import pytest
from test_identifiability import Q_NOMINAL, StandInTable

from oilwatch.models.bearing.equilibrium import coefficients_at, static_equilibrium
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.nuisance_bound import (
    harmonic_fisher,
    harmonic_sensitivity,
    nuisance_bound,
    viscosity_derivative,
)
from oilwatch.models.system.orbit_bound import cramer_rao_bound, fisher_information
from oilwatch.models.system.rotor_bearing import RotorBearingSystem
from oilwatch.models.validation import InputError

SIGMA = 1e-6
Q = np.array([0.9, 0.8]) * Q_NOMINAL


@pytest.fixture(scope="module")
def system():
    rotor = Rotor.from_machine(load_machine())
    return RotorBearingSystem(rotor, [StandInTable(), StandInTable()], 75.0)


def _stand_in_viscosity(flows):
    """A made-up smooth viscosity derivative (the bound's algebra does not care where it comes from)."""
    out = []
    for q in flows:
        value = StandInTable().evaluate(q)
        out.append(
            SimpleNamespace(
                eccentricity_m=-0.8 * value.eccentricity_m,
                stiffness=0.7 * value.stiffness,
                damping=1.0 * value.damping,
            )
        )
    return out


def test_known_and_offsets_reproduce_the_plain_bound(system):
    for n in (400, 1234):
        plain = cramer_rao_bound(system, Q, SIGMA, n)
        np.testing.assert_allclose(nuisance_bound(system, Q, SIGMA, n, ()).std_pct, plain.std_pct, rtol=1e-6)
        offsets = cramer_rao_bound(system, Q, SIGMA, n, unknown_offsets=True)
        np.testing.assert_allclose(
            nuisance_bound(system, Q, SIGMA, n, ("offsets",)).std_pct, offsets.std_pct, rtol=1e-5
        )


def test_closed_form_fisher_equals_the_sum_over_samples(system):
    sens = harmonic_sensitivity(system, Q, ("offsets", "unbalance", "viscosity"), _stand_in_viscosity(Q))
    n, dt = 777, 1e-3
    phase = np.exp(1j * system.omega_rad_s * dt * np.arange(n))
    jac = sens.static[None] + (sens.amplitude[None] * phase[:, None, None]).real
    np.testing.assert_allclose(
        harmonic_fisher(sens, system.omega_rad_s, SIGMA, n, dt), fisher_information(jac, SIGMA), rtol=1e-9
    )


def test_more_unknowns_never_help_and_a_baseline_does(system):
    kwargs = {"viscosity_derivatives": _stand_in_viscosity}
    stds = [
        nuisance_bound(system, Q, SIGMA, 2000, groups, **kwargs).std_pct
        for groups in ((), ("offsets",), ("offsets", "unbalance"), ("offsets", "unbalance", "viscosity"))
    ]
    for smaller, larger in itertools.pairwise(stds):
        assert np.all(larger >= smaller * (1 - 1e-9))
    groups = ("offsets", "unbalance", "viscosity")
    free = nuisance_bound(system, Q, SIGMA, 2000, groups, **kwargs)
    baseline = {"baseline_flowrates_m3_s": (Q_NOMINAL,) * 2, "baseline_samples": 60_000, **kwargs}
    base = nuisance_bound(system, Q, SIGMA, 2000, groups, **baseline)
    drifted = nuisance_bound(system, Q, SIGMA, 2000, groups, drift_std={"offset": 3.0}, **baseline)
    known = stds[0]
    assert base.baseline and np.all(base.std_pct < free.std_pct)
    assert np.all(known <= base.std_pct * (1 + 1e-9)) and np.all(base.std_pct < drifted.std_pct)
    assert np.all(drifted.std_pct <= free.std_pct * (1 + 1e-9))
    assert set(free.nuisance_std) == {
        "offset_x1",
        "offset_y1",
        "offset_x2",
        "offset_y2",
        "unbalance_re",
        "unbalance_im",
        "viscosity_1",
        "viscosity_2",
    }


def test_bad_group_and_missing_viscosity_are_named(system):
    with pytest.raises(InputError, match="nuisance groups"):
        nuisance_bound(system, Q, SIGMA, 100, ("phase",))
    with pytest.raises(InputError, match="viscosity"):
        harmonic_sensitivity(system, Q, ("viscosity",))


def test_viscosity_derivative_obeys_the_sommerfeld_scaling():
    """Film forces scale with mu at fixed (q, e): K(f mu, W) = f K(mu, W / f), e0(f mu, W) = e0(mu, W / f), so
    the viscosity derivative equals K - W dK/dW and -W de0/dW, here from independent load re-solves."""
    bearing = load_machine().bearing
    load, speed, q, mesh = 3272.8, 75.0, 0.9 * Q_NOMINAL, {"n_circ": 60, "n_axial": 12}
    table = SimpleNamespace(
        metadata={"bearing": dataclasses.asdict(bearing), "mesh": mesh}, load_n=load, speed_hz=speed
    )
    derivative = viscosity_derivative(table, q)
    from oilwatch.models.bearing.grid import Mesh

    values = []
    for sign in (1.0, -1.0):
        eq = static_equilibrium(bearing, load * (1 + sign * 0.01), speed, SupplyFlow(q), Mesh(**mesh))
        k, c = coefficients_at(bearing, eq, speed, SupplyFlow(q), Mesh(**mesh))
        values.append((eq.eccentricity_m, k, c))
    eq = static_equilibrium(bearing, load, speed, SupplyFlow(q), Mesh(**mesh))
    k0, c0 = coefficients_at(bearing, eq, speed, SupplyFlow(q), Mesh(**mesh))
    w_de = (values[0][0] - values[1][0]) / 0.02
    w_dk = (values[0][1] - values[1][1]) / 0.02
    w_dc = (values[0][2] - values[1][2]) / 0.02
    for actual, expected in (
        (derivative.eccentricity_m, -w_de),
        (derivative.stiffness, k0 - w_dk),
        (derivative.damping, c0 - w_dc),
    ):
        np.testing.assert_allclose(actual, expected, rtol=0.0, atol=0.01 * np.abs(expected).max())


def test_synchronous_viscosity_derivative_obeys_the_sommerfeld_scaling_too():
    """At whirl = spin the film's K(Omega), C(Omega) scale with mu as the quasi-static ones (the whirl ratio
    is fixed), so the synchronous part equals K - W dK/dW, C - W dC/dW from load re-solves; the quasi-static
    part is the plain derivative's."""
    from oilwatch.models.bearing.dynamic import synchronous_coefficients
    from oilwatch.models.bearing.grid import Mesh

    bearing = load_machine().bearing
    load, speed, q, mesh = 3272.8, 75.0, 0.9 * Q_NOMINAL, {"n_circ": 60, "n_axial": 12}
    table = SimpleNamespace(
        metadata={"bearing": dataclasses.asdict(bearing), "mesh": mesh}, load_n=load, speed_hz=speed
    )
    quasi_static, synchronous = viscosity_derivative(table, q, synchronous=True)
    plain = viscosity_derivative(table, q)
    np.testing.assert_array_equal(quasi_static.stiffness, plain.stiffness)
    supply = SupplyFlow(q)
    values = []
    for factor in (1.01, 0.99, 1.0):
        eq = static_equilibrium(bearing, load * factor, speed, supply, Mesh(**mesh))
        values.append(synchronous_coefficients(eq.film, eq.eccentricity_m, speed, supply))
    (k_up, c_up), (k_down, c_down), (k0, c0) = values
    for actual, expected in (
        (synchronous.stiffness, k0 - (k_up - k_down) / 0.02),
        (synchronous.damping, c0 - (c_up - c_down) / 0.02),
    ):
        np.testing.assert_allclose(actual, expected, rtol=0.0, atol=0.02 * np.abs(expected).max())
    # and it is not the quasi-static derivative (which a synchronous system's orbit does not follow)
    assert np.abs(synchronous.damping - quasi_static.damping).max() > 0.05 * np.abs(synchronous.damping).max()
