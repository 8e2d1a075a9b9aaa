"""``oilwatch run SCENARIO``: one of the paper's real-time scenarios through the two FMUs (Figs. 10-12)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from oilwatch.experiment_config import ScenarioConfig

from .config_options import add_config_options
from .machine_option import add_machine_option, load_machine_option

SCENARIO_NAMES = (
    "constant",
    "slow-drop",
    "intermediate-drop",
    "sudden-drop",
    "drop-b1",
    "drop-b2",
    "clog-b1",
    "clog-b2",
    "operating-ramps",
)
"""The names of ``oilwatch.scenarios.SCENARIOS`` (kept here so that --help imports nothing heavy)."""


def estimator_parameters_help() -> str:
    """The estimator's settable parameters with defaults and ranges, generated from its configuration."""
    from oilwatch.estimator.boundary_parameters import ESTIMATOR_PARAMETERS

    def bounds(p) -> str:
        low = "" if p.low is None else f"{p.low:g}"
        high = "" if p.high is None else f"{p.high:g}"
        return f"[{low}, {high}]" if p.high is not None else f">= {low}"

    unit = {p.name: "" if p.unit == "1" else f" {p.unit}" for p in ESTIMATOR_PARAMETERS}
    return "; ".join(f"{p.name} ({p.default:g}{unit[p.name]}, {bounds(p)})" for p in ESTIMATOR_PARAMETERS)


