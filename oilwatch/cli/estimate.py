"""``oilwatch estimate RECORD...``: the estimator on recorded measurements (CSV, Parquet, TDMS or stdin)."""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path


def register(subparsers) -> None:
    """Add the ``estimate`` subcommand."""
    from oilwatch.monitoring import OPERATING_POINTS
    from oilwatch.monitoring.resume import RESUME_CHOICES

    from .config_options import add_preset_options
    from .machine_option import add_machine_option

    parser = subparsers.add_parser(
        "estimate",
        help="run the estimator on recorded probe data: estimates.csv, summary.json, views, report.html",
        description=(
            "Estimate both bearings' oil supply flowrates from recorded proximity-probe signals, with "
            "oilwatch's estimator (the OilFlowEKF FMU's filter, in-process, its default tuning). Records: "
            "CSV (time_s and one column per probe in um along its axis, the record format of 'oilwatch "
            "baseline'; optional speed_hz and oil_temperature_c), Parquet or NI TDMS (gap voltages in V "
            "need probes.*.unit = 'V' and rest_gap_v); '-' reads CSV from standard input line by line and "
            "prints each estimate line as soon as it is computed. The channel mapping and probe "
            "conventions come from the machine file's [probes] table (see the README), overridden by "
            "--probe. Any sample rate at or above 1 kHz is anti-alias filtered onto the estimator's 1 kHz "
            "grid. Writes DIR/estimates.csv (flushed block by block), DIR/summary.json, DIR/trend.png, "
            "DIR/centerline.png, DIR/orbits.png, DIR/probe_health.png and DIR/report.html. Several "
            "records run as Dask tasks, one output folder each (DIR/<record name>/). One run per output "
            "folder at a time; every file appears whole; summary.json, written last, says whether the run "
            "completed. Exit code 2 on a bad record (one line naming the column and the row) or an output "
            "that cannot be written, 3 when the estimate sat at a coefficient-table limit or was "
            "inconsistent with the model for over 10 % of the record, or the record ended in a model "
            "mismatch (summary.json 'trust' and 'model_mismatch': the estimates and alarms then come from "
            "the static change relative to the --baseline, or the alarms are held), 130 / 143 "
            "when interrupted by SIGINT / SIGTERM (estimates.csv keeps whole rows; rerun to resume). See "
            "docs/operations.md."
        ),
    )
    parser.add_argument(
        "records", nargs="+", metavar="RECORD", help="record file(s), or - for standard input"
    )
    add_machine_option(parser)
    parser.add_argument(
        "--baseline",
        metavar="FILE",
        help="commissioning baseline (JSON of 'oilwatch baseline'): the probe offsets' prior (default: the "
        "machine file's [probes] offset_prior_std_um, 25 um for the turbine)",
    )
    parser.add_argument(
        "--record-start",
        metavar="TIME",
        help="when the record started, ISO 8601 in UTC (e.g. 2026-12-01T08:00:00Z): with a --baseline that "
        "records its own start, the baseline's age widens the offsets' prior by the machine file's [probes] "
        "offset_drift_um_per_day (default: age unknown, not widened)",
    )
    parser.add_argument(
        "--offset-prior-um",
        type=float,
        metavar="STD",
        help="prior std of each probe's zero offset [um] (default: the --preset's: the machine file's "
        "[probes] offset_prior_std_um on the machine preset, 0 on the paper preset; 0: the offsets are known "
        "to be zero)",
    )
    add_preset_options(parser)
    parser.add_argument(
        "--probe",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a key of the machine file's [probes] table, e.g. x1.column=Ch0, layout=api670, "
        "x1.unit=V, x1.rest_gap_v=-9.5, keyphasor_column=KP (repeatable)",
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        help=(
            "output folder (default: estimates/<record stem>-<8 hex digits of the record's path and size>, "
            "so that two records of one name never share a folder; several records: DIR/<that name>/ each)"
        ),
    )
    parser.add_argument(
        "--output-every",
        type=int,
        default=1,
        metavar="N",
        help="write every N-th estimator sample to estimates.csv (default: 1; the summary, alarms and views "
        "use every sample)",
    )
    parser.add_argument(
        "--operating-point",
        choices=OPERATING_POINTS,
        default="auto",
        help="follow: the estimator's model follows the record's speed (speed_hz column or keyphasor) and "
        "oil temperature (oil_temperature_c) along the dimensionless bearing tables, as the estimator FMU "
        "with bearing_table = 1; nominal: the model at the machine's nominal speed and viscosity "
        "(bearing_table = 0); auto (default): follow when the record has a speed or an oil temperature",
    )
    parser.add_argument(
        "--resume",
        choices=RESUME_CHOICES,
        default="auto",
        help="auto (default): when the output folder holds a partial run of the same record, machine and "
        "options (stopped by Ctrl-C, SIGTERM, a full disk), continue it from its last resume point, with the "
        "estimates of an uninterrupted run; yes: resume or refuse; no: start over (docs/operations.md)",
    )
    parser.add_argument("--no-views", action="store_true", help="no PNG views and no report.html")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="several records: an existing Dask cluster, e.g. tcp://HOST:8786 (default: a local cluster)",
    )
    parser.add_argument("--workers", type=int, metavar="N", help="worker processes of the local cluster")
    parser.add_argument("--json", action="store_true", help="print summary.json on stdout (files only)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Check the arguments, then run one record in-process or several on Dask."""
    from oilwatch.models.validation import InputError, require_in_range
    from oilwatch.monitoring.estimate import EstimateOptions
    from oilwatch.records.readers import STDIN

    from .config_options import check_preset_options

    if args.output_every < 1:
        raise InputError(f"--output-every must be an integer >= 1, got {args.output_every}")
    if args.scheduler is not None or args.workers is not None:  # checked with one record too
        from oilwatch.study.runner import check_cluster_options

        check_cluster_options(args.scheduler, args.workers)
    if STDIN in args.records and len(args.records) > 1:
        raise InputError("- (standard input) must be the only record")
    live = args.records == [STDIN]
    if args.baseline is not None:
        from oilwatch.estimator.baseline import load_baseline

        try:
            load_baseline(args.baseline)  # a bad file fails here, before any record is read
        except InputError as error:
            raise InputError(f"--baseline: {error}") from None
    if args.record_start is not None:
        from oilwatch.monitoring.baseline_age import baseline_age_days, parse_utc

        parse_utc(args.record_start, "--record-start")
        if args.baseline is not None:
            baseline_age_days(args.baseline, args.record_start)  # a baseline newer than the record fails here
    if args.offset_prior_um is not None:
        require_in_range("--offset-prior-um", args.offset_prior_um, 0.0, 1000.0, "um")
    check_preset_options(args)
    options = EstimateOptions(
        machine_file=args.machine,
        baseline_file=args.baseline,
        offset_prior_std_um=args.offset_prior_um,
        preset=args.preset,
        viscosity_factor_prior_std=args.viscosity_prior,
        unbalance_prior_std=args.unbalance_prior,
        probe_overrides=tuple(args.probe),
        output_every=args.output_every,
        views=not args.no_views,
        live=live,
        operating_point=args.operating_point,
        record_start=args.record_start,
        resume=args.resume,
    )
    if len(args.records) > 1:
        return _run_many(args, options)
    source = args.records[0]
    out = Path(args.out) if args.out else Path("estimates") / output_folder_name(source)
    if live:
        summary = _run_one(source, out, options, progress=False, live=sys.stdout)
        print(_describe(summary), file=sys.stderr)
        return _exit_code(summary)
    summary = _run_one(source, out, options, progress=not args.no_progress)
    print(json.dumps(summary, indent=2) if args.json else _describe(summary))
    return _exit_code(summary)


def _exit_code(summary: dict) -> int:
    """0, or :data:`oilwatch.monitoring.trust.UNTRUSTED_EXIT_CODE` when the estimate is not trustworthy."""
    from oilwatch.monitoring.trust import UNTRUSTED_EXIT_CODE

    return 0 if summary.get("trust", {}).get("trusted", True) else UNTRUSTED_EXIT_CODE


def _stem(source: str) -> str:
    return "stdin" if source == "-" else Path(source).stem


def output_folder_name(source: str) -> str:
    """The default output folder of a record: its stem, a dash and the first 8 hex digits of the SHA-256 of
    its absolute path and its size in bytes (``result-3f9c0a1b``). The stem alone let two records named
    ``result.csv`` in different folders overwrite each other's estimates; the size tells a record rewritten
    in place from the one estimated before. Standard input is ``stdin``."""
    if source == "-":
        return "stdin"
    path = Path(source).resolve()
    try:
        size = path.stat().st_size
    except OSError:
        size = -1  # a missing record is refused by its reader, with its own message
    digest = hashlib.sha256(f"{path}\0{size}".encode()).hexdigest()[:8]
    return f"{path.stem}-{digest}"


def _run_one(source: str, out: Path, options, progress: bool, live=None) -> dict:
    from tqdm import tqdm

    from oilwatch.monitoring.estimate import EstimateRun

    # shown after a second: a record refused at once (a missing file, a bad column) prints its error alone
    bar = tqdm(
        disable=not progress, desc=f"estimate {_stem(source)}", unit_scale=True, file=sys.stderr, delay=1.0
    )

    def total(amount, unit):
        bar.total, bar.unit = amount, unit

    try:
        runner = EstimateRun(
            source, out, options, progress=bar.update, total_callback=total, live_stream=live
        )
        return runner.run()
    finally:
        bar.close()


def estimate_task(source: str, out: str, options) -> dict:
    """The Dask task of one record (single-threaded BLAS, no progress bar)."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        return _run_one(source, Path(out), options, progress=False)


def _run_many(args, options) -> int:
    from distributed import as_completed
    from tqdm import tqdm

    from oilwatch.models.validation import InputError
    from oilwatch.records.readers import open_record
    from oilwatch.study.runner import dask_client

    stems = [output_folder_name(source) for source in args.records]
    if len(set(stems)) != len(stems):
        raise InputError("a record is given twice; give each record once (one folder each)")
    for source in args.records:
        open_record(source, "time_s").close()  # a missing or unknown file fails here, before the cluster
    base = Path(args.out) if args.out else Path("estimates")
    failed, untrusted = [], 0
    with dask_client(args.scheduler, args.workers) as client:
        futures = {
            client.submit(estimate_task, source, str(base / stem), options, pure=False): source
            for source, stem in zip(args.records, stems, strict=True)
        }
        for future in tqdm(
            as_completed(futures), total=len(futures), desc="records", disable=args.no_progress
        ):
            source = futures[future]
            try:
                summary = future.result()
            except InputError as error:
                failed.append(source)
                print(f"oilwatch estimate: error: {error}", file=sys.stderr)
                continue
            print(json.dumps(summary, indent=2) if args.json else _describe(summary))
            untrusted += _exit_code(summary) != 0
    return 2 if failed else _exit_code({"trust": {"trusted": not untrusted}})


def _describe(summary: dict) -> str:
    record = summary["record"]
    lines = [
        f"{record['source']} ({record['format']}, {record['rows']} rows at {record['sample_rate_hz']:g} Hz): "
        f"{summary['duration_s']:.3f} s estimated, RTF {summary['realtime_factor']}"
    ]
    for b in (1, 2):
        q, std = summary[f"q{b}_final_ml_min"], summary[f"q{b}_std_final_ml_min"]
        numbers = "n/a" if q is None else f"{q:.1f} +- {2 * std:.1f} ml/min (2 std)"
        lines.append(f"  bearing {b}: {numbers}; {summary['verdict'][f'bearing{b}']}")
    mismatch = summary.get("model_mismatch")
    if mismatch is not None and mismatch["final"] != "consistent":
        share = 1.0 - mismatch["fraction"]["consistent"]
        lines.append(f"  model mismatch at the end ({mismatch['final']}; {100 * share:.0f} % of the record)")
    for alarm in summary["alarms"]:
        lines.append(f"  alarm: bearing {alarm['bearing']} at {alarm['time_s']:.3f} s")
    if record["gap_count"]:
        lines.append(
            f"  {record['gap_count']} gap(s) bridged with missing samples, the first at row "
            f"{record['gaps'][0]['row']}"
        )
    lines.append(
        f"  wrote {summary['estimates_csv']}"
        + (f", {summary['report_html']}" if "report_html" in summary else "")
    )
    return "\n".join(lines)
