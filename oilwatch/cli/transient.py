"""``oilwatch transient``: direct simulations with the transient films and the frequency-dependent tables.

Studies (``--study``, repeatable; each result is merged into the results file as soon as it is done,
so a stopped run loses only the study under way):

* ``synchronous-table``: the flowrate table with K, C at whirl frequency = spin speed
  (``tables/<machine>_bearing_<speed>hz_synchronous.json``);
* ``linear-threshold``: the instability threshold of the linear model with frequency-dependent
  coefficients, each mode at its own whirl frequency;
* ``threshold``: whirl growth rates by direct simulation at ``--speeds-hz`` (bracketing the threshold);
* ``orbits``: 1x orbits at 100 % and 75 % of the nominal flowrate, nonlinear against the linear models
  (saved as ``orbits``, or ``orbits_<mesh>`` with ``--orbit-key-by-mesh``);
* ``orbit-mesh``: the linear models' orbits about the nonlinear static equilibrium on each mesh of
  ``--meshes`` (no time stepping) and their changes against the last (finest) one;
* ``starvation``: the sudden drop 100 % -> 75 % and how long the film takes to settle.

Results go to ``tables/<machine>_transient_results.json`` (read by ``oilwatch report``).
"""

from __future__ import annotations

import argparse
import itertools
import json
import shlex
import sys
from pathlib import Path

from .modes import add_machine_option

STUDIES = ("synchronous-table", "linear-threshold", "threshold", "orbits", "orbit-mesh", "starvation")