def register(subparsers) -> None:
    """Add the ``run`` subcommand."""
    parser = subparsers.add_parser(
        "run",
        help="simulate a starvation scenario: plant FMU + estimator FMU, result.csv, summary, plot",
        description=(
            "Simulate one of the paper's real-time scenarios (section 3.2.2): the RotorBearingPlant FMU "
            "and the OilFlowEKF FMU co-simulated by oilwatch's fmpy master (Gauss-Seidel, 1 ms steps). "
            "Each bearing's flowrate is a percentage of its own nominal flowrate (--q1-pct of bearing 1's, "
            "--q2-pct of bearing 2's) and the scenario runs at the machine's "
            "nominal speed (--machine; default: the bundled turbine); the sigmoid transition is centred at "
            "half the "
            "duration. Writes DIR/result.csv (flushed every row), DIR/summary.json and "
            "DIR/estimates.png. A missing coefficient table is computed first (beside the machine file; "
            "the bundled turbine: the cache). The FMUs of the machine are built on first use into "
            "~/.cache/oilwatch/build/<hash>/ ($OILWATCH_CACHE overrides ~/.cache/oilwatch) unless --fmu-dir "
            "or --ssp is given. "
            "Exit code 2 on bad input, 130 when interrupted (result.csv keeps the steps done)."
        ),
        epilog=(
            f"scenarios: constant (--q1-pct, --q2-pct; default {ScenarioConfig.q1_pct:g}); operating-ramps "
            "(the same while speed ramps nominal -3 -> +3 Hz over 10 s and oil +10 degC over 60 s); "
            "slow-drop, intermediate-drop, "
            "sudden-drop (both bearings 100 -> 75 %); drop-b1, drop-b2 (one bearing 100 -> 75 %, "
            "the other nominal); clog-b1, clog-b2 (one bearing 100 -> 75 %, the other 100 -> 125 %). "
            f"Estimator parameters for --set ekf.NAME=VALUE (default, range): {estimator_parameters_help()}"
        ),
    )
    parser.add_argument("scenario", metavar="SCENARIO", help=f"one of: {', '.join(SCENARIO_NAMES)}")
    add_config_options(parser, ScenarioConfig)
    parser.add_argument(
        "--speed-profile",
        metavar="PROFILE",
        help="measured spin speed fed to both FMUs [Hz]: constant:V, ramp:V0:V1:START_S:DURATION_S or "
        "step:V0:V1:START_S; +d/-d: relative to the nominal (e.g. ramp:72:78:0:10 or ramp:-3:+3:0:10); "
        "both FMUs then run on the dimensionless bearing table",
    )
    parser.add_argument(
        "--oil-temperature-profile",
        metavar="PROFILE",
        help="measured oil supply temperature fed to both FMUs [degC], same forms (e.g. ramp:+0:+10:0:60)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="FMU.NAME=VALUE",
        help="another FMU parameter, e.g. ekf.alarm_hold_on_s=0.5 or ekf.alarm_on_fraction=0.85 (repeatable)",
    )
    parser.add_argument(
        "--paper-tuning",
        action="store_true",
        help="the paper's filter: ekf.q_std_displacement_um=10, ekf.q_std_velocity_um_s=10, "
        "ekf.velocity_channels=1 (default: the estimator's recommended tuning)",
    )
    parser.add_argument("--out", metavar="DIR", help="output folder (default: oilwatch_runs/SCENARIO)")
    add_machine_option(parser)
    source = parser.add_mutually_exclusive_group()
    add_fmu_dir_option(source)
    source.add_argument(
        "--ssp",
        metavar="FILE",
        help="run the system of an SSP file (e.g. OilStarvation.ssp); the scenario's parameters override "
        "its bindings",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--json", action="store_true", help="print summary.json on stdout (and nothing else)")
    parser.set_defaults(func=run)


def add_fmu_dir_option(parser) -> None:
    """``--fmu-dir DIR`` (shared by ``run`` and ``demo``)."""
    parser.add_argument(
        "--fmu-dir",
        metavar="DIR",
        help="use the FMUs in DIR (from 'oilwatch build-fmus --out DIR', for the same --machine); never "
        "builds",
    )


def execute(
    run_settings,
    out: Path,
    fmu_dir: str | None,
    ssp: str | None,
    progress: bool,
    command: str,
    machine=None,
    labels: dict[str, dict[str, str]] | None = None,
):
    """Find or build the FMUs of ``machine`` (computing a missing coefficient table first), run, and return
    the summary, holding the lock of ``out`` (one run per folder).

    Shared by ``oilwatch run`` and ``oilwatch demo``. The previous run's files in ``out`` are removed once
    the FMUs are initialized (:func:`~oilwatch.scenarios.runner.run_scenario`), so that a run stopped
    part-way leaves its own rows in result.csv and no summary or plot of another run beside them.
    labels: see :func:`parameter_labels`.
    """
    from oilwatch.cosim.errors import SystemDescriptionError
    from oilwatch.outputs.lock import output_lock
    from oilwatch.scenarios.fmus import ensure_fmus
    from oilwatch.scenarios.runner import run_scenario

    from .machine_option import ensure_flowrate_tables
    from .outputs import output_folder

    def log(text: str) -> None:
        print(f"oilwatch {command}: {text}", file=sys.stderr)

    if ssp is not None:
        ssp_path, folder = Path(ssp), None
        if not ssp_path.is_file():
            raise SystemDescriptionError(f"--ssp: SSP file {ssp_path} does not exist")
    else:
        ssp_path = None
    if machine is not None:
        speeds = (run_settings.speed_hz("plant"), run_settings.speed_hz("ekf"))
        ensure_flowrate_tables(machine, speeds, command, progress)
    if ssp is None:
        folder = ensure_fmus(fmu_dir, log, machine)
    output_folder("--out", out)
    with output_lock(out, command):  # an interruption: oilwatch.cli.main says what result.csv keeps
        return run_scenario(run_settings, out, fmu_dir=folder, ssp=ssp_path, progress=progress, labels=labels)


def describe(summary: dict) -> list[str]:
    """Human-readable lines for a run's summary."""

    def pct(value):
        return "n/a" if value is None else f"{value:.2f} %"

    lines = [f"{summary['title']} ({summary['scenario']}), noise {summary['noise_um']:g} um, "
             f"{summary['duration_s']:g} s"]  # fmt: skip
    for b in (1, 2):
        delay, first = summary[f"alarm_delay_s_b{b}"], summary[f"first_alarm_s_b{b}"]
        alarm = "no alarm" if delay is None else f"alarm {delay:+.3f} s from the sigmoid centre"
        if summary[f"starved_initially_b{b}"]:
            alarm = "starved from the start: " + ("no alarm" if first is None else f"alarm at {first:.3f} s")
        if summary[f"false_alarm_s_b{b}"] is not None:
            alarm += f" (FALSE ALARM at {summary[f'false_alarm_s_b{b}']:.3f} s)"
        settle = summary[f"q{b}_settle_s"]
        settled = "not within 2 % at the end" if settle is None else f"within 2 % from {settle:+.2f} s"
        lines.append(
            f"  bearing {b}: error {pct(summary[f'q{b}_err_pct_before'])} before, "
            f"{pct(summary[f'q{b}_err_pct_after'])} after ({settled}); {alarm}"
        )
    lines.append(
        f"  real-time factor {summary['realtime_factor']:.2f} (simulation {summary['wall_s']:.1f} s, "
        f"set-up {summary['setup_s']:.1f} s)"
    )
    return lines


def parse_settings(items: list[str]) -> dict[str, dict[str, object]]:
    """``["ekf.alarm_hold_on_s=0.5", ...]`` -> ``{"ekf": {"alarm_hold_on_s": 0.5}}`` (integers as int,
    other numbers as float, the rest as text; the master checks each against its variable's FMI type,
    :mod:`oilwatch.cosim.values`, and names it ``--set ekf.alarm_hold_on_s``)."""
    from oilwatch.models.validation import InputError

    result: dict[str, dict[str, object]] = {}
    for item in items:
        target, equals, text = item.partition("=")
        role, dot, name = target.partition(".")
        if not (equals and dot and role and name):
            raise InputError(f"--set {item!r}: expected FMU.NAME=VALUE, e.g. ekf.alarm_hold_on_s=0.5")
        value: object = text
        for number in (int, float):
            try:
                value = number(text)
                break
            except ValueError:
                continue
        result.setdefault(role, {})[name] = value
    return result


def parameter_labels(scenario: str, given: dict[str, dict[str, object]], paper_tuning: dict) -> dict:
    """How the user gave each FMU parameter of a run, per role: the flag (``--q1-pct``, ``--seed``,
    ``--set ekf.NAME`` for the ``given`` ones, which win over ``paper_tuning``), so that every error about
    a parameter names the input the user can change."""
    flows = {
        f"q{b}_{end}_ml_min": f"--q{b}-pct"
        if scenario == "constant"
        else f"scenario {scenario!r} (bearing {b})"
        for b in (1, 2)
        for end in ("initial", "final")
    }
    common = {"noise_um": "--noise-um"}
    labels = {
        "plant": {**common, **flows, "seed": "--seed", "fault_time_s": "--duration-s"},
        "ekf": {**common, **{name: "--paper-tuning" for name in paper_tuning}},
    }
    for role, values in given.items():
        for name in values:
            labels.setdefault(role, {})[name] = f"--set {role}.{name}"
    return labels


def run(args: argparse.Namespace) -> int:
    """Run the scenario, write the files and print the summary."""
    from oilwatch.cosim import SlaveError
    from oilwatch.scenarios import PAPER_TUNING, make_run

    given = parse_settings(args.set)
    overrides = {role: dict(values) for role, values in given.items()}
    if args.paper_tuning:
        overrides["ekf"] = {**PAPER_TUNING, **overrides.get("ekf", {})}
    machine = load_machine_option(args)
    settings = make_run(
        args.scenario,
        args.noise_um,
        args.duration_s,
        args.seed,
        args.q1_pct,
        args.q2_pct,
        overrides,
        machine,
        args.speed_profile,
        args.oil_temperature_profile,
    )
    labels = parameter_labels(args.scenario, given, PAPER_TUNING if args.paper_tuning else {})
    out = Path(args.out) if args.out else Path("oilwatch_runs") / args.scenario
    try:
        summary = execute(settings, out, args.fmu_dir, args.ssp, not args.no_progress, "run", machine, labels)
    except SlaveError as error:
        print(f"oilwatch run: error: {error}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(summary, indent=2))
        return 0
    print("\n".join(describe(summary)))
    print(f"  wrote {out / 'result.csv'}, {out / 'summary.json'}, {out / 'estimates.png'}")
    return 0
