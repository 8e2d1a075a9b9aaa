"""The rotor subcommands, in-process: JSON schema, readable output, plots and error exits."""

from __future__ import annotations

import json

import pytest

from oilwatch.cli import main
from oilwatch.models.machine import BUNDLED_MACHINE


def run_cli(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_modes_json_schema(capsys):
    code, out, _ = run_cli(
        capsys, "modes", "--speed-hz", "75", "--bearing-k", "1e8", "--bearing-c", "1e4", "--json"
    )
    assert code == 0
    data = json.loads(out)
    assert data["speed_hz"] == 75.0
    modes = data["modes"]
    assert len(modes) >= 8
    frequencies = [m["frequency_hz"] for m in modes]
    assert frequencies == sorted(frequencies) and frequencies[0] > 0
    for mode in modes:
        assert {"frequency_hz", "log_decrement", "whirl"} <= set(mode)
        assert mode["whirl"] in ("forward", "backward")
        assert isinstance(mode["log_decrement"], float)
    # Gyroscopic splitting at 75 Hz: the first pair is backward then forward.
    assert [m["whirl"] for m in modes[:2]] == ["backward", "forward"]


def test_modes_table(capsys):
    code, out, _ = run_cli(capsys, "modes", "--speed-hz", "75", "--bearing-k", "1e8")
    assert code == 0
    assert "log decrement" in out and "forward" in out
    assert len([line for line in out.splitlines() if line.strip()[:1].isdigit()]) == 8


def test_campbell_plot_and_json(capsys, tmp_path):
    png = tmp_path / "campbell.png"
    code, out, _ = run_cli(capsys, "campbell", "--speed-max-hz", "120", "--n-speeds", "13", "--out", str(png))
    assert code == 0 and png.stat().st_size > 10_000
    assert "critical speeds" in out
    code, out, _ = run_cli(
        capsys,
        "campbell",
        "--speed-max-hz",
        "120",
        "--n-speeds",
        "5",
        "--out",
        str(tmp_path / "c.svg"),
        "--json",
    )
    data = json.loads(out)
    assert len(data["speeds_hz"]) == 5 and data["speeds_hz"][-1] == 120.0
    assert len(data["frequencies_hz"][0]) == 8 and len(data["whirl"][0]) == 8
    assert all(40 < c < 60 for c in data["critical_speeds_hz"])


def test_rotor_summary(capsys):
    code, out, _ = run_cli(capsys, "rotor")
    assert code == 0
    assert "6545.6 N" in out and "667.24 kg" in out and "3539.8 g mm" in out
    code, out, _ = run_cli(capsys, "rotor", "--json")
    data = json.loads(out)
    assert data["weight_n"] == pytest.approx(6545.6, abs=0.5)
    assert len(data["nodes"]) == 21 and len(data["discs"]) == 3


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["modes", "--speed-hz", "-1"], "--speed-hz must be >= 0"),
        (["modes", "--bearing-k", "-5"], "--bearing-k must be >= 0"),
        (["modes", "--n-modes", "0"], "--n-modes"),
        (["campbell", "--speed-max-hz", "-10"], "--speed-max-hz"),
        (["campbell", "--speed-min-hz", "50", "--speed-max-hz", "40"], "must exceed"),
        (["rotor", "--machine", "/nonexistent/machine.toml"], "cannot read machine file"),
    ],
)
def test_bad_input_exits_2_with_one_line(capsys, argv, message):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2 and out == ""
    assert message in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("30.0, 60.0, 30.0, 45.0,", "30.0, 60.0, 30.0, -45.0,", "element_length_mm[3] must be > 0"),
        ("node = 13\nphase_deg", "node = 99\nphase_deg", "unbalance.node = 99 is not a node"),
    ],
)
def test_bad_machine_file_exits_2(capsys, tmp_path, old, new, message):
    text = BUNDLED_MACHINE.read_text()
    assert old in text
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, new, 1))
    for command in ("rotor", "modes", "campbell"):
        code, _, err = run_cli(capsys, command, "--machine", str(path))
        assert code == 2 and message in err
