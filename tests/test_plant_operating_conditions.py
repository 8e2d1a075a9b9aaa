"""The plant at a changing operating point: speed and oil temperature as inputs, on the dimensionless
table."""

import math

import numpy as np
import pytest

from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_point import operating_system, operating_table_of
from oilwatch.models.system.plant import RotorBearingPlant
from oilwatch.models.validation import InputError

MACHINE = load_machine()
Q = 596.3e-6 / 60.0
T0 = MACHINE.nominal_oil_temperature_c


@pytest.fixture(scope="module")
def table():
    return operating_table_of(MACHINE)  # the machine file's kind: synchronous


def _plant(table, unbalance=0.0, **kwargs):
    # The machine's default: quasi-static dynamics, synchronous 1x load (both dimensionless tables).
    system = operating_system(MACHINE, 75.0, MACHINE.bearing.viscosity_pa_s, unbalance_moment_kg_m=unbalance)
    assert system.synchronous_tables[0].table.metadata == table.metadata
    plant = RotorBearingPlant(
        system,
        1e-3,
        None,
        0.0,
        1,
        initial_flowrates_m3_s=(Q, Q),
        oil=MACHINE.oil,
        oil_temperature_c=T0,
        **kwargs,
    )
    return system, plant


def _static(system):
    return system.bearing_positions(system.static_coordinates((Q, Q))).ravel()


def test_static_position_follows_the_table_under_slow_speed_and_temperature_ramps(table):
    system, plant = _plant(table)
    start = plant.current_sample().true_position_m
    for k in range(1, 1001):  # 75 -> 72 Hz and +3 degC in 1 s: about 5 times faster than the ramps
        sample = plant.step((Q, Q), speed_hz=75.0 - 3e-3 * k, oil_temperature_c=T0 + 3e-3 * k)
    static = _static(system)  # at the instantaneous (72 Hz, T0 + 3 degC)
    assert np.abs(sample.true_position_m - start).max() > 2e-6  # the operating point moved the journal
    assert np.abs(sample.true_position_m - static).max() < 0.06e-6  # quasi-static lag of a 1 s ramp
    for _ in range(300):
        sample = plant.step((Q, Q))
    assert np.abs(sample.true_position_m - static).max() < 0.01e-6
    # The table's equilibrium at that operating point: the static journal position in each bearing.
    e0 = np.concatenate([t.evaluate(Q).eccentricity_m for t in system.tables])
    assert np.abs(static - e0).max() < 0.05e-6
    assert plant.viscosity_pa_s == pytest.approx(MACHINE.oil.dynamic_viscosity_pa_s(T0 + 3.0))


def test_rotor_angle_is_the_integral_of_the_speed(table):
    _, plant = _plant(table)
    speeds = 75.0 + 0.01 * np.arange(1, 51)
    for f in speeds:
        plant.step((Q, Q), speed_hz=f)
    assert plant.rotor_angle_rad == pytest.approx(2 * math.pi * speeds.sum() * 1e-3, rel=1e-12)


def test_viscosity_factor_moves_the_journal_like_a_colder_oil(table):
    factored, _ = _plant(table, viscosity_factor=1.1)
    colder, cold_plant = _plant(table)
    cold = MACHINE.oil.temperature_at_viscosity_c(1.1 * MACHINE.oil.dynamic_viscosity_pa_s(T0))
    cold_plant.step((Q, Q), oil_temperature_c=cold)
    nominal, _ = _plant(table)
    np.testing.assert_allclose(_static(factored), _static(colder), atol=1e-12)
    assert np.abs(_static(factored) - _static(nominal)).max() > 0.3e-6


def test_on_the_dimensionless_table_at_nominal_the_orbit_matches_the_flowrate_table(table):
    moment = load_system(reduced=False).unbalance_moment_kg_m
    system, _ = _plant(table, unbalance=moment)
    classic = load_system(reduced=False)
    for a, b in ((system, classic),):
        amp_a = a.bearing_positions(a.unbalance_coordinates((Q, Q)))
        amp_b = b.bearing_positions(b.unbalance_coordinates((Q, Q)))
        assert np.abs(amp_a - amp_b).max() < 0.01 * np.abs(amp_b).max()
        assert np.abs(_static(a) - _static(b)).max() < 0.005 * np.abs(_static(b)).max()


def test_speed_or_temperature_outside_the_table_or_without_it_is_refused(table):
    _, plant = _plant(table)
    with pytest.raises(InputError, match="Sommerfeld"):
        plant.step((Q, Q), speed_hz=12.0)
    classic = RotorBearingPlant(load_system(reduced=False), 1e-3, None, 0.0, 1, initial_flowrates_m3_s=(Q, Q))
    with pytest.raises(InputError, match="dimensionless table"):
        classic.step((Q, Q), speed_hz=74.0)
