"""The synchronous 1x load at the instantaneous speed: the plant and the estimator take the 1x orbit's
impedances and the rotor's dynamic stiffness at the speed the rotor turns at, not at the speed their model
was built for (``RotorBearingSystem.unit_unbalance_load(..., whirl_rad_s)``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from oilwatch.models.machine import load_machine
from oilwatch.models.system.operating_maps import OperatingMaps
from oilwatch.models.system.operating_point import (
    operating_system,
    operating_table_of,
    set_operating_conditions,
)

MACHINE = load_machine()
MU = MACHINE.bearing.viscosity_pa_s
Q = tuple(np.array([0.8, 0.9]) * MACHINE.lubrication.nominal_flowrates_m3_s)


def _dynamic_stiffness(system, tables, speed_hz):
    """K - Omega^2 M + i Omega (D + (Omega - Omega_0) G) + sum P^T Z P with Z = K_b + i Omega C_b of
    ``tables`` at Q."""
    w = 2.0 * math.pi * speed_hz
    damping = system.damping + (w - system.omega_rad_s) * system.gyroscopic
    matrix = system.stiffness - w * w * system.mass + 1j * w * damping
    for p, table, q in zip(system.bearing_maps, tables, Q, strict=True):
        c = table.evaluate(q)
        matrix = matrix + p.T @ (c.stiffness + 1j * w * c.damping) @ p
    return matrix


@pytest.fixture(scope="module")
def built_at_72():
    system = operating_system(MACHINE, 72.0, MU)
    set_operating_conditions(system, 78.0, MU)
    return system


def test_the_quasi_static_dynamics_under_the_load_give_the_synchronous_orbit_at_the_speed(built_at_72):
    system = built_at_72
    growth = (78.0 / 72.0) ** 2
    load = growth * system.unit_unbalance_load(Q, 2.0 * math.pi * 78.0)
    orbit = np.linalg.solve(_dynamic_stiffness(system, system.tables, 78.0), load)
    synchronous = np.linalg.solve(
        _dynamic_stiffness(system, system.synchronous_tables, 78.0), growth * system.unit_unbalance_force
    )
    np.testing.assert_allclose(orbit, synchronous, rtol=0.0, atol=1e-9 * np.abs(synchronous).max())
    # at the build speed's whirl the orbit would be another one (what the plant took before)
    stale = np.linalg.solve(
        _dynamic_stiffness(system, system.tables, 78.0), growth * system.unit_unbalance_load(Q)
    )
    assert np.abs(stale - synchronous).max() > 1e-3 * np.abs(synchronous).max()


def test_the_load_does_not_depend_on_the_speed_the_model_was_built_for(built_at_72):
    at_78 = operating_system(MACHINE, 78.0, MU).unit_unbalance_load(Q)
    from_72 = (78.0 / 72.0) ** 2 * built_at_72.unit_unbalance_load(Q, 2.0 * math.pi * 78.0)
    np.testing.assert_allclose(from_72, at_78, rtol=0.0, atol=1e-9 * np.abs(at_78).max())


def test_the_estimators_maps_take_the_plants_1x_load_at_the_speed():
    """The operating maps on a system built at 75 Hz, at 78 Hz, against a system built at 78 Hz."""
    system_75 = operating_system(MACHINE, 75.0, MU)
    maps = OperatingMaps(
        system_75, operating_table_of(MACHINE, "quasi-static"), 1e-3, operating_table_of(MACHINE)
    )
    block = maps.block(np.array(Q), 78.0, np.full(2, MU))
    system_78 = operating_system(MACHINE, 78.0, MU)
    n = system_78.n_coordinates
    load = system_78.unbalance_load(Q)
    expected = np.linalg.solve(system_78.mass, np.column_stack([load.real, -load.imag]))
    np.testing.assert_allclose(
        block[n : 2 * n, 2 * n + 1 :], expected, rtol=0.0, atol=1e-8 * np.abs(expected).max()
    )
