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
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Compute and print the comparison."""
    from models.system.reproduction import paper_comparison

    from .machine_option import ensure_flowrate_tables, load_machine_option

    machine = load_machine_option(args)
    ensure_flowrate_tables(machine, [machine.nominal_speed_hz], "report")
    result = paper_comparison(args.machine)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(format_report(result))
    return 0


def _number(value) -> str:
    return "n/a" if value is None else f"{value:10.2f}"


def _row(label: str, ours, paper) -> str:
    diff = "n/a" if ours is None else f"{100.0 * (ours / paper - 1.0):+.1f} %"
    return f"{label:48s}{_number(ours):>12s}{_number(paper):>12s}{diff:>12s}"


def format_report(result: dict) -> str:
    """The human-readable report."""
    mesh = result["mesh"]
    lines = [
        f"oilwatch vs the paper (speed {result['speed_hz']:g} Hz, film mesh {mesh['n_circ']} x "
        f"{mesh['n_axial']})",
        "",
        f"{'quantity':48s}{'oilwatch':>12s}{'paper':>12s}{'difference':>12s}",
    ]
    for key, label in ROWS:
        lines.append(_row(label, result[key], result["paper"][key]))
    for key, label in ROWS[3:]:
        alternative = f"  {label.removesuffix(' [Hz]')}, squeeze everywhere [Hz]"
        lines.append(_row(alternative, result["squeeze_everywhere"][key], result["paper"][key]))
    for name, title in (
        ("table4", "Table 4: q1 = q2 falling"),
        ("table5", "Table 5: q1 falling, q2 nominal"),
    ):
        lines += ["", f"{title}; variation per step [um], oilwatch (paper)"]
        lines.append(f"{'interval':10s}" + "".join(f"{label:>17s}" for _, label in COLUMNS))
        for ours, paper in zip(result[name], result["paper"][name], strict=True):
            cells = "".join(f"{ours[key]:>9.2f} ({paper[key]:5.2f})" for key, _ in COLUMNS)
            lines.append(f"{ours['interval_pct']:10s}{cells}")
    lines += ["", "definitions:"] + [f"  {key}: {text}" for key, text in result["definitions"].items()]
    return "\n".join(lines)
