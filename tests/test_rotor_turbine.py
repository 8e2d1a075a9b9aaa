"""The paper's generic turbine: weight, unbalance (Eqs. 5-6), whirl over speed, unbalance response."""

from __future__ import annotations

import numpy as np
import pytest

from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.rotor.modal import campbell_diagram, damped_modes
from oilwatch.models.rotor.response import (
    orbit_semi_axes,
    static_deflection,
    unbalance_response,
    unbalance_response_sweep,
)
from oilwatch.models.rotor.supports import LinearBearing, isotropic_bearings
from oilwatch.models.validation import InputError


@pytest.fixture(scope="module")
def rotor():
    return Rotor.from_machine(load_machine())


@pytest.fixture(scope="module")
def bearings(rotor):
    return isotropic_bearings(rotor.bearing_nodes, 1e8, 1e4)


def test_weight_and_bearing_loads(rotor):
    # Paper: W = 6545.6 N, 3272.8 N per bearing (REFERENCE.md: 351.39 kg shaft + discs).
    assert rotor.weight_n == pytest.approx(6545.6, abs=0.5)
    assert rotor.shaft_mass_kg == pytest.approx(351.39, abs=0.01)
    assert [d.mass_kg for _, d in rotor.discs] == pytest.approx([74.13, 100.14, 141.58], abs=0.01)
    np.testing.assert_allclose(rotor.bearing_static_loads_n, 3272.8, atol=0.25)
    # The consistent gravity load carries exactly the weight, all along -y.
    assert -rotor.gravity_force[1::4].sum() == pytest.approx(rotor.weight_n, rel=1e-12)
    assert not rotor.gravity_force[0::4].any()


def test_unbalance_moment_iso_g25(rotor):
    assert rotor.unbalance_moment_kg_m == pytest.approx(3.54e-3, rel=0.005)
    assert rotor.unbalance_node == 13


@pytest.mark.parametrize("phase", [0.0, 1.1])
def test_unbalance_amplitude_is_eqs_5_6(phase):
    base = Rotor.from_machine(load_machine())
    rotor = Rotor.build(
        load_machine().element_lengths_m,
        load_machine().element_diameters_m,
        load_machine().material,
        base.discs,
        unbalance_node=13,
        unbalance_moment_kg_m=base.unbalance_moment_kg_m,
        unbalance_phase_rad=phase,
    )
    omega = 2 * np.pi * 75.0
    amplitude = rotor.unbalance_amplitude(omega)
    assert np.count_nonzero(amplitude) == 2
    x, y = rotor.dof(13, "x"), rotor.dof(13, "y")
    me = rotor.unbalance_moment_kg_m
    for t in np.linspace(0.0, 0.02, 7):
        force = np.real(amplitude * np.exp(1j * omega * t))
        assert force[x] == pytest.approx(me * omega**2 * np.cos(omega * t + phase), abs=1e-12)
        assert force[y] == pytest.approx(me * omega**2 * np.sin(omega * t + phase), abs=1e-12)
        np.testing.assert_allclose(rotor.unbalance_force(omega, t), force, atol=1e-12)


def test_forward_whirl_rises_backward_falls(rotor, bearings):
    speeds = np.linspace(0.0, 120.0, 13)
    diagram = campbell_diagram(rotor, speeds, bearings, n_modes=6)
    for pair in range(3):
        low, high = diagram.frequencies_hz[1:, 2 * pair], diagram.frequencies_hz[1:, 2 * pair + 1]
        assert not diagram.forward[1:, 2 * pair].any(), "lower of a split pair whirls backward"
        assert diagram.forward[1:, 2 * pair + 1].all(), "upper of a split pair whirls forward"
        assert np.all(np.diff(high) > 0) and np.all(np.diff(low) < 0)
    # Only the forward branch meets 1x: one critical speed below 120 Hz on these bearings.
    critical = diagram.critical_speeds_hz()
    assert len(critical) == 1 and 40.0 < critical[0] < 60.0


def test_speed_dependent_bearings(rotor):
    def soft_then_stiff(speed_hz):
        return isotropic_bearings(rotor.bearing_nodes, 1e7 * (1 + speed_hz / 10.0), 1e4)

    diagram = campbell_diagram(rotor, [0.0, 50.0], soft_then_stiff, n_modes=2)
    fixed = damped_modes(rotor, 50.0, soft_then_stiff(50.0), n_modes=2)
    np.testing.assert_allclose(diagram.frequencies_hz[1], [m.frequency_hz for m in fixed])
    assert diagram.frequencies_hz[1, 0] > diagram.frequencies_hz[0, 0] * 1.5


