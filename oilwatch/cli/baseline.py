"""``oilwatch baseline``: probe zero offsets from a commissioning record at known, healthy flowrates, and the
probes' runout (slow-roll vectors) from a slow-roll record."""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

PROBE_COLUMNS = ("x1_um", "y1_um", "x2_um", "y2_um")
"""The record's probe columns, in um along each probe's axis (the plant FMU's output names)."""


def register(subparsers) -> None:
    """Add the ``baseline`` subcommand."""
    from .config_options import add_preset_options
    from .machine_option import add_machine_option

    parser = subparsers.add_parser(
        "baseline",
        help="commissioning: the probe offsets from a record at known flowrates, the clearances from a "
        "coast-down",
        description=(
            "Read a record taken at known, healthy flowrates (default: the machine's nominal), as 'oilwatch "
            "estimate' reads it (CSV, Parquet or NI TDMS at any sample rate at or above 1 kHz, anti-alias "
            "filtered onto the estimator's grid; the machine file's [probes] mapping, --probe overrides, "
            "keyphasor, speed_hz and oil_temperature_c columns), estimate the four probe zero offsets and, "
            "as the --preset says, the complex unbalance and the bearings' viscosity factors with their "
            "joint covariance, and the record's mean probe signals (the static reference a model mismatch "
            "is read against), and write them as JSON: the estimator's prior for later runs. With "
            "--slow-roll-record, also fit each probe's 1x and 2x slow-roll (runout) vectors to a record "
            "taken at slow roll, store them with their stds and subtract them from the commissioning "
            "record (and, in later runs, from every sample: API 670 slow-roll compensation). With "
            "--coast-down-record, also measure each bearing's radial clearance from its shaft centreline "
            "between slow roll and speed (the flooded locus of the machine file's bearing, the probe "
            "offsets and the film's viscosity free), which the estimator's model then takes."
        ),
    )
    parser.add_argument(
        "--record",
        default=None,
        metavar="FILE",
        help="the commissioning record (any record 'oilwatch estimate' reads)",
    )
    parser.add_argument(
        "--slow-roll-record",
        default=None,
        metavar="FILE",
        help="a record at slow roll (CSV: time_s, the probe columns in um and rotor_angle_deg from the "
        "keyphasor, or speed_hz with time_s = 0 at a keyphasor pulse): the probes' runout vectors",
    )
    parser.add_argument(
        "--coast-down-record",
        default=None,
        metavar="FILE",
        help="a coast-down or run-up record at nominal supply pressure, from slow roll (a few %% of the "
        "running speed) to speed, with speed_hz (any record 'oilwatch estimate' reads, or a shaft-centreline "
        "export: one row per speed): each bearing's radial clearance, measured from its centreline, which "
        "the estimator's model then takes",
    )
    add_machine_option(parser)
    parser.add_argument("--q1-ml-min", type=float, default=None, help="known flowrate of bearing 1 [ml/min]")
    parser.add_argument("--q2-ml-min", type=float, default=None, help="known flowrate of bearing 2 [ml/min]")
    parser.add_argument(
        "--noise-um",
        type=float,
        default=None,
        help="probe noise std [um] (default: the machine file's [probes] noise_um, as 'oilwatch estimate')",
    )
    parser.add_argument(
        "--probe",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a key of the machine file's [probes] table as in 'oilwatch estimate' (repeatable)",
    )
    parser.add_argument(
        "--offset-prior-um",
        type=float,
        default=None,
        help="prior std of each offset [um] (default: the machine file's [probes] offset_prior_std_um, 25)",
    )
    add_preset_options(parser)
    parser.add_argument(
        "--record-start",
        metavar="TIME",
        help="when the commissioning record started, ISO 8601 in UTC: stored as record_start_utc, against "
        "which 'oilwatch estimate --record-start' ages the baseline (default: not stored, age unknown)",
    )
    parser.add_argument("--out", required=True, metavar="FILE", help="baseline JSON to write")
    parser.set_defaults(func=run)