def register(subparsers) -> None:
    """Add the ``transient`` subcommand."""
    parser = subparsers.add_parser(
        "transient",
        help="transient-film direct simulations, frequency-dependent coefficients (results for the report)",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_machine_option(parser)
    parser.add_argument("--study", action="append", choices=STUDIES, required=True, help="what to compute")
    parser.add_argument("--mesh", default="60x16", help="film mesh N_CIRCxN_AXIAL of the direct simulations")
    parser.add_argument("--speeds-hz", default="", help="comma-separated speeds of the threshold study [Hz]")
    parser.add_argument("--duration-s", type=float, default=None, help="simulated time per run [s]")
    parser.add_argument(
        "--bracket-hz", default="60,160", help="LOW,HIGH speeds bracketing the linear threshold [Hz] (60,160)"
    )
    parser.add_argument(
        "--tolerance-hz", type=float, default=0.05, help="bisection width of the linear threshold [Hz] (0.05)"
    )
    parser.add_argument(
        "--meshes", default="60x16,120x36,240x72", help="comma-separated meshes of the orbit-mesh study"
    )
    parser.add_argument(
        "--plant-tolerances",
        action="store_true",
        help="orbits: the high-fidelity plant's coupling and film tolerances (1e-9 m, 1e-8) instead of "
        "the studies' (1e-10 m, 1e-11): about half the film sweeps",
    )
    parser.add_argument(
        "--orbit-key-by-mesh", action="store_true", help="orbits: save as orbits_<mesh> (keeps 'orbits')"
    )
    parser.add_argument("--out", default=None, help="results file (default: next to the machine file)")
    parser.set_defaults(func=run)


def _mesh(text: str):
    from oilwatch.models.bearing.grid import Mesh

    return Mesh.from_text(text)


def run(args: argparse.Namespace) -> int:
    """Run the studies and merge their results into the results file."""
    import datetime as dt

    from tqdm import tqdm

    from oilwatch.cli.progress import progress_bar
    from oilwatch.models import __version__
    from oilwatch.models.bearing.dynamic_table import synchronous_table
    from oilwatch.models.machine import load_machine
    from oilwatch.models.rotor.assembly import Rotor
    from oilwatch.models.system import nonlinear_studies as studies
    from oilwatch.models.system.factory import load_tables
    from oilwatch.models.system.frequency_stability import frequency_dependent_threshold
    from oilwatch.models.system.transient_comparison import results_path, synchronous_table_path
    from oilwatch.models.validation import InputError, require_positive

    machine = load_machine(args.machine)
    mesh = _mesh(args.mesh)
    out = Path(args.out) if args.out else results_path(machine)
    results = json.loads(out.read_text()) if out.exists() else {}
    command = "oilwatch " + shlex.join(sys.argv[1:])
    q_nominal = machine.shared_nominal_flowrate_m3_s("oilwatch transient")
    rotor = Rotor.from_machine(machine)

    def save(key, value, study_mesh):
        value = {
            **value,
            "provenance": {
                "command": command,
                "oilwatch_version": __version__,
                "date_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
                "mesh": {"n_circ": study_mesh.n_circ, "n_axial": study_mesh.n_axial},
            },
        }
        # Re-read before writing: another study may have saved its key since this run started.
        latest = json.loads(out.read_text()) if out.exists() else {}
        latest[key] = value
        results[key] = value
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(latest, indent=1) + "\n")
        print(f"wrote {key} to {out}", file=sys.stderr)

    def bar(total, desc):
        progress = tqdm(total=total, desc=desc, unit="step", file=sys.stderr)
        return progress, lambda k: progress.update(1)

    for study in args.study:
        if study == "synchronous-table":
            speed = machine.nominal_speed_hz
            quasi_static = load_tables(machine, rotor, speed, coefficients="quasi-static")
            for index in machine.distinct_geometries:  # one table per bearing geometry
                bearing = machine.bearings[index]
                with progress_bar("synchronous table", unit="flowrate") as progress:
                    table = synchronous_table(bearing, quasi_static[index], progress, command=command)
                path = synchronous_table_path(machine, speed, index)
                table.save(path)
                print(f"wrote {path}", file=sys.stderr)
        elif study == "linear-threshold":
            bracket = _speeds(args.bracket_hz, "--bracket-hz")
            if len(bracket) != 2 or bracket[0] >= bracket[1]:
                raise InputError(f"--bracket-hz must be LOW,HIGH with LOW < HIGH, got {args.bracket_hz!r}")
            found = frequency_dependent_threshold(
                machine,
                rotor,
                q_nominal,
                mesh,
                *bracket,
                tolerance_hz=require_positive("--tolerance-hz", args.tolerance_hz, "Hz"),
                progress=lambda s, m: print(
                    f"  {s:.3f} Hz: log dec {m.log_decrement:+.4f} at {m.frequency_hz:.2f} Hz",
                    file=sys.stderr,
                ),
            )
            save(f"linear_threshold_{mesh.n_circ}x{mesh.n_axial}", found, mesh)
        elif study == "threshold":
            if not args.speeds_hz:
                raise InputError("--speeds-hz is required for --study threshold (e.g. 110,112,114)")
            speeds = _speeds(args.speeds_hz, "--speeds-hz")
            runs = dict(results.get("threshold", {}).get("runs", {}))
            duration = args.duration_s or 0.4
            for speed in speeds:
                progress, tick = bar(round(duration / 2e-4), f"whirl at {speed:g} Hz")
                growth = studies.whirl_growth_rate(
                    machine, mesh, speed, q_nominal, duration_s=duration, progress=tick
                )
                progress.close()
                runs[f"{speed:g}"] = growth
                save("threshold", {"runs": runs, **_bracket(runs)}, mesh)
        elif study == "orbits":
            key = f"orbits_{mesh.n_circ}x{mesh.n_axial}" if args.orbit_key_by_mesh else "orbits"
            orbits = dict(results.get(key, {}).get("by_flowrate_pct", {}))
            duration = args.duration_s or 0.6
            options = {}
            if args.plant_tolerances:
                from oilwatch.models.system.nonlinear_plant import (
                    PLANT_FILM_OPTIONS,
                    PLANT_POSITION_TOLERANCE_M,
                )

                options = {
                    "position_tolerance_m": PLANT_POSITION_TOLERANCE_M,
                    "film_options": PLANT_FILM_OPTIONS,
                }
            for pct in (100, 75):
                progress, tick = bar(round(duration * machine.nominal_speed_hz * 64), f"orbit {pct} %")
                orbits[str(pct)] = studies.unbalance_orbits(
                    machine, mesh, pct / 100 * q_nominal, duration_s=duration, progress=tick, **options
                )
                progress.close()
                save(key, {"by_flowrate_pct": orbits}, mesh)
        elif study == "orbit-mesh":
            meshes = [_mesh(m) for m in args.meshes.split(",")]
            by_pct = {}
            for pct in (100, 75):
                runs = {}
                for m in meshes:
                    print(f"  linear orbits, {pct} %, mesh {m.n_circ}x{m.n_axial}", file=sys.stderr)
                    runs[f"{m.n_circ}x{m.n_axial}"] = studies.linear_orbits(machine, m, pct / 100 * q_nominal)
                reference = f"{meshes[-1].n_circ}x{meshes[-1].n_axial}"
                by_pct[str(pct)] = {
                    "runs": runs,
                    "reference_mesh": reference,
                    "changes": studies.mesh_changes(runs, reference),
                }
                save("orbit_mesh", {"by_flowrate_pct": by_pct}, meshes[-1])
        elif study == "starvation":
            duration = args.duration_s or 0.5
            progress, tick = bar(round((duration + 0.05) * machine.nominal_speed_hz * 64), "sudden drop")
            drop = studies.starvation_transient(
                machine, mesh, q_nominal, 0.75 * q_nominal, after_s=duration, progress=tick
            )
            progress.close()
            save("starvation", drop, mesh)
    return 0


def _speeds(text: str, option: str) -> list[float]:
    """Comma-separated speeds [Hz], each > 0."""
    from oilwatch.models.validation import InputError, require_positive

    try:
        return [require_positive(option, float(v), "Hz") for v in text.split(",")]
    except ValueError:
        raise InputError(f"{option} must be comma-separated speeds in Hz, got {text!r}") from None


def _bracket(runs: dict) -> dict:
    """The tightest pair of neighbouring speeds with decaying then growing whirl, and the zero crossing."""
    ordered = sorted(runs.values(), key=lambda r: r["speed_hz"])
    for low, high in itertools.pairwise(ordered):
        if low["growth_rate_1_s"] < 0.0 <= high["growth_rate_1_s"]:
            a, b = low["speed_hz"], high["speed_hz"]
            ga, gb = low["growth_rate_1_s"], high["growth_rate_1_s"]
            return {"bracket_hz": [a, b], "threshold_hz": a + (b - a) * (-ga) / (gb - ga)}
    return {"bracket_hz": None, "threshold_hz": None}
