"""Bad input names the argument and its allowed range (models.validation.InputError)."""

from __future__ import annotations

import pytest

from oilwatch.models.bearing.equilibrium import static_equilibrium
from oilwatch.models.bearing.film import solve_film
from oilwatch.models.bearing.geometry import JournalBearing
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import SupplyFlow, SupplyPressure
from oilwatch.models.validation import InputError

BEARING = JournalBearing(0.045, 0.070, 120e-6, 0.094, 0.0, 16.2e-3, 35e-3)
MESH = Mesh(48, 12)


def test_negative_flowrate_and_pressure():
    with pytest.raises(InputError, match=r"supply flowrate q_m3_s must be >= 0"):
        SupplyFlow(-1e-6)
    with pytest.raises(InputError, match=r"supply pressure p_pa must be >= 0"):
        SupplyPressure(-1.0)
    with pytest.raises(InputError, match=r"q_m3_s must be finite"):
        SupplyFlow(float("nan"))


def test_zero_speed():
    with pytest.raises(InputError, match=r"speed_hz must be > 0"):
        solve_film(BEARING, 0.0, (0.0, -1e-5), SupplyPressure(0.0), mesh=MESH)
    with pytest.raises(InputError, match=r"speed_hz must be > 0"):
        static_equilibrium(BEARING, 3272.8, 0.0, SupplyPressure(0.0), MESH)


def test_eccentricity_ratio_at_or_beyond_one():
    with pytest.raises(InputError, match=r"eccentricity_m gives an eccentricity ratio 1\b"):
        solve_film(BEARING, 75.0, (0.0, -120e-6), SupplyPressure(0.0), mesh=MESH)
    with pytest.raises(InputError, match=r"eccentricity_m .* ratio 1.5"):
        solve_film(BEARING, 75.0, (180e-6, 0.0), SupplyPressure(0.0), mesh=MESH)


def test_mesh_too_coarse():
    with pytest.raises(InputError, match=r"mesh n_circ must be >= 24 \(mesh too coarse\), got 8"):
        Mesh(8, 12)
    with pytest.raises(InputError, match=r"mesh n_axial must be >= 6 \(mesh too coarse\), got 2"):
        Mesh(48, 2)
    with pytest.raises(InputError, match=r"mesh n_circ must be an integer"):
        Mesh(48.5, 12)


def test_load_and_unreachable_equilibrium():
    with pytest.raises(InputError, match=r"load_n must be > 0"):
        static_equilibrium(BEARING, -5.0, 75.0, SupplyPressure(0.0), MESH)
    with pytest.raises(InputError, match=r"no static equilibrium found for load_n"):
        static_equilibrium(BEARING, 3272.8, 75.0, SupplyFlow(1e-9), MESH)