def read_slow_roll_record(path: str | Path):
    """(times (K,) [s], signals (K, 4) [m], rotor angle (K,) [rad]) of a slow-roll record: the rotor angle
    from its ``rotor_angle_deg`` column, or the integral of ``speed_hz`` from time_s = 0 (a keyphasor
    pulse)."""
    import numpy as np

    from oilwatch.models.validation import InputError

    try:
        with open(path, newline="") as handle:
            reader = csv.DictReader(handle)
            names = reader.fieldnames or []
            angle = next((c for c in ("rotor_angle_deg", "speed_hz") if c in names), None)
            missing = [c for c in ("time_s", *PROBE_COLUMNS) if c not in names]
            if missing or angle is None:
                need = ", ".join(missing + ([] if angle else ["rotor_angle_deg or speed_hz"]))
                raise InputError(f"--slow-roll-record {path}: missing column(s) {need}")
            rows = [[row["time_s"], *(row[c] for c in PROBE_COLUMNS), row[angle]] for row in reader]
    except FileNotFoundError:
        raise InputError(f"--slow-roll-record: file not found: {path}") from None
    try:
        table = np.array(rows, dtype=float).reshape(-1, 6)
    except ValueError as error:
        raise InputError(f"--slow-roll-record {path}: not numeric ({error})") from None
    table = table[np.isfinite(table[:, 0]) & np.isfinite(table[:, 5])]
    if len(table) < 2 or np.any(np.diff(table[:, 0]) <= 0.0):
        raise InputError(f"--slow-roll-record {path}: needs increasing time_s over at least 2 samples")
    times = table[:, 0]
    if angle == "rotor_angle_deg":
        theta = np.unwrap(np.radians(table[:, 5]))
    else:
        speed = table[:, 5]
        steps = 0.5 * (speed[1:] + speed[:-1]) * np.diff(times)
        theta = 2.0 * np.pi * (speed[0] * times[0] + np.concatenate([[0.0], np.cumsum(steps)]))
    return times, table[:, 1:5] * 1e-6, theta


def run(args: argparse.Namespace) -> int:
    """Fit the baseline, holding the lock of --out (one writer per file); the file appears whole."""
    from oilwatch.outputs.lock import output_lock

    with output_lock(args.out, "baseline", kind="file"):
        return _run_locked(args)


