"""The dimensionless table on the flooded threshold: K and C jump there, so the table keeps both one-sided
limits and can interpolate the starved (f <= 1) and flooded (f >= 1) nodes separately (``one_sided``), never
across the jump.

Fast: a small table (coarse mesh) solved here. The committed tables against direct solves just either side of
the threshold are in the slow tests of tests/test_operating_table*.py.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.operating_accuracy import table_error
from oilwatch.models.bearing.operating_table import OperatingTable, operating_table_path
from oilwatch.models.bearing.operating_table_solve import compute_operating_table
from oilwatch.models.bearing.sommerfeld import ON_THRESHOLD, sommerfeld_number
from oilwatch.models.machine import load_machine
from oilwatch.models.validation import InputError

MACHINE = load_machine()
LOAD_N, SPEED_HZ = 3272.8, 75.0
F_NODES = np.array([0.5, 0.75, 1.0, 1.25, 1.5])


@pytest.fixture(scope="module")
def small_table() -> OperatingTable:
    nominal = sommerfeld_number(MACHINE.bearing, MACHINE.bearing.viscosity_pa_s, SPEED_HZ, LOAD_N)
    s_nodes = nominal * np.array([0.8, 1.0, 1.25])
    return compute_operating_table(MACHINE.bearing, LOAD_N, SPEED_HZ, s_nodes, F_NODES, Mesh(48, 16))


def test_the_threshold_node_is_the_mean_of_its_one_sided_limits(small_table):
    sides = small_table.threshold_sides
    np.testing.assert_allclose(0.5 * (sides[:, 0] + sides[:, 1]), small_table.values[:, 2], rtol=0, atol=1e-9)
    # the equilibrium and groove pressure are one state; K (and C) jump by several % of the largest entry
    np.testing.assert_allclose(sides[:, 0, 0:2], sides[:, 1, 0:2], rtol=0, atol=1e-12)
    jump = np.abs(sides[:, 0, 2:6] - sides[:, 1, 2:6]).max(axis=1) / np.abs(sides[:, 0, 2:6]).max(axis=1)
    assert np.all(jump > 0.01)


def test_each_side_of_the_threshold_tends_to_its_own_limit(small_table):
    s = float(small_table.sommerfeld_nodes[1])
    sides = small_table.threshold_sides[1]
    step = 2.0 * ON_THRESHOLD
    below, _, d_below = small_table.interpolate(s, 1.0 - step, one_sided=True)
    above, _, d_above = small_table.interpolate(s, 1.0 + step, one_sided=True)
    np.testing.assert_allclose(below + step * d_below, sides[0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(above - step * d_above, sides[1], rtol=0, atol=1e-6)
    mean = 0.5 * (sides[0] + sides[1])
    np.testing.assert_allclose(small_table.interpolate(s, 1.0, one_sided=True)[0], mean, rtol=0, atol=1e-12)
    for f in (
        1.0 - 0.5 * ON_THRESHOLD,
        1.0 + 0.5 * ON_THRESHOLD,
    ):  # within the band: the mean, moved by f - 1
        on, _, d_on = small_table.interpolate(s, f, one_sided=True)
        np.testing.assert_allclose(on - (f - 1.0) * d_on, mean, rtol=0, atol=1e-6)
    # the starved side uses no flooded node: moving a flooded node leaves f < 1 unchanged
    moved_values = small_table.values.copy()
    moved_values[:, 3:] *= 1.5
    moved = OperatingTable(
        small_table.sommerfeld_nodes,
        small_table.fraction_nodes,
        moved_values,
        small_table.threshold_flow_ratio,
        small_table.geometry,
        small_table.metadata,
        small_table.threshold_sides,
    )
    for f in (0.6, 0.9, 0.999):
        np.testing.assert_array_equal(
            moved.interpolate(s, f, one_sided=True)[0], small_table.interpolate(s, f, one_sided=True)[0]
        )


def test_a_slice_gives_the_same_rows_as_evaluate_on_both_sides(small_table):
    viscosity = MACHINE.bearing.viscosity_pa_s * 1.1
    for one_sided in (False, True):
        table_slice = small_table.at(SPEED_HZ, viscosity, LOAD_N, one_sided)
        q_t = table_slice.flooded_threshold_m3_s
        flows = q_t * np.array([0.6, 0.99, 1.0, 1.01, 1.4])
        rows = table_slice.rows(flows)
        for q, row in zip(flows, rows, strict=True):
            point = small_table.evaluate(SPEED_HZ, viscosity, LOAD_N, q, one_sided)
            stiffness, damping = point.coefficients.stiffness.ravel(), point.coefficients.damping.ravel()
            expected = np.concatenate([point.eccentricity_m, stiffness, damping])
            np.testing.assert_allclose(row, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


def test_an_older_table_is_refused_with_the_command_that_upgrades_it(small_table, tmp_path):
    older = small_table.to_dict()
    del older["threshold_sides"]
    older["format_version"] = 1
    path = tmp_path / "older.json"
    path.write_text(__import__("json").dumps(older))
    table = OperatingTable.load(path)
    q = small_table.at(SPEED_HZ, MACHINE.bearing.viscosity_pa_s, LOAD_N).flooded_threshold_m3_s
    with pytest.raises(InputError, match=r"oilwatch bearing-map --reuse"):
        table.evaluate(SPEED_HZ, MACHINE.bearing.viscosity_pa_s, LOAD_N, q, one_sided=True)
    # across the threshold it still serves, as before
    np.testing.assert_array_equal(
        table.evaluate(SPEED_HZ, MACHINE.bearing.viscosity_pa_s, LOAD_N, q).coefficients.stiffness,
        small_table.evaluate(SPEED_HZ, MACHINE.bearing.viscosity_pa_s, LOAD_N, q).coefficients.stiffness,
    )
    # reusing it solves only the limits, and gives the table back
    upgraded = compute_operating_table(
        MACHINE.bearing, LOAD_N, SPEED_HZ, table.sommerfeld_nodes, F_NODES, Mesh(48, 16), reuse=table
    )
    np.testing.assert_array_equal(upgraded.values, small_table.values)
    np.testing.assert_allclose(upgraded.threshold_sides, small_table.threshold_sides, rtol=1e-9, atol=1e-12)
    with pytest.raises(InputError, match="differs in mesh"):
        compute_operating_table(
            MACHINE.bearing, LOAD_N, SPEED_HZ, table.sommerfeld_nodes, F_NODES, Mesh(60, 16), reuse=table
        )


def test_a_table_needs_a_node_on_the_threshold(small_table):
    with pytest.raises(InputError, match="flooded threshold"):
        OperatingTable(
            small_table.sommerfeld_nodes,
            F_NODES * 0.9,
            small_table.values,
            small_table.threshold_flow_ratio,
            dataclasses.asdict(MACHINE.bearing),
        )


COMMITTED_POINTS = [
    (60.0, 0.07, 0.99),
    (60.0, 0.07, 1.0),
    (60.0, 0.07, 1.01),
    (90.0, 0.12, 0.99),
    (90.0, 0.12, 1.0),
]


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["quasi-static", "synchronous"])
@pytest.mark.parametrize(("speed_hz", "viscosity", "fraction"), COMMITTED_POINTS)
def test_the_committed_tables_one_sided_match_direct_solves_at_the_threshold(
    kind, speed_hz, viscosity, fraction
):
    """Off the Sommerfeld nodes, on and beside the threshold: K and C within 1 % of the largest entry. (Just
    above the threshold at the higher Sommerfeld number the direct flooded branch itself steps by several %
    within 1 % of q_t as the groove fills its neighbouring cells, which no table node spacing follows:
    docs/bearings.md.)"""
    table = OperatingTable.load(operating_table_path(MACHINE.source_path, kind))
    load = 3272.8248078061615
    mesh = Mesh(**table.metadata["mesh"])
    err = table_error(table, MACHINE.bearing, speed_hz, viscosity, load, fraction, mesh, one_sided=True)
    assert err.stiffness < 0.01 and err.damping < 0.01 and err.eccentricity_ratio < 0.005
