"""``oilwatch validate``, in-process: the published-table comparison and the table-vs-direct check print
their tables with the worst errors within the tolerances of the tests that hold the model to them."""

from __future__ import annotations

import re

import pytest

from oilwatch.cli import main


def run_cli(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_bearing_tables_on_one_mesh_print_the_worst_rows_within_the_published_tables_tolerance(
    capsys, tmp_path
):
    plot = tmp_path / "validation.png"
    code, out, _ = run_cli(capsys, "validate", "bearing-tables", "--mesh", "72x24", "--plot", str(plot))
    assert code == 0 and plot.stat().st_size > 10_000
    worst = re.findall(
        r"^\| (0\.5|1\.0) \| 72 x 24 \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) % .*\| ([\d.]+) % ", out, re.M
    )
    assert [row[0] for row in worst] == ["0.5", "1.0"]
    for _, eps, phi, k, b in worst:  # tests/test_published_bearing_tables.py's tolerances on 72 x 24
        assert float(eps) < 0.004 and float(phi) < 0.3 and float(k) < 2.5 and float(b) < 2.5
    ocvirk = re.findall(r"^\| (0\.\d+) \| (0\.\d) \| ([\d.]+) \|", out, re.M)
    assert len(ocvirk) == 12
    assert all(abs(float(ours) - float(eps)) < 0.015 for _, eps, ours in ocvirk)


@pytest.mark.slow
def test_bearing_map_quick_is_within_the_tables_one_percent(capsys):
    code, out, _ = run_cli(capsys, "validate", "bearing-map", "--quick")
    assert code == 0
    rows = re.findall(
        r"^\s+\d+\.\d\s+0\.\d+\s+[\d.]+\s+[\d.]+\s+[\d.]+\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)$", out, re.M
    )
    assert len(rows) == 4
    assert all(float(e) < 0.5 and float(k) < 1.0 and float(c) < 1.0 for e, k, c in rows)
    assert "against the 1-D" in out


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (("bearing-tables", "--mesh", "72by24"), "--mesh"),
        (("bearing-map", "--mesh", "72x24"), "--mesh"),
        (("bearing-tables", "--quick"), "--quick"),
    ],
)
def test_a_bad_option_is_one_line_with_exit_code_2(capsys, argv, named):
    code, out, err = run_cli(capsys, "validate", *argv)
    assert code == 2 and not out
    assert len(err.strip().splitlines()) == 1 and named in err