def _run_locked(args: argparse.Namespace) -> int:
    from oilwatch.estimator.baseline import FORMAT, FORMAT_VERSION, clearance_factors_of, estimate_baseline
    from oilwatch.estimator.ekf_config import ML_MIN, EKFConfig
    from oilwatch.estimator.runout import fit_slow_roll
    from oilwatch.models.machine import load_machine
    from oilwatch.models.probes import read_probes
    from oilwatch.models.validation import InputError, require_in_range
    from oilwatch.monitoring.estimate import read_record_samples
    from oilwatch.monitoring.estimator_setup import estimator_model
    from oilwatch.outputs.atomic import write_json_atomic

    from .config_options import check_preset_options, preset_prior

    if args.noise_um is not None:
        require_in_range("--noise-um", args.noise_um, 0.01, 100.0, "um")
    check_preset_options(args)
    if args.record is None and args.slow_roll_record is None and args.coast_down_record is None:
        raise InputError(
            "oilwatch baseline needs --record FILE, --slow-roll-record FILE, --coast-down-record FILE or more"
        )
    runout = None
    if args.slow_roll_record is not None:
        runout = fit_slow_roll(*read_slow_roll_record(args.slow_roll_record))
        doc = runout.to_document()
        described = "; ".join(
            f"{c[:2]} 1x {a:.3f} um at {p:.1f} deg (std {s:.3f}), 2x {b:.3f} um at {q:.1f} deg"
            for c, a, p, s, b, q in zip(
                PROBE_COLUMNS,
                *(
                    doc[f"runout_{k}"]
                    for k in ("1x_um", "1x_phase_deg", "1x_std_um", "2x_um", "2x_phase_deg")
                ),
                strict=True,
            )
        )
        print(f"baseline: slow-roll vectors {described}")
    machine = load_machine(args.machine)
    probes = read_probes(machine)
    clearance, measured = {}, []
    if args.coast_down_record is not None:
        clearance, measured = coast_down_clearances(args, machine, probes)
    factors = clearance_factors_of(clearance)
    if args.record is None:
        document = {"format": FORMAT, "format_version": FORMAT_VERSION, "machine_file": args.machine}
        if runout is not None:
            document.update(runout=runout.to_document(), slow_roll_record=str(args.slow_roll_record))
        document.update(clearance)
        write_json_atomic(args.out, document)
        parts = " and ".join(p for p, given in (("runout", runout), ("clearances", factors)) if given)
        print("\n".join([*measured, f"baseline: {parts} only; written to {args.out}"]))
        return 0
    prior_um = probes.offset_prior_std_m * 1e6 if args.offset_prior_um is None else args.offset_prior_um
    require_in_range("--offset-prior-um", prior_um, 0.01, 1000.0, "um")
    nominal = tuple(float(q) for q in machine.lubrication.nominal_flowrates_m3_s)
    flows = [
        q if v is None else v * ML_MIN for q, v in zip(nominal, (args.q1_ml_min, args.q2_ml_min), strict=True)
    ]
    viscosity = preset_prior(args, "viscosity_prior")
    follow = viscosity > 0.0 and machine.oil is not None
    if viscosity > 0.0 and not follow:
        if args.viscosity_prior is not None:
            raise InputError("--viscosity-prior > 0 needs the machine's oil ([oil] in the machine file)")
        viscosity = 0.0  # the preset's factors need the model that follows the operating point
    # the estimator's own model, as 'oilwatch estimate' builds it
    model = estimator_model(args.machine, follow=follow, clearance_factors=factors)
    for name, value, (low, high) in zip(
        ("--q1-ml-min", "--q2-ml-min"), flows, model.bearing_flowrate_bounds_m3_s, strict=True
    ):
        require_in_range(name, value / ML_MIN, low / ML_MIN, high / ML_MIN, "ml/min")
    record = read_record_samples(args.record, machine, tuple(args.probe))
    noise_um = record["stream"].setup.noise_um if args.noise_um is None else args.noise_um
    speed, temperature = record["speed_hz"], record["oil_temperature_c"]
    if not follow:
        speed = temperature = None
    config = EKFConfig.preset(
        args.preset,
        speed_hz=machine.nominal_speed_hz,
        noise_std_m=noise_um * 1e-6,
        first_sample_time_s=record["first_sample_time_s"],
        probe_angle_deg=record["probe_angle_deg"],
        offset_prior_std_m=prior_um * 1e-6,
        offset_random_walk_m_sqrt_s=probes.offset_random_walk_m_sqrt_s,
        q_nominal_m3_s=nominal,
        runout=runout,
        unbalance_prior_std=preset_prior(args, "unbalance_prior"),
        viscosity_factor_prior_std=viscosity,
    )
    from oilwatch.monitoring.baseline_age import BASELINE_START_KEY, parse_utc

    start = None if args.record_start is None else parse_utc(args.record_start, "--record-start")
    document = estimate_baseline(
        model, record["measurement_m"], flows, config, speed_hz=speed, oil_temperature_c=temperature
    )
    document.update(record=str(args.record), machine_file=args.machine, preset=args.preset)
    if start is not None:  # the baseline's age in estimate (oilwatch.monitoring.baseline_age)
        document[BASELINE_START_KEY] = start.isoformat()
    if runout is not None:
        document.update(runout=runout.to_document(), slow_roll_record=str(args.slow_roll_record))
    document.update(clearance)
    write_json_atomic(args.out, document)
    offsets = ", ".join(
        f"{c} {o:+.2f} +- {s:.2f}"
        for c, o, s in zip(PROBE_COLUMNS, document["offsets_um"], document["offset_std_um"], strict=True)
    )
    others = ""
    if "viscosity_factor" in document:
        factors = zip(document["viscosity_factor"], document["viscosity_factor_std"], strict=True)
        others += "; viscosity factors " + ", ".join(f"{v:.3f} +- {s:.3f}" for v, s in factors)
    if "unbalance" in document:
        (re, im), (s_re, s_im) = document["unbalance"], document["unbalance_std"]
        others += f"; unbalance {re:+.3f} {im:+.3f}i (std {s_re:.3f}, {s_im:.3f}) of the machine file's"
    from oilwatch.monitoring.trust import UNTRUSTED_EXIT_CODE, noticeable

    # as oilwatch estimate's trust: written, but not trustworthy when the model could not explain the record
    trusted = not noticeable(1.0 - document["consistent_fraction"])
    if not trusted:
        others += (
            f"; its model explained the record only {100 * document['consistent_fraction']:.0f} % of the "
            "time (model_consistent): the nuisances above may carry the model's error"
        )
    print("\n".join([*measured, f"baseline: offsets [um] {offsets}{others}; written to {args.out}"]))
    return 0 if trusted else UNTRUSTED_EXIT_CODE


