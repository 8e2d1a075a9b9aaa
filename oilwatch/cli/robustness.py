"""``oilwatch robustness``: the estimator against the plant with each machine-vs-model discrepancy."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path


def register(subparsers) -> None:
    """Add the ``robustness`` subcommand."""
    from .machine_option import add_machine_option

    parser = subparsers.add_parser(
        "robustness",
        help="run the plant with each machine-vs-model discrepancy against the estimator",
        description=(
            "For each discrepancy (probe offsets, unbalance size and phase, viscosity, speed and temperature "
            "ramps, runout, sensitivity, probe mounting angle, probe faults; and the model-structure ones: "
            "film model, bearing clearance and length, unbalance over several discs, flexible pedestals, "
            "load split, a side force, runout without a slow-roll record, a bent shaft, all at once) and "
            "truth point (100/100 and 80/90 % of nominal), simulate the plant with it (its measurement "
            "chain, unbalance, film, structure and operating point), run the estimator and print the errors "
            "beside the filter's own stds, false alarms, detections, flagged probes and the error over the "
            "nuisance Cramer-Rao bound. Writes DIR/robustness.json (row by row) and DIR/robustness.md."
        ),
    )
    add_machine_option(parser)
    parser.add_argument("--duration-s", type=float, default=60.0, help="record length [s] (default: 60)")
    parser.add_argument("--noise-um", type=float, default=1.0, help="probe noise std [um] (default: 1)")
    parser.add_argument("--seed", type=int, default=1, help="noise seed (default: 1)")
    parser.add_argument(
        "--offset-prior-um",
        type=float,
        default=None,
        help="prior std of the estimator's probe-offset states [um]; 0: offsets assumed zero (default: the "
        "machine file's [probes] offset_prior_std_um, 25)",
    )
    parser.add_argument(
        "--unbalance-prior",
        type=float,
        default=2.0,
        help="prior std of the estimator's complex unbalance state, relative to the machine file's; "
        "0: the machine file's unbalance taken as exact (default: 2)",
    )
    parser.add_argument(
        "--viscosity-prior",
        type=float,
        default=0.1,
        help="prior std of the estimator's viscosity factor per bearing, in the cases that change the film "
        "or the operating point (needs an estimator that follows them; default: 0.1)",
    )
    parser.add_argument(
        "--cases", nargs="+", default=None, metavar="NAME", help="cases to run (default: all)"
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="worker processes, one case at a time each (default: one per core)",
    )
    parser.add_argument(
        "--out", default="robustness", metavar="DIR", help="output folder (default: robustness)"
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="keep the rows DIR/robustness.json already holds from a run with the same settings and run only "
        "the others (a stopped run continues)",
    )
    parser.add_argument(
        "--from-json",
        nargs="+",
        default=None,
        metavar="FILE",
        help="make the table from earlier robustness.json files instead of running (a later file's row "
        "replaces an earlier one of the same case and point)",
    )
    parser.add_argument(
        "--readme",
        default=None,
        metavar="FILE",
        help="also write the table into FILE between <!-- generated BLOCK: ... --> and "
        "<!-- /generated BLOCK -->",
    )
    parser.add_argument(
        "--block",
        default="robustness",
        metavar="BLOCK",
        help="the name of the --readme block (default: robustness; another name for a second table on "
        "the page)",
    )
    parser.set_defaults(func=run)


def _rows_from_json(paths) -> list[dict]:
    import json

    from oilwatch.models.validation import InputError

    rows: dict[tuple, dict] = {}
    for path in paths:
        try:
            document = json.loads(Path(path).read_text())
            found = document["rows"]
        except (OSError, ValueError, KeyError, TypeError) as error:
            raise InputError(f"--from-json {path}: not a robustness.json ({error})") from None
        from oilwatch.robustness.report_table import with_case_bounds

        settings = document.get("settings") if isinstance(document, dict) else None
        # the bound of each row's own configuration (a file without its run's settings keeps its own)
        for row in found if settings is None else with_case_bounds(found, settings):
            rows[(row["case"], row["q1_pct"], row["q2_pct"])] = row
    from oilwatch.robustness import CASES

    rank = {case.name: k for k, case in enumerate(CASES)}  # the cases' order, whichever file a row came from
    return sorted(rows.values(), key=lambda r: (rank.get(r["case"], len(rank)), -r["q1_pct"]))


def run(args: argparse.Namespace) -> int:
    from oilwatch.models.validation import InputError, require_in_range
    from oilwatch.outputs.lock import output_lock
    from oilwatch.robustness import CASES, case_by_name, format_table

    from .readme_block import replace_block

    command = "oilwatch robustness " + " ".join(sys.argv[2:]) if sys.argv[1:2] == ["robustness"] else ""
    if args.from_json is not None:
        table = "\n".join(format_table(_rows_from_json(args.from_json)))
        print(table)
        if args.readme is not None:
            replace_block(args.readme, args.block, table, command or "oilwatch robustness --from-json")
        return 0

    require_in_range("--duration-s", args.duration_s, 1.0, 3600.0, "s")
    require_in_range("--noise-um", args.noise_um, 0.01, 100.0, "um")
    if args.offset_prior_um is None:
        from oilwatch.models.machine import load_machine
        from oilwatch.models.probes import read_probes

        args.offset_prior_um = read_probes(load_machine(args.machine)).offset_prior_std_m * 1e6
    require_in_range("--offset-prior-um", args.offset_prior_um, 0.0, 1000.0, "um")
    require_in_range("--unbalance-prior", args.unbalance_prior, 0.0, 100.0)
    require_in_range("--viscosity-prior", args.viscosity_prior, 0.0, 0.5)
    workers = (os.cpu_count() or 1) if args.workers is None else args.workers
    require_in_range("--workers", workers, 1, 256)
    cases = CASES if args.cases is None else [case_by_name(name) for name in args.cases]
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f"--out: cannot create {out}: {error}") from None
    with output_lock(out, "robustness"):
        return _run_locked(args, cases, out, workers, command)


def _run_locked(args, cases, out: Path, workers: int, command: str) -> int:
    """The cases, holding the lock of ``out``; robustness.json is rewritten (whole) after every row."""
    from oilwatch.models.machine import bundled_name
    from oilwatch.outputs.atomic import write_text_atomic
    from oilwatch.robustness import format_table, run_robustness

    from .readme_block import replace_block

    # a bundled machine by name (portable), a file of the user's by its absolute path: robustness.json's
    # settings name the machine that --from-json and --resume load again, from whichever folder
    machine_file = (
        None if args.machine is None else bundled_name(args.machine) or str(Path(args.machine).resolve())
    )
    rows = run_robustness(
        cases,
        machine_file=machine_file,
        duration_s=args.duration_s,
        noise_um=args.noise_um,
        seed=args.seed,
        offset_prior_um=args.offset_prior_um,
        unbalance_prior=args.unbalance_prior,
        viscosity_prior=args.viscosity_prior,
        out_dir=out,
        workers=workers,
        progress=lambda text: print(f"robustness: {text}", file=sys.stderr, flush=True),
        resume=args.resume,
    )
    table = "\n".join(format_table(rows))
    write_text_atomic(out / "robustness.md", table + "\n")
    print(table)
    if args.readme is not None:
        replace_block(args.readme, args.block, table, command or "oilwatch robustness")
    return 0
