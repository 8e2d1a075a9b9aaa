"""Groove layouts: several axial grooves, a full circumferential groove, all on one supply.

The one-groove bearing is the special case (the bundled turbine's grid, film and tables are unchanged: the
rest of the suite runs on them). Here: the machine file's forms and their errors, the grid's groove cells,
an exact Poiseuille check of the circumferential groove and the film's division of one supply between two
axial grooves.
"""

from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

from oilwatch.models.bearing.film import solve_film
from oilwatch.models.bearing.geometry import AxialGroove, JournalBearing
from oilwatch.models.bearing.grid import Mesh, film_grid
from oilwatch.models.bearing.supply import SupplyFlow, SupplyPressure
from oilwatch.models.machine import BUNDLED_MACHINE, load_machine, machine_from_dict
from oilwatch.models.validation import InputError

R, L, C, MU = 0.05, 0.05, 100e-6, 0.02
SPAN = math.radians(20.0) * R


def two_groove_bearing(length=L, **extra) -> JournalBearing:
    """Two 20-deg axial grooves at the horizontal split line (bearing angles 90 and 270 deg)."""
    second = AxialGroove(math.radians(270.0), SPAN, length)
    return JournalBearing(R, length, C, MU, math.radians(90.0), SPAN, length, (second,), **extra)


@pytest.fixture(scope="module")
def turbine():
    return tomllib.loads(BUNDLED_MACHINE.read_text())


def with_grooves(turbine, grooves, **bearing_keys):
    data = copy.deepcopy(turbine)
    for key in ("groove_angle_deg", "groove_circumferential_mm", "groove_axial_mm"):
        del data["bearings"][key]
    data["bearings"]["grooves"] = grooves
    data["bearings"].update(bearing_keys)
    return data


def test_the_machine_file_lists_any_number_of_grooves_and_a_circumferential_one(turbine):
    grooves = [
        {"angle_deg": 90.0, "circumferential_mm": 15.7, "axial_mm": 60.0},
        {"angle_deg": 270.0, "circumferential_mm": 15.7, "axial_mm": 60.0},
    ]
    machine = machine_from_dict(with_grooves(turbine, grooves, circumferential_groove_axial_mm=8.0))
    bearing = machine.bearing
    assert len(bearing.grooves) == 2
    assert [math.degrees(g.angle_rad) for g in bearing.grooves] == pytest.approx([90.0, 270.0])
    assert bearing.grooves[1].axial_m == pytest.approx(0.06)
    assert bearing.circumferential_groove_m == pytest.approx(0.008)
    # the one-groove keys of the bundled file are the one-groove layout
    assert load_machine().bearing.grooves[0].axial_m == pytest.approx(0.035)
    assert load_machine().bearing.more_grooves == ()


@pytest.mark.parametrize(
    ("grooves", "keys", "message"),
    [
        (
            [{"angle_deg": 90.0, "circumferential_mm": 15.7, "axial_mm": 80.0}],
            {},
            r"grooves\[0\].axial_mm must be <=",
        ),
        (
            [{"angle_deg": 90.0, "circumferential_mm": 150.0, "axial_mm": 30.0}],
            {},
            r"circumferential_mm must be <= pi R",
        ),
        (
            [{"angle_deg": 90.0, "circumferential_mm": -1.0, "axial_mm": 30.0}],
            {},
            r"circumferential_mm must be > 0",
        ),
        ([{"angle_deg": 90.0, "axial_mm": 30.0}], {}, r"missing bearings.grooves\[0\].circumferential_mm"),
        ([], {}, r"non-empty array"),
        (
            [
                {"angle_deg": 90.0, "circumferential_mm": 20.0, "axial_mm": 30.0},
                {"angle_deg": 100.0, "circumferential_mm": 20.0, "axial_mm": 30.0},
            ],
            {},
            "overlap around the circumference",
        ),
        (
            [{"angle_deg": 90.0, "circumferential_mm": 15.7, "axial_mm": 30.0}],
            {"circumferential_groove_axial_mm": 70.0},
            r"circumferential_groove_axial_mm must be < 70",
        ),
    ],
)
def test_bad_groove_layouts_are_named_in_one_line(turbine, grooves, keys, message):
    with pytest.raises(InputError, match=message) as error:
        machine_from_dict(with_grooves(turbine, grooves, **keys))
    assert "\n" not in str(error.value)


