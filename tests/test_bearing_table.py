"""The committed coefficient table: reproducible rows, interpolation, file format, range errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from oilwatch.models.bearing.equilibrium import coefficients_at, static_equilibrium
from oilwatch.models.bearing.geometry import JournalBearing
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.bearing.table import CoefficientTable
from oilwatch.models.validation import InputError

COMMITTED = Path(__file__).resolve().parents[1] / "models" / "tables" / "turbine_bearing_75hz.json"


@pytest.fixture(scope="module")
def table() -> CoefficientTable:
    return CoefficientTable.load(COMMITTED)


def test_committed_table_spans_half_to_one_and_a_half_q_t(table):
    q_t = table.metadata["flooded_threshold_m3_s"]
    low, high = table.flowrate_range_m3_s
    assert low == pytest.approx(0.5 * q_t, rel=1e-9)
    assert high == pytest.approx(1.5 * q_t, rel=1e-9)
    assert table.speed_hz == 75.0
    assert table.regimes[0] == "starved" and table.regimes[-1] == "flooded"
    # Starvation moves the journal out: the eccentricity falls as the supply rises to q_t.
    below = table.flowrates_m3_s <= q_t * (1 + 1e-9)
    assert np.all(np.diff(table.eccentricity_ratio[below]) < 0.0)
    assert {"oilwatch_version", "command_line", "date_utc"} <= set(table.metadata["provenance"])


def test_a_row_of_the_committed_table_is_reproduced(table):
    meta = table.metadata
    bearing = JournalBearing(**meta["bearing"])
    mesh = Mesh(**meta["mesh"])
    row = table.rows[1]
    supply = SupplyFlow(row["supply_flowrate_m3_s"])
    eq = static_equilibrium(bearing, table.load_n, table.speed_hz, supply, mesh)
    stiffness, damping = coefficients_at(bearing, eq, table.speed_hz, supply, mesh)
    np.testing.assert_allclose(
        eq.eccentricity_m, [row["eccentricity_x_m"], row["eccentricity_y_m"]], rtol=1e-6
    )
    assert eq.regime == row["regime"]
    np.testing.assert_allclose(stiffness, table.stiffness[1], rtol=1e-4)
    np.testing.assert_allclose(damping, table.damping[1], rtol=1e-4)


def test_interpolation_reproduces_the_nodes(table):
    for k, q in enumerate(table.flowrates_m3_s):
        c = table.evaluate(q)
        np.testing.assert_allclose(c.eccentricity_m, table.eccentricity_m[k], rtol=1e-12)
        np.testing.assert_allclose(c.stiffness, table.stiffness[k], rtol=1e-12)
        np.testing.assert_allclose(c.damping, table.damping[k], rtol=1e-12)


def test_derivative_matches_finite_differences(table):
    low, high = table.flowrate_range_m3_s
    h = 1e-6 * (high - low)
    for q in np.linspace(low, high, 23)[1:-1]:
        value, slope = table.evaluate_with_derivative(q)
        up, down = table.evaluate(q + h), table.evaluate(q - h)
        for name in ("eccentricity_m", "stiffness", "damping"):
            fd = (getattr(up, name) - getattr(down, name)) / (2 * h)
            scale = np.abs(getattr(value, name)).max() / (high - low)
            np.testing.assert_allclose(getattr(slope, name), fd, atol=1e-5 * scale)
        np.testing.assert_allclose(value.stiffness, table.evaluate(q).stiffness, rtol=1e-14)


def test_outside_the_range_is_an_input_error_naming_q_and_the_range(table):
    low, high = table.flowrate_range_m3_s
    for q in (0.99 * low, 1.01 * high):
        with pytest.raises(InputError, match=r"q = .* ml/min .* outside the table range \["):
            table.evaluate(q)
        with pytest.raises(InputError, match="outside the table range"):
            table.evaluate_with_derivative(q)
        with pytest.raises(InputError, match="outside the table range"):
            table.evaluate_many(np.array([low, q, high]))
    with pytest.raises(InputError, match="outside the table range"):
        table.evaluate_many(np.array([low, np.nan]))


def test_vectorized_evaluation_equals_the_scalar_one_at_nodes_and_between(table):
    low, high = table.flowrate_range_m3_s
    flowrates = np.concatenate([table.flowrates_m3_s, np.linspace(low, high, 37)])
    rows = table.evaluate_many(flowrates)
    for q, row in zip(flowrates, rows, strict=True):
        c = table.evaluate(q)
        expected = np.concatenate([c.eccentricity_m, c.stiffness.ravel(), c.damping.ravel()])
        np.testing.assert_allclose(row, expected, rtol=1e-14, atol=0.0)


def test_save_and_load_round_trip(table, tmp_path):
    path = tmp_path / "t.json"
    table.save(path)
    again = CoefficientTable.load(path)
    np.testing.assert_array_equal(again.stiffness, table.stiffness)
    assert again.metadata == table.metadata
    q = 0.3 * sum(table.flowrate_range_m3_s)
    np.testing.assert_array_equal(again.evaluate(q).damping, table.evaluate(q).damping)


def test_bad_table_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        CoefficientTable.load(tmp_path / "missing.json")
    (tmp_path / "x.json").write_text('{"format": "something else"}')
    with pytest.raises(InputError, match="is not an oilwatch bearing coefficient table"):
        CoefficientTable.load(tmp_path / "x.json")


def test_pchip_coefficients_are_scipys_to_the_last_bit():
    """The table computes its interpolant without scipy.interpolate (an FMU's start-up); it must be scipy's
    PCHIP exactly: interior nodes with slopes of either sign, a zero slope, a sign change at an end, and the
    two-node case."""
    from scipy.interpolate import PchipInterpolator

    from oilwatch.models.bearing.table import pchip_coefficients

    rng = np.random.default_rng(7)
    for n in (2, 3, 5, 7, 13):
        x = np.sort(rng.uniform(0.0, 3.0, n)) + np.arange(n)
        y = rng.normal(size=(n, 6))
        y[:, 0] = np.cumsum(np.abs(y[:, 0]))  # monotone
        y[:, 1] = y[0, 1]  # flat
        if n > 2:
            y[1, 2] = y[0, 2]  # one zero slope
            y[:, 3] = [(-1.0) ** k for k in range(n)]  # a sign change at every node
        expected = PchipInterpolator(x, y, axis=0).c
        assert np.array_equal(pchip_coefficients(x, y), expected), n
