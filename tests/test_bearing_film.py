"""p-theta film solver: mass conservation, the seamless supply regimes, the Gauss-Seidel reference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from oilwatch.models.bearing.film import solve_film
from oilwatch.models.bearing.gauss_seidel import gauss_seidel_film
from oilwatch.models.bearing.geometry import JournalBearing
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S, SupplyFlow, SupplyPressure

BEARING = JournalBearing(0.045, 0.070, 120e-6, 0.094, 0.0, 16.2e-3, 35e-3)
SPEED_HZ = 75.0
MESH = Mesh(60, 16)


def _position(ratio: float = 0.125, attitude_deg: float = 65.0) -> tuple[float, float]:
    angle = math.radians(attitude_deg - 90.0)
    e = ratio * BEARING.clearance_m
    return (e * math.cos(angle), e * math.sin(angle))


@pytest.mark.parametrize(
    "supply",
    [
        SupplyFlow(300.0 / ML_MIN_PER_M3_S),
        SupplyFlow(800.0 / ML_MIN_PER_M3_S),
        SupplyPressure(0.0),
        SupplyPressure(5e4),
    ],
    ids=["starved", "flooded-by-flow", "zero-pressure", "0.5bar"],
)
def test_supply_flow_equals_side_leakage(supply):
    film = solve_film(BEARING, SPEED_HZ, _position(), supply, mesh=Mesh(100, 30))
    assert film.residual < 1e-10
    assert film.side_leakage_m3_s == pytest.approx(film.supply_flow_m3_s, rel=1e-6)
    assert np.all(film.pressure_pa >= 0.0)
    assert np.all((film.fill_fraction >= 0.0) & (film.fill_fraction <= 1.0))
    # Complementarity: no volume is both under pressure and partly filled.
    assert np.all((film.pressure_pa <= 0.0) | (film.fill_fraction >= 1.0))


def test_regimes_meet_without_a_seam():
    """Given flow q, the solution equals the pressure-fed one whose flow is q; starved below q_t."""
    ecc = _position()
    threshold = solve_film(BEARING, SPEED_HZ, ecc, SupplyPressure(0.0), mesh=MESH)
    q_t = threshold.supply_flow_m3_s
    at_threshold = solve_film(BEARING, SPEED_HZ, ecc, SupplyFlow(q_t), mesh=MESH)
    assert at_threshold.supply_pressure_pa == pytest.approx(0.0, abs=1e-3)
    assert at_threshold.groove_fill_fraction == pytest.approx(1.0, abs=1e-9)
    np.testing.assert_allclose(at_threshold.force_n, threshold.force_n, rtol=1e-9)

    fed = solve_film(BEARING, SPEED_HZ, ecc, SupplyPressure(4e4), mesh=MESH)
    by_flow = solve_film(BEARING, SPEED_HZ, ecc, SupplyFlow(fed.supply_flow_m3_s), mesh=MESH)
    assert by_flow.regime == "flooded"
    assert by_flow.supply_pressure_pa == pytest.approx(4e4, rel=1e-8)
    np.testing.assert_allclose(by_flow.force_n, fed.force_n, rtol=1e-9)

    starved = solve_film(BEARING, SPEED_HZ, ecc, SupplyFlow(0.8 * q_t), mesh=MESH)
    assert starved.regime == "starved"
    assert starved.supply_pressure_pa == 0.0
    assert 0.0 < starved.groove_fill_fraction < 1.0
    # Less oil carries less load.
    assert np.linalg.norm(starved.force_n) < np.linalg.norm(threshold.force_n)


@pytest.mark.parametrize(
    "supply", [SupplyFlow(400.0 / ML_MIN_PER_M3_S), SupplyPressure(5e4)], ids=["flow", "pressure"]
)
def test_gauss_seidel_reference_agrees(supply):
    ecc = _position()
    fast = solve_film(BEARING, SPEED_HZ, ecc, supply, mesh=Mesh(48, 12))
    reference = gauss_seidel_film(BEARING, SPEED_HZ, ecc, supply, mesh=Mesh(48, 12))
    peak = fast.pressure_pa.max()
    assert np.abs(fast.pressure_pa - reference.pressure_pa).max() < 1e-6 * peak
    assert np.abs(fast.fill_fraction - reference.fill_fraction).max() < 1e-6
    np.testing.assert_allclose(reference.force_n, fast.force_n, rtol=1e-6)
    assert reference.supply_flow_m3_s == pytest.approx(fast.supply_flow_m3_s, rel=1e-6)
    assert reference.regime == fast.regime


def test_squeeze_modes_differ_only_in_the_cavitated_zone():
    """Both squeeze treatments coincide for a full film (high supply pressure, no cavitation)."""
    ecc = _position(0.02)
    velocity = (1e-4, -2e-4)
    fed = SupplyPressure(2e6)
    a = solve_film(BEARING, SPEED_HZ, ecc, fed, velocity_m_s=velocity, mesh=MESH)
    b = solve_film(BEARING, SPEED_HZ, ecc, fed, velocity_m_s=velocity, mesh=MESH, squeeze="everywhere")
    assert np.all(a.pressure_pa > 0.0)
    assert np.all(b.pressure_pa > 0.0)
    np.testing.assert_allclose(a.force_n, b.force_n, rtol=1e-9)
    # A rigid translation leaves the full film's volume unchanged: still supply = side leakage.
    assert a.supply_flow_m3_s == pytest.approx(a.side_leakage_m3_s, rel=1e-9)
    # ... but the squeeze changes the pressure: the velocity is felt.
    still = solve_film(BEARING, SPEED_HZ, ecc, fed, mesh=MESH)
    assert np.linalg.norm(a.force_n - still.force_n) > 1e-3 * np.linalg.norm(still.force_n)
