"""``oilwatch demo``: the sudden drop of both supply flowrates at 1 um noise, with a pass/fail verdict."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .machine_option import add_machine_option, load_machine_option
from .run import add_fmu_dir_option

MAX_ERROR_AFTER_PCT = 2.0
MAX_ALARM_DELAY_S = 2.0


def register(subparsers) -> None:
    """Add the ``demo`` subcommand."""
    parser = subparsers.add_parser(
        "demo",
        help="the sudden-drop scenario at 1 um noise: verdict table and plot (builds the FMUs if needed)",
        description=(
            "Run 'oilwatch run sudden-drop --noise-um 1' (both supply flowrates 100 -> 75 % of the machine's "
            "nominal flowrate, 0.1 s transition centred at 10 s of 20 s), building the FMUs first if they "
            "are missing, and print a verdict per bearing: pass when the error over the last 2 s is under "
            f"{MAX_ERROR_AFTER_PCT:g} % and the starvation alarm comes within {MAX_ALARM_DELAY_S:g} s "
            "after the sigmoid's centre. Exit code 0 when both pass, 1 otherwise."
        ),
    )
    parser.add_argument("--out", default="demo", metavar="DIR", help="output folder (default: demo)")
    add_machine_option(parser)
    add_fmu_dir_option(parser)
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


def verdict_rows(summary: dict) -> list[tuple[int, float | None, float | None, float | None, bool]]:
    """(bearing, error before %, error after %, alarm delay s, passed) per bearing."""
    rows = []
    for b in (1, 2):
        after = summary[f"q{b}_err_pct_after"]
        delay = summary[f"alarm_delay_s_b{b}"]
        passed = (
            after is not None
            and after < MAX_ERROR_AFTER_PCT
            and delay is not None
            and 0.0 <= delay <= MAX_ALARM_DELAY_S
            and summary[f"false_alarm_s_b{b}"] is None
        )
        rows.append((b, summary[f"q{b}_err_pct_before"], after, delay, passed))
    return rows


def format_table(rows) -> list[str]:
    """The verdict table as text lines."""

    def cell(value, unit):
        return "n/a" if value is None else f"{value:.2f} {unit}"

    lines = [f"{'bearing':<8}{'error before':>14}{'error after':>13}{'alarm delay':>13}  verdict"]
    for b, before, after, delay, passed in rows:
        lines.append(
            f"{b:<8}{cell(before, '%'):>14}{cell(after, '%'):>13}{cell(delay, 's'):>13}  "
            f"{'pass' if passed else 'FAIL'}"
        )
    return lines


def run(args: argparse.Namespace) -> int:
    """Run the demo and print the verdict."""
    from oilwatch.cosim import SlaveError
    from oilwatch.scenarios import make_run

    from .run import execute

    machine = load_machine_option(args)
    settings = make_run("sudden-drop", machine=machine)
    out = Path(args.out)
    try:
        summary = execute(settings, out, args.fmu_dir, None, not args.no_progress, "demo", machine)
    except SlaveError as error:
        print(f"oilwatch demo: error: {error}", file=sys.stderr)
        return 2
    rows = verdict_rows(summary)
    (initial, final) = settings.q1_ml_min
    print(
        f"oilwatch demo: {machine.name}: sudden drop of both oil supply flowrates, {initial:.1f} -> "
        f"{final:.1f} ml/min (100 -> 75 %) centred at t = {settings.fault_time_s:g} s, measurement noise "
        f"{settings.noise_um:g} um"
    )
    print("\n".join(format_table(rows)))
    print(
        f"criteria: error over the last 2 s under {MAX_ERROR_AFTER_PCT:g} %, alarm within "
        f"{MAX_ALARM_DELAY_S:g} s after the centre, no false alarm before the drop"
    )
    print(f"real-time factor {summary['realtime_factor']:.2f}; plot: {Path(summary['plot']).resolve()}")
    return 0 if all(row[-1] for row in rows) else 1
