"""``oilwatch report``: the paper's model figures and oilwatch's, side by side."""

from __future__ import annotations

import argparse
import json

from .machine_option import add_machine_option

ROWS = (
    ("rotor_weight_n", "rotor weight [N]"),
    ("flooded_threshold_ml_min", "flooded threshold q_t [ml/min]"),
    ("nominal_flow_ml_min", "flow at 0.5 bar [ml/min]"),
    ("first_critical_hz", "first critical speed [Hz]"),
    ("instability_threshold_hz", "instability threshold [Hz]"),
)
COLUMNS = (
    ("ecc_var_um_b1", "ecc b1"),
    ("ecc_var_um_b2", "ecc b2"),
    ("amp_x_var_um_b1", "amp x b1"),
    ("amp_x_var_um_b2", "amp x b2"),
    ("amp_y_var_um_b1", "amp y b1"),
    ("amp_y_var_um_b2", "amp y b2"),
)


def register(subparsers) -> None:
    """Add the ``report`` subcommand."""
    parser = subparsers.add_parser(
        "report",
        help="the paper's model figures and ours side by side (weight, flows, speeds, Tables 4-5)",
        description=(
            "Recompute the paper's model figures with oilwatch's rotor, bearing tables and speed sweep, and "
            "print them beside the paper's: ours | paper | difference."
        ),
    )
    add_machine_option(parser)
    parser.add_argument("--json", action="store_true", help="print JSON on stdout")
    parser.add_argument(
        "--readme",
        action="append",
        default=[],
        metavar="FILE",
        help=(
            "also write the comparison as Markdown into FILE's generated blocks 'report-summary' and/or "
            "'report-tables' (<!-- generated NAME: ... --> ... <!-- /generated NAME -->); repeatable"
        ),
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Compute and print the comparison."""
    from oilwatch.models.system.reproduction import paper_comparison

    from .machine_option import ensure_flowrate_tables, load_machine_option

    machine = load_machine_option(args)
    ensure_flowrate_tables(machine, [machine.nominal_speed_hz], "report")
    result = paper_comparison(args.machine)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(format_report(result))
    if args.readme:
        from .readme_block import replace_blocks

        blocks = {"report-summary": markdown_summary(result), "report-tables": markdown_tables(result)}
        machine_flag = [] if args.machine is None else [f"--machine {args.machine}"]
        for readme in args.readme:
            command = " ".join(["oilwatch report", *machine_flag, f"--readme {readme}"])
            replace_blocks(readme, blocks, command)
    return 0


def _summary_rows(result: dict) -> list[tuple[str, float | None, float]]:
    """(label, oilwatch, paper) of the model figures, the machine's coefficient kind first."""
    paper = result["paper"]
    kind = result.get("coefficients", "quasi-static")
    rows = []
    for key, label in ROWS:
        if key == "instability_threshold_hz" and kind != "quasi-static":
            label = "instability threshold, frequency-dependent roots [Hz]"
        rows.append((label, result[key], paper[key]))
    threshold = paper["instability_threshold_hz"]
    rows.append(("instability threshold, direct simulation on transient films [Hz]",
                 result["instability_threshold_direct_hz"], threshold))  # fmt: skip
    if kind != "quasi-static":
        rows.append(("instability threshold, quasi-static frozen content [Hz]",
                     result["instability_threshold_quasi_static_hz"], threshold))  # fmt: skip
    for key, label in ROWS[3:]:
        rows.append((f"{label.removesuffix(' [Hz]')}, quasi-static squeeze everywhere [Hz]",
                     result["squeeze_everywhere"][key], paper[key]))  # fmt: skip
    return rows


def _difference(ours, paper) -> str:
    return "n/a" if ours is None else f"{100.0 * (ours / paper - 1.0):+.1f} %"


def markdown_summary(result: dict) -> str:
    """The model figures as a Markdown table: quantity | oilwatch | paper | difference."""
    lines = ["| quantity | oilwatch | paper | difference |", "|---|---|---|---|"]
    for label, ours, paper in _summary_rows(result):
        value = "n/a" if ours is None else f"{ours:.2f}"
        lines.append(f"| {label} | {value} | {paper:.2f} | {_difference(ours, paper)} |")
    return "\n".join(lines)


def markdown_tables(result: dict) -> str:
    """Tables 4 and 5 (the machine's coefficient kind) as Markdown: oilwatch's variation per step, the
    paper's in brackets."""
    kind = result.get("coefficients", "quasi-static")
    out = []
    for name, title in (
        ("table4", f"Table 4: q1 = q2 falling ({kind} coefficients)"),
        ("table5", f"Table 5: q1 falling, q2 nominal ({kind} coefficients)"),
    ):
        out += [f"**{title}**, variation per 5 % step [um], oilwatch (paper):", ""]
        out.append("| step [%] | " + " | ".join(label for _, label in COLUMNS) + " |")
        out.append("|---" * (len(COLUMNS) + 1) + "|")
        for ours, paper in zip(result[name], result["paper"][name], strict=True):
            cells = " | ".join(f"{_two(ours[key])} ({paper[key]:.2f})" for key, _ in COLUMNS)
            out.append(f"| {ours['interval_pct']} | {cells} |")
        out.append("")
    return "\n".join(out).rstrip()


def _number(value) -> str:
    return "n/a" if value is None else f"{value:10.2f}"


def _two(value: float) -> str:
    """Two decimals, a value that rounds to zero without a sign: a step that moves nothing in theory moves
    1e-15 um either way by round-off, whose sign depends on the machine's floating-point paths."""
    return f"{round(value, 2) + 0.0:.2f}"


def _row(label: str, ours, paper) -> str:
    diff = "n/a" if ours is None else f"{100.0 * (ours / paper - 1.0):+.1f} %"
    return f"{label:60s}{_number(ours):>12s}{_number(paper):>12s}{diff:>12s}"


def format_report(result: dict) -> str:
    """The human-readable report."""
    mesh = result["mesh"]
    lines = [
        f"oilwatch vs the paper (speed {result['speed_hz']:g} Hz, film mesh {mesh['n_circ']} x "
        f"{mesh['n_axial']})",
        "",
        f"{'quantity':60s}{'oilwatch':>12s}{'paper':>12s}{'difference':>12s}",
    ]
    kind = result.get("coefficients", "quasi-static")
    for key, label in ROWS:
        if key == "instability_threshold_hz" and kind != "quasi-static":
            label = "instability threshold, frequency-dependent roots [Hz]"
        lines.append(_row(label, result[key], result["paper"][key]))
    if kind != "quasi-static":
        lines.append(
            _row(
                "  threshold, quasi-static frozen content [Hz]",
                result["instability_threshold_quasi_static_hz"],
                result["paper"]["instability_threshold_hz"],
            )
        )
    for key, label in ROWS[3:]:
        alternative = f"  {label.removesuffix(' [Hz]')}, quasi-static squeeze everywhere [Hz]"
        lines.append(_row(alternative, result["squeeze_everywhere"][key], result["paper"][key]))
    lines += _transient_lines(result)
    for name, title in (
        ("table4", f"Table 4: q1 = q2 falling, {kind} coefficients"),
        ("table5", f"Table 5: q1 falling, q2 nominal, {kind} coefficients"),
        ("table4_quasi_static", "Table 4 with the quasi-static (frozen-content) coefficients"),
        ("table5_quasi_static", "Table 5 with the quasi-static (frozen-content) coefficients"),
        ("table4_frequency_dependent", "Table 4 with the synchronous (frequency-dependent) coefficients"),
        ("table5_frequency_dependent", "Table 5 with the synchronous (frequency-dependent) coefficients"),
    ):
        if name in result:
            lines += _table_lines(title, result[name], result["paper"][name.split("_")[0]])
    lines += ["", "definitions:"] + [f"  {key}: {text}" for key, text in result["definitions"].items()]
    return "\n".join(lines)


def _table_lines(title: str, rows: list[dict], paper_rows: list[dict]) -> list[str]:
    """One of Tables 4-5, ours with the paper's in brackets."""
    lines = ["", f"{title}; variation per step [um], oilwatch (paper)"]
    lines.append(f"{'interval':10s}" + "".join(f"{label:>17s}" for _, label in COLUMNS))
    for ours, paper in zip(rows, paper_rows, strict=True):
        cells = "".join(f"{_two(ours[key]):>9s} ({paper[key]:5.2f})" for key, _ in COLUMNS)
        lines.append(f"{ours['interval_pct']:10s}{cells}")
    return lines


def _transient_lines(result: dict) -> list[str]:
    """Thresholds and the orbit check from the transient-film results file."""
    paper = result["paper"]["instability_threshold_hz"]
    mesh = result.get("direct_simulation_mesh")
    where = f" on the film mesh {mesh['n_circ']} x {mesh['n_axial']}" if mesh else ""
    lines = [
        _row("  threshold, direct simulation [Hz]", result["instability_threshold_direct_hz"], paper),
        _row(
            "  threshold, frequency-dependent linear [Hz]",
            result["instability_threshold_frequency_dependent_hz"],
            paper,
        ),
    ]
    bracket = result.get("instability_threshold_direct_bracket_hz")
    if bracket:
        lines.append(
            f"    direct simulation{where}: whirl decays at {bracket[0]:g} Hz, grows at {bracket[1]:g} Hz"
        )
    for key, value in result.get("frequency_dependent_thresholds_by_mesh_hz", {}).items():
        lines.append(f"    frequency-dependent linear threshold on mesh {key}: {value:.2f} Hz")
    check = result.get("orbit_check")
    if check:
        lines += ["", "75 Hz 1x orbits, linear model vs nonlinear transient films (max over x1, y1, x2, y2)"]
        for pct, models in check.items():
            cells = ", ".join(
                f"{name} {m['max_amplitude_error_pct']:.1f} % / {m['max_phase_error_deg']:.1f} deg"
                for name, m in models.items()
                if name != "settling_pct"
            )
            lines.append(f"  {pct} % flow: {cells}")
    drop = result.get("starvation")
    if drop:
        lines.append(
            f"sudden drop {drop['from_ml_min']:.0f} -> {drop['to_ml_min']:.0f} ml/min, settling (98 %): film "
            f"content {drop['settling_time_content_s'] * 1e3:.0f} ms, side leakage "
            f"{drop['settling_time_leakage_s'] * 1e3:.0f} ms, mean journal position "
            f"{drop['settling_time_mean_position_s'] * 1e3:.0f} ms"
        )
    return lines
