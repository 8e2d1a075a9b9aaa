"""``oilwatch study``: the constant-flowrate identification study (Table 6, Figs. 7-8) on Dask."""

from __future__ import annotations

import argparse
import json
import sys

from oilwatch.experiment_config import StudyConfig

from .config_options import add_config_options
from .machine_option import add_machine_option


def register(subparsers) -> None:
    """Add the ``study`` subcommand."""
    parser = subparsers.add_parser(
        "study",
        help="identification accuracy over the (q1, q2) grid on Dask: Table 6, Figs. 7-8, Cramer-Rao bound",
        description=(
            "Identify constant supply flowrates q1, q2 from 100 % down to 75 % of each bearing's nominal "
            "flowrate (--machine; default: the bundled turbine) on a grid, one Dask task per case, and "
            "compare the errors with the paper's Table 6 and the Cramer-Rao bound. Each finished case is "
            "appended to DIR/cases.csv at once; run the same command again to continue a stopped study. "
            "Writes DIR/summary.json and "
            "DIR/error_map_sigma<N>.png. Exit code 1 when some cases kept failing (listed in the "
            "summary), 2 on bad input."
        ),
    )
    add_config_options(parser, StudyConfig, ("noise_um", "grid_step_pct", "seeds", "duration_s", "discard_s"))
    parser.add_argument(
        "--out", default="study_out", metavar="DIR", help="output folder (default: study_out)"
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="an existing Dask cluster's scheduler, e.g. tcp://HOST:8786 (default: a local cluster)",
    )
    parser.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="worker processes of the local cluster (default: one per core)",
    )
    parser.add_argument(
        "--case",
        default="cosim",
        metavar="NAME",
        help="case model: cosim (plant + EKF FMUs through the master), direct (the same models "
        "in-process, no FMI), direct-nuisances (direct with the probe offsets and the unbalance unknown "
        "estimator states) or synthetic (machinery test) (default: cosim)",
    )
    parser.add_argument(
        "--fmu-dir",
        metavar="DIR",
        help="with --case cosim: folder of RotorBearingPlant.fmu and OilFlowEKF.fmu ('python build.py --out "
        "DIR'); it must be at the same path on every worker (default: built automatically)",
    )
    add_config_options(parser, StudyConfig, ("retries",))
    parser.add_argument("--max-cases", type=int, metavar="N", help="stop after N new cases (run in slices)")
    parser.add_argument("--json", action="store_true", help="print summary.json on stdout")
    add_machine_option(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run (or continue) the study and print its Table 6."""
    from oilwatch.models.validation import InputError
    from oilwatch.study import get_case_model, make_cases, run_study
    from oilwatch.study.runner import check_cluster_options

    from .machine_option import ensure_flowrate_tables, load_machine_option

    check_cluster_options(args.scheduler, args.workers)
    if args.max_cases is not None and args.max_cases < 1:
        raise InputError(f"--max-cases must be >= 1, got {args.max_cases}")
    machine = load_machine_option(args)
    if args.case != "synthetic":
        ensure_flowrate_tables(machine, [machine.nominal_speed_hz], "study")
    model = get_case_model(args.case, args.fmu_dir)
    cases = make_cases(
        args.noise_um, args.grid_step_pct, args.seeds, args.duration_s, args.discard_s, machine
    )
    outcome = run_study(
        cases,
        args.out,
        model,
        args.case,
        scheduler=args.scheduler,
        workers=args.workers,
        retries=args.retries,
        max_cases=args.max_cases,
        progress=True,
    )
    if args.json:
        print(json.dumps(outcome.summary, indent=1))
    else:
        print(format_summary(outcome.summary))
        print(f"\nfiles: {outcome.out_dir / 'cases.csv'}, {outcome.out_dir / 'summary.json'}")
        for path in outcome.maps:
            print(f"       {path}")
    if outcome.failed:
        print(
            f"oilwatch study: {len(outcome.failed)} case(s) kept failing; see failed_cases in summary.json "
            "(run the command again to retry them)",
            file=sys.stderr,
        )
        return 1
    return 0


def _cell(value, fmt: str = ".2f") -> str:
    return "-" if value is None else format(value, fmt)


def format_summary(summary: dict) -> str:
    """Table 6, ours beside the paper's, with the accuracy targets."""
    settings = summary["settings"]
    lines = [
        f"identification study: case model {settings['case_model']}, {settings['n_cases']} cases, "
        f"records {settings['duration_s']:g} s (first {settings['discard_s']:g} s discarded)",
        f"errors: {summary['aggregation']}",
        "",
        f"{'noise':>6s} {'cases':>9s} {'mean %':>14s} {'std %':>14s} {'max %':>14s} {'target':>14s} "
        f"{'CRLB ratio':>11s}  worst case",
        f"{'[um]':>6s} {'':>9s} {'ours (paper)':>14s} {'ours (paper)':>14s} {'ours (paper)':>14s} "
        f"{'mean/max':>14s}",
    ]
    for level in summary["noise_levels"]:
        paper = level["paper"] or {}
        target = level["target"]
        target_text = "-"
        if target is not None:
            verdict = {True: "pass", False: "FAIL", None: "-"}[target["pass"]]
            target_text = f"{target['mean_err_pct']:g}/{target['max_err_pct']:g} {verdict}"
        worst = level["worst_case"]
        worst_text = (
            "-" if worst is None else f"{worst['case_id']} (q{worst['bearing']}: {worst['err_pct']:+.2f} %)"
        )
        columns = [
            f"{_cell(level[key])} ({_cell(paper.get(key))})"
            for key in ("mean_err_pct", "std_err_pct", "max_err_pct")
        ]
        lines.append(
            f"{level['noise_um']:>6g} {level['n_cases']:>4d}/{level['n_expected']:<4d} "
            + " ".join(f"{column:>14s}" for column in columns)
            + f" {target_text:>14s} {_cell(level['mean_crlb_ratio']):>11s}  {worst_text}"
        )
    if summary["failed_cases"]:
        lines.append(f"\nfailed cases: {', '.join(item['case_id'] for item in summary['failed_cases'])}")
    return "\n".join(lines)