def test_both_groove_forms_at_once_are_refused(turbine):
    data = copy.deepcopy(turbine)
    data["bearings"]["grooves"] = [{"angle_deg": 90.0, "circumferential_mm": 15.7, "axial_mm": 30.0}]
    with pytest.raises(InputError, match=r"give the grooves once"):
        machine_from_dict(data)


def test_every_groove_edge_is_on_a_cell_face_and_all_grooves_are_one_control_volume():
    bearing = JournalBearing(
        R, L, C, MU, math.radians(90.0), SPAN, 0.03, (AxialGroove(math.radians(270.0), SPAN, 0.04),), 0.01
    )
    grid = film_grid(bearing, Mesh(72, 24))
    alpha = np.degrees(grid.alpha_faces_rad - 0.5 * math.pi)  # bearing angle, from 80 deg on
    for centre in (90.0, 270.0):
        for edge in (centre - 10.0, centre + 10.0):
            assert np.min(np.abs(alpha - edge)) < 1e-9
    for width in (0.01, 0.03, 0.04):
        for edge in (0.5 * (L - width), 0.5 * (L + width)):
            assert np.min(np.abs(grid.z_faces_m - edge)) < 1e-12
    assert np.all(grid.node_of_cell[grid.in_groove] == grid.groove_node)
    # the circumferential band is groove all round; each axial groove covers its own width only
    z = 0.5 * (grid.z_faces_m[:-1] + grid.z_faces_m[1:])
    assert np.all(grid.in_groove[:, np.abs(z - 0.5 * L) < 0.005])
    in_first = (alpha[:-1] >= 80.0 - 1e-9) & (alpha[1:] <= 100.0 + 1e-9)
    covered = grid.in_groove[in_first]
    assert np.all(covered[:, np.abs(z - 0.5 * L) < 0.015]) and not np.any(
        covered[:, np.abs(z - 0.5 * L) > 0.015]
    )
    # mirror-symmetric about the mid-plane, so the half grid holds
    assert np.allclose(grid.z_faces_m + grid.z_faces_m[::-1], L)
    assert film_grid(bearing, Mesh(72, 24), half=True).in_groove.shape == (72, 12)


def test_a_circumferential_groove_feeds_two_lands_as_poiseuille_flow():
    """Journal all but centred (1e-4 c: exactly centred, a ring of cavitated cells would have no balance),
    band at p_s: each land's pressure falls linearly from p_s to 0 (exact on the finite volumes), so the
    flow is 2 pi D c^3 p_s / (12 mu L_land) to O(e/c)."""
    band, p_s = 0.01, 2.0e5
    bearing = JournalBearing(R, L, C, MU, 0.0, 0.002, 0.002, (), band)
    film = solve_film(bearing, 50.0, (1e-4 * C, 0.0), SupplyPressure(p_s), mesh=Mesh(48, 26))
    land = 0.5 * (L - band)
    expected = 2.0 * math.pi * 2.0 * R * C**3 * p_s / (12.0 * MU * land)
    assert film.supply_flow_m3_s == pytest.approx(expected, rel=1e-6)
    assert film.side_leakage_m3_s == pytest.approx(expected, rel=1e-6)


def test_one_supply_divides_between_two_grooves_by_the_film_balance():
    """The supply is the bearing's total; the grooves share one pressure and fill, the film draws what it
    carries from each, and the total leaves through the ends (mass conservation)."""
    bearing = two_groove_bearing()
    speed, e = 50.0, (0.3 * C * math.sin(math.radians(60.0)), -0.3 * C * math.cos(math.radians(60.0)))
    flooded = solve_film(bearing, speed, e, SupplyPressure(0.0), mesh=Mesh(72, 24))
    q_t = flooded.supply_flow_m3_s
    assert flooded.side_leakage_m3_s == pytest.approx(q_t, rel=1e-8)
    starved = solve_film(bearing, speed, e, SupplyFlow(0.7 * q_t), mesh=Mesh(72, 24))
    assert starved.regime == "starved" and starved.supply_pressure_pa == 0.0
    assert starved.side_leakage_m3_s == pytest.approx(0.7 * q_t, rel=1e-8)
    assert 0.0 < starved.groove_fill_fraction < 1.0
    # a smaller supply carries less load
    assert np.hypot(*starved.force_n) < np.hypot(*flooded.force_n)