def test_cross_coupled_bearings_can_destabilize(rotor):
    # Lund convention: kxy > 0, kyx < 0 feeds energy into forward whirl (oil-whip mechanism).
    def bearing_set(cross):
        k = np.array([[1e8, cross], [-cross, 1e8]])
        return [LinearBearing(n, k, 1e4 * np.eye(2)) for n in rotor.bearing_nodes]

    first_forward = [
        next(m for m in damped_modes(rotor, 75.0, bearing_set(cross), 4) if m.whirl == "forward")
        for cross in (0.0, 5e7)
    ]
    assert first_forward[0].log_decrement > 0 > first_forward[1].log_decrement


def test_unbalance_response_satisfies_equation_of_motion(rotor):
    k = np.array([[7e7, 3e8], [-3.2e8, 4e7]])
    c = np.array([[1.3e6, -1.5e5], [-1.5e5, 1.4e6]])
    supports = [LinearBearing(n, k, c) for n in rotor.bearing_nodes]
    speed = 75.0
    omega = 2 * np.pi * speed
    response = unbalance_response(rotor, speed, supports)
    from oilwatch.models.rotor.supports import bearing_matrices

    k_b, c_b = bearing_matrices(rotor.n_dof, supports)
    for t in (0.0, 0.0031, 0.0107):
        phasor = np.exp(1j * omega * t)
        r = np.real(response * phasor)
        v = np.real(1j * omega * response * phasor)
        a = np.real(-(omega**2) * response * phasor)
        lhs = (
            rotor.mass_matrix @ a
            + (rotor.damping_matrix + c_b + omega * rotor.gyroscopic_matrix) @ v
            + (rotor.stiffness_matrix + k_b) @ r
        )
        np.testing.assert_allclose(lhs, rotor.unbalance_force(omega, t), atol=1e-9)
    major, minor = orbit_semi_axes(response, 13)
    assert 1e-7 < minor <= major < 1e-3


def test_isotropic_response_is_a_forward_circle(rotor, bearings):
    response = unbalance_response(rotor, 30.0, bearings)
    for node in (6, 13, 20):
        major, minor = orbit_semi_axes(response, node)
        assert minor == pytest.approx(major, rel=1e-9)
        x, y = response[rotor.dof(node, "x")], response[rotor.dof(node, "y")]
        assert np.imag(x * np.conj(y)) > 0  # turns with the spin


def test_unbalance_response_peaks_at_the_critical_speed(rotor, bearings):
    critical = campbell_diagram(rotor, np.linspace(30, 70, 21), bearings, 4).critical_speeds_hz()
    speeds = np.linspace(30.0, 70.0, 401)
    sweep = unbalance_response_sweep(rotor, speeds, bearings)
    amplitude = np.abs(sweep[:, rotor.dof(13, "x")])
    peak = speeds[np.argmax(amplitude)]
    assert len(critical) == 1 and peak == pytest.approx(critical[0], abs=0.3)
    # Lightly damped (log decrement 0.035): a sharp resonance.
    assert amplitude.max() > 20 * amplitude[0]


def test_static_deflection_on_bearings(rotor, bearings):
    sag = static_deflection(rotor, bearings)
    # Each bearing spring carries its share of the weight (statically determinate, two supports).
    springs = -1e8 * sag[[rotor.dof(6, "y"), rotor.dof(20, "y")]]
    assert springs.sum() == pytest.approx(rotor.weight_n, rel=1e-9)
    assert not sag[0::4].any()
    with pytest.raises(InputError, match="do not hold"):
        static_deflection(rotor, [])


def test_bad_inputs(rotor, bearings):
    with pytest.raises(InputError, match="speed_hz"):
        damped_modes(rotor, -1.0, bearings)
    with pytest.raises(InputError, match="not a node"):
        damped_modes(rotor, 10.0, isotropic_bearings([22], 1e8, 0.0))
    with pytest.raises(InputError, match="not a node"):
        rotor.dof(0, "x")
    with pytest.raises(InputError, match="direction"):
        rotor.dof(3, "z")
    with pytest.raises(InputError, match="bearing node"):
        LinearBearing(6.0, np.eye(2), np.eye(2))
    with pytest.raises(InputError, match="2x2"):
        LinearBearing(6, np.eye(3), np.eye(2))
    with pytest.raises(InputError, match="stiffness"):
        isotropic_bearings([6], -1e8, 0.0)
    with pytest.raises(InputError, match="n_modes"):
        damped_modes(rotor, 10.0, bearings, n_modes=0)
