"""estimates.csv rows formatted by the compiled writer (oilwatch.monitoring.csv_rows) read back as the
values, rounded to each column's decimals; a missing value is an empty cell; inf and values too large for the
digit loop are written exactly."""

from __future__ import annotations

import io

import numpy as np

from oilwatch.monitoring.csv_rows import RowWriter, format_rows


def _parse(text: str) -> np.ndarray:
    return np.array([[float(x) if x else np.nan for x in line.split(",")] for line in text.splitlines()])


def test_rows_read_back_as_the_values_rounded_to_each_column_s_decimals():
    rng = np.random.default_rng(4)
    rows = np.column_stack([
        np.round(rng.uniform(0, 3600, 500), 3),  # time
        rng.normal(596.3, 50.0, 500),  # a flowrate
        rng.normal(0.0, 1e-3, 500),  # a small signed value
        rng.integers(0, 2, 500).astype(float),  # a flag
        rng.normal(1.0, 0.01, 500),  # a dimensionless factor
    ])  # fmt: skip
    rows[::7, 2] = np.nan
    rows[3, 1], rows[4, 1], rows[5, 2] = np.inf, -np.inf, -0.0
    decimals = np.array([6, 6, 6, 0, 9])
    back = _parse(format_rows(rows, decimals))
    assert back.shape == rows.shape
    np.testing.assert_array_equal(np.isnan(back), np.isnan(rows))
    for j, d in enumerate(decimals):
        finite = np.isfinite(rows[:, j])
        np.testing.assert_allclose(back[finite, j], rows[finite, j], rtol=0, atol=0.5001 * 10.0**-d)
    assert back[3, 1] == np.inf and back[4, 1] == -np.inf
    text = format_rows(np.array([[1.0, 0.5, -2.0, 596.3]]), np.array([0, 6, 6, 6]))
    assert text == "1,0.5,-2,596.3\n"  # no trailing zeros, no bare point, flags as integers
    assert format_rows(np.array([[-1e-9]]), np.array([6])) == "0\n"  # rounds to zero: no "-0"


def test_a_value_too_large_for_the_digit_loop_is_written_exactly():
    rows = np.array([[1.0, 1e30], [2.0, 3.5]])
    np.testing.assert_array_equal(_parse(format_rows(rows, np.array([6, 6]))), rows)


def test_the_writer_keeps_every_nth_row_over_the_whole_run_and_copies_the_live_stream():
    file, live = io.StringIO(), io.StringIO()
    writer = RowWriter(file, live, every=3)
    writer.header(["time_s", "q"], np.array([3, 3]))
    for start in (0, 4, 5):  # blocks of 4, 1 and 5 rows
        n = {0: 4, 4: 1, 5: 5}[start]
        writer.write(np.column_stack([np.arange(start, start + n), np.zeros(n)]).astype(float))
    assert file.getvalue() == live.getvalue() == "time_s,q\n0,0\n3,0\n6,0\n9,0\n"