def _not_applied(fit, clearance_um: float) -> str:
    return (
        f"; NOT applied (the machine file's {clearance_um:.1f} um kept): a film {fit.viscosity_factor:.2f} x "
        "the oil law's is more viscous than the oil supplied, so the centreline is not the file's bearing "
        "under its load (a static load, or a geometry, that the file does not give)"
    )


def coast_down_clearances(args: argparse.Namespace, machine, probes) -> tuple[dict, list[str]]:
    """The baseline's clearance part (:func:`oilwatch.estimator.baseline.clearance_document`) from
    ``--coast-down-record``, read as 'oilwatch estimate' reads a record, and a line per bearing to print
    (after the file is written)."""
    from oilwatch.estimator.baseline import clearance_document
    from oilwatch.estimator.measurement import probe_rotation
    from oilwatch.models.system.clearance import measure_clearances, record_revolutions
    from oilwatch.models.validation import InputError
    from oilwatch.monitoring.estimate import read_record_samples
    from oilwatch.monitoring.estimator_setup import ESTIMATOR_DT_S

    source = args.coast_down_record
    record = read_record_samples(source, machine, tuple(args.probe))
    if record["speed_hz"] is None:
        raise InputError(f"--coast-down-record {source}: needs the speed (a speed_hz column or a keyphasor)")
    # the samples along the probes' axes, turned into the model's (x, y)
    rotation = probe_rotation(math.radians(record["probe_angle_deg"]))
    positions = record["measurement_m"] @ rotation
    noise_um = record["stream"].setup.noise_um if args.noise_um is None else args.noise_um
    fits = measure_clearances(
        machine,
        record["speed_hz"],
        positions,
        noise_um * 1e-6,
        record["oil_temperature_c"],
        revolutions=record_revolutions(record["speed_hz"], ESTIMATOR_DT_S),  # on the estimator's grid
        probe_scale_factor_std=probes.scale_factor_std,
    )
    clearances_um = [bearing.clearance_m * 1e6 for bearing in machine.bearings]
    lines = [
        f"baseline: bearing {b} clearance {fit.clearance_factor * c_um:.1f} +- "
        f"{2 * fit.clearance_factor_std * c_um:.1f} um (2 std; the machine file's {c_um:.1f} um, factor "
        f"{fit.clearance_factor:.4f}), film {fit.viscosity_factor:.3f} x the oil law's, centreline "
        f"residual {fit.residual_rms_m * 1e6:.3f} um rms over {fit.points} speed bins "
        f"({fit.speed_span:.1f}:1){'' if fit.explains_centreline else _not_applied(fit, c_um)}"
        for b, (fit, c_um) in enumerate(zip(fits, clearances_um, strict=True), start=1)
    ]
    return clearance_document(fits, str(source)), lines
