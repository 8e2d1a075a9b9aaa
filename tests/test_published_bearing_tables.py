"""oilwatch's film against published tables: Lund & Thomsen (1978) and the short-bearing (Ocvirk) limit.

Lund & Thomsen's flooded two-axial-groove bearing (oilwatch/models/bearing/published_tables.py gives the
source, the rows as reproduced in petrobras/ross ``ross/tests/test_fluid_film_literature.py`` and the
frames): oilwatch solves it with both grooves full at ambient pressure (``SupplyPressure(0)``) and the
project's quasi-static coefficients (held-partition stiffness, frozen-content damping).

Why the tolerances (docs/validation-bearing.md has the measured figures):

* Cavitation model. Lund uses Swift-Stieber (Reynolds) boundaries, oilwatch the mass-conserving p-theta
  film. They differ only where the film re-forms inside a land. In this bearing the cavitated zone of the
  unloaded pad runs into the downstream groove at every tabulated S (no land cell re-forms: checked below),
  so the steady films solve the same problem; the held-partition stiffness is the first-order perturbation
  with the Reynolds boundary moving (the pressure vanishes on it), and the frozen-content damping puts no
  squeeze pressure in the cavitated zone, as Lund's does. The squeeze term applied in the cavitated cells
  too moves nothing (its extra oil drains into the flooded groove: checked below).
* What is left is discretization and the table's own precision (3-4 printed digits of a 1978
  finite-difference solution). On 72 x 24 cells: eccentricity ratio within 0.004, attitude within 0.3 deg,
  every K and B entry within 2.5 % of its matrix's largest entry and entries above 1 within 5 % of
  themselves; the damping converges first-order with the mesh, so the slow sibling on 144 x 48 holds
  1.2 % and 3 %.
"""

from __future__ import annotations

import numpy as np
import pytest

from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.published_tables import (
    COLUMNS,
    LUND_THOMSEN_1978,
    published,
    short_bearing,
    solve,
    two_groove_bearing,
)

ROWS = [(ld, row) for ld, rows in LUND_THOMSEN_1978.items() for row in rows]
IDS = [f"LD{ld}-S{row[0]}" for ld, row in ROWS]
STIFFNESS, DAMPING = COLUMNS[2:6], COLUMNS[6:10]


def check_row(ld, row, mesh, matrix_tol, entry_tol):
    values, flow, eq = solve(two_groove_bearing(ld), row[0], mesh)
    ref = published(row)
    assert values["eps"] == pytest.approx(ref["eps"], abs=0.004)
    assert values["phi"] == pytest.approx(ref["phi"], abs=0.3)
    for names in (STIFFNESS, DAMPING):
        largest = max(abs(ref[n]) for n in names)
        for name in names:
            assert abs(values[name] - ref[name]) < matrix_tol * largest, (name, values[name], ref[name])
            if abs(ref[name]) > 1.0:
                assert values[name] == pytest.approx(ref[name], rel=entry_tol), name
    return values, flow, eq


@pytest.mark.parametrize(("ld", "row"), ROWS, ids=IDS)
def test_lund_thomsen_two_axial_groove_bearing(ld, row):
    _, flow, eq = check_row(ld, row, Mesh(72, 24), 0.025, 0.05)
    # the cavitated zone drains into the downstream groove: no land cell re-forms, the Swift-Stieber film
    film = eq.film
    full = film.fill_fraction >= 1.0 - 1e-12
    land = ~film.grid.in_groove
    reforming = full & land & ~np.roll(full, 1, axis=0) & np.roll(land, 1, axis=0)
    assert not reforming.any()
    assert 0.0 < flow < 0.5 and eq.side_leakage_m3_s == pytest.approx(eq.supply_flow_m3_s, rel=1e-8)


@pytest.mark.slow
@pytest.mark.parametrize(("ld", "row"), ROWS, ids=IDS)
def test_lund_thomsen_on_a_finer_mesh(ld, row):
    check_row(ld, row, Mesh(144, 48), 0.012, 0.03)


def test_the_squeeze_term_in_the_cavitated_zone_does_not_move_the_flooded_two_groove_bearing():
    ld, row = ROWS[1]
    bearing = two_groove_bearing(ld)
    full_film, _, _ = solve(bearing, row[0], Mesh(72, 24))
    everywhere, _, _ = solve(bearing, row[0], Mesh(72, 24), squeeze="everywhere")
    assert max(abs(full_film[n] - everywhere[n]) for n in COLUMNS) < 1e-3


@pytest.mark.parametrize("eps", [0.1, 0.3, 0.5, 0.7])
def test_short_bearing_limit_is_ocvirk(eps):
    """L/D = 1/16: Ocvirk neglects the circumferential pressure flow, an error of order (L/D)^2 that is
    largest at small eps, where the circumferential pressure gradient is largest against the axial one.
    Tolerances: eps 1.5 %, attitude 0.3 deg, K and B 1.5 % of the largest entry; the flow against Ocvirk's
    q = eps R c L omega (the Couette flow in at the thickest film less that out at the thinnest) at
    oilwatch's own eccentricity, 0.3 %."""
    eq, k, b, flow, reference = short_bearing(1.0 / 16.0, eps)
    assert eq.eccentricity_ratio == pytest.approx(eps, rel=0.015)
    assert eq.attitude_deg == pytest.approx(reference["phi"], abs=0.3)
    assert flow == pytest.approx(eq.eccentricity_ratio, rel=0.003)
    assert np.abs(k - reference["K"]).max() < 0.015 * np.abs(reference["K"]).max()
    assert np.abs(b - reference["B"]).max() < 0.015 * np.abs(reference["B"]).max()


def test_the_short_bearing_error_shrinks_as_the_bearing_shortens():
    errors = []
    for ld in (0.25, 0.125, 0.0625):
        _, k, _, _, reference = short_bearing(ld, 0.1)
        errors.append(np.abs(k - reference["K"]).max() / np.abs(reference["K"]).max())
    assert errors[0] > 2.0 * errors[1] > 4.0 * errors[2]
