"""What a person looks at: ``oilwatch --version``, ``--help``'s order, estimate's default output folder,
report.html's words for flags and never-flagged probes, and the scenario plot's reference lines."""

from __future__ import annotations

import re

import numpy as np
import pytest

from oilwatch.cli import SUBCOMMANDS, USER_COMMANDS, build_parser, main
from oilwatch.cli.estimate import output_folder_name


def test_version_prints_the_installed_version(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"oilwatch {version('oilwatch')}"


def test_help_lists_the_commands_a_user_runs_first():
    text = build_parser().format_help()
    listed = [name.replace("_", "-") for name in SUBCOMMANDS]
    positions = [re.search(rf"\n    {name}\b", text).start() for name in listed]
    assert positions == sorted(positions)
    assert listed[: len(USER_COMMANDS)] == ["estimate", "baseline", "demo", "run", "coast-down", "build-fmus"]


def test_two_records_of_one_name_get_two_output_folders(tmp_path):
    first, second = tmp_path / "a" / "result.csv", tmp_path / "b" / "result.csv"
    for path in (first, second):
        path.parent.mkdir()
        path.write_text("time_s,x1_um,y1_um,x2_um,y2_um\n")
    names = {output_folder_name(str(first)), output_folder_name(str(second))}
    assert len(names) == 2
    assert all(name.startswith("result-") and len(name) == len("result-") + 8 for name in names)
    assert output_folder_name(str(first)) == output_folder_name(str(first))  # the same record: one folder
    before = output_folder_name(str(first))
    first.write_text("time_s,x1_um,y1_um,x2_um,y2_um\n0,1,2,3,4\n")  # rewritten in place, another size
    assert output_folder_name(str(first)) != before
    assert output_folder_name("-") == "stdin"


def _report_summary(**changes) -> dict:
    """A summary.json as ``oilwatch estimate`` writes it, for report.html, with ``changes`` applied."""
    record = {"source": "r.csv", "format": "csv", "rows": 10, "sample_rate_hz": 1000.0,
              "estimator_rate_hz": 1000.0, "anti_alias_taps": 0, "keyphasor_pulses": 0, "time_shift_s": 0.0,
              "speed_source": "nominal", "gap_count": 0, "missing_samples": 0}  # fmt: skip
    summary = {
        "record": record, "q1_nominal_ml_min": 596.3, "q2_nominal_ml_min": 596.3,
        "verdict": {"bearing1": "healthy", "bearing2": "starved"},
        "q1_final_ml_min": 596.0, "q2_final_ml_min": 447.0, "q1_std_final_ml_min": 2.0,
        "q2_std_final_ml_min": 2.0, "duration_s": 1.0, "final_window_s": 0.1, "machine_file": "turbine",
        "estimator": {"model": "grid", "offset_prior_std_um": 0.0}, "realtime_factor": 10.0,
        "alarms": [], "probes": {},
    }  # fmt: skip
    return {**summary, **changes}


def test_report_says_yes_no_and_never_instead_of_python_values(tmp_path):
    from oilwatch.monitoring.report import write_report

    probes = {name: {"offset_um": 0.0, "offset_std_um": 0.0, "status_final": "ok", "flagged_s": 0.0}
              for name in ("x1", "y1", "x2")}  # fmt: skip
    probes["y2"] = {"offset_um": 0.0, "offset_std_um": 0.0, "status_final": "dead", "flagged_s": 0.5}
    alarms = [
        {"bearing": 2, "time_s": 0.4, "consistent": True},
        {"bearing": 2, "time_s": 0.9, "consistent": False},
    ]
    page = write_report(_report_summary(alarms=alarms, probes=probes), tmp_path).read_text()
    shown = page.split("<h2>Summary</h2>")[0]  # summary.json's own dump follows, folded away
    assert "True" not in shown and "False" not in shown
    assert "<td>yes</td>" in page and "<td>no</td>" in page
    assert page.count("<td>never</td>") == 3 and "<td>0.500</td>" in page and "0.000</td>" not in page


def test_report_gives_each_bearing_its_own_nominal_flowrate(tmp_path):
    """A machine whose bearings differ (tests/test_second_machine.py's, 1786.9 / 1678.5 ml/min): each row
    shows its bearing's nominal beside its percentage; no sentence gives one bearing's as the machine's."""
    from oilwatch.monitoring.report import write_report

    summary = _report_summary(
        q1_nominal_ml_min=1786.9, q2_nominal_ml_min=1678.5, q1_final_ml_min=1786.9, q2_final_ml_min=1342.8
    )
    shown = write_report(summary, tmp_path).read_text().split("<h2>Summary</h2>")[0]
    for b, nominal, pct in ((1, "1786.9", "100.00"), (2, "1678.5", "80.00")):
        row = re.search(rf"<tr><th>bearing {b}</th>.*?</tr>", shown).group(0)
        assert f"<td>{nominal}</td><td>{pct}</td>" in row
        assert shown.count(nominal) == 1 + (b == 1)  # its row (bearing 1's flowrate is its nominal too)


def test_the_scenario_plot_draws_the_nominal_and_the_alarm_threshold(tmp_path, monkeypatch):
    import matplotlib.axes

    from oilwatch.scenarios import make_run
    from oilwatch.scenarios.plot import plot_estimates

    run = make_run("sudden-drop", noise_um=1.0, duration_s=2.0, seed=1)
    time_s = np.arange(0.0, 2.0, 1e-3)
    columns = {"time_s": time_s}
    for b in (1, 2):
        flat = np.full_like(time_s, 500.0)
        columns |= {f"q{b}_true_ml_min": flat, f"q{b}_est_ml_min": flat}
        columns |= {f"q{b}_std_ml_min": np.ones_like(flat), f"starved{b}": np.zeros_like(flat)}
    lines = []
    original = matplotlib.axes.Axes.axhline

    def record(self, y=0, *args, **kwargs):
        lines.append((y, kwargs.get("label")))
        return original(self, y, *args, **kwargs)

    monkeypatch.setattr(matplotlib.axes.Axes, "axhline", record)
    plot_estimates(run, columns, {}, tmp_path / "estimates.png")
    for nominal in run.nominal_ml_min:
        assert (nominal, f"nominal {nominal:.1f}") in lines
        assert (0.9 * nominal, "alarm set (90 % of nominal)") in lines
    assert (tmp_path / "estimates.png").stat().st_size > 0
