"""The transient-film figures of the paper comparison, read from the committed results file.

The direct simulations take minutes to hours, so ``oilwatch transient`` writes them (with provenance)
to ``tables/<machine>_transient_results.json`` and the report only reads them; the Tables 4-5
amplitudes with the synchronous (frequency-dependent) coefficients are recomputed here from the
committed synchronous table, which is fast.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..bearing.coefficient_kinds import SYNCHRONOUS
from ..machine import Machine
from .factory import build_system, flowrate_table_path
from .sensitivity import orbit_variation_table

CHOSEN_MODEL = "frequency-dependent"


def results_path(machine: Machine) -> Path:
    """The machine's transient results file (written by ``oilwatch transient``)."""
    return machine.source_path.parent / "tables" / f"{machine.source_path.stem}_transient_results.json"


def synchronous_table_path(machine: Machine, speed_hz: float, bearing_index: int = 0) -> Path:
    """The flowrate table at whirl frequency = spin speed of bearing ``bearing_index``'s geometry (``oilwatch
    bearing-table --coefficients synchronous`` or ``oilwatch transient --study synchronous-table``)."""
    return flowrate_table_path(machine, speed_hz, SYNCHRONOUS, bearing_index)


def orbit_check(orbits: dict) -> dict:
    """Per flowrate [% of nominal]: each linear model's largest |amplitude error| [%] and |phase error|
    [deg] (and the run's settling, %)."""
    out = {}
    for pct, run in orbits.items():
        out[pct] = {
            name: {
                "max_amplitude_error_pct": max(abs(v) for v in model["amplitude_error_pct"]),
                "max_phase_error_deg": max(abs(v) for v in model["phase_error_deg"]),
            }
            for name, model in run["linear"].items()
        }
        out[pct]["settling_pct"] = run["settling_pct"]
    return out


def _orbit_checks_by_mesh(results: dict) -> dict:
    """``orbit_check`` of every orbit study in the results file, keyed by its mesh (``60x16``)."""
    out = {}
    for key, value in results.items():
        if key == "orbits" or key.startswith("orbits_"):
            mesh = value["provenance"]["mesh"]
            out[f"{mesh['n_circ']}x{mesh['n_axial']}"] = orbit_check(value["by_flowrate_pct"])
    return out


def transient_figures(machine: Machine) -> dict:
    """The report's transient-film entries (None where the results file lacks them)."""
    path = results_path(machine)
    results = json.loads(path.read_text()) if path.exists() else {}
    direct = results.get("threshold", {})
    mesh = direct.get("provenance", {}).get("mesh")
    linear_key = f"linear_threshold_{mesh['n_circ']}x{mesh['n_axial']}" if mesh else None
    linear = results.get(linear_key, {}) if linear_key else {}
    production = {key: value for key, value in results.items() if key.startswith("linear_threshold_")}
    figures = {
        "instability_threshold_direct_hz": direct.get("threshold_hz"),
        "instability_threshold_direct_bracket_hz": direct.get("bracket_hz"),
        "instability_threshold_frequency_dependent_hz": linear.get("threshold_hz"),
        "frequency_dependent_whirl_hz": linear.get("whirl_frequency_hz"),
        "frequency_dependent_thresholds_by_mesh_hz": {
            key.removeprefix("linear_threshold_"): value["threshold_hz"] for key, value in production.items()
        },
        "direct_simulation_mesh": mesh,
        "direct_growth_rates": [
            {k: run[k] for k in ("speed_hz", "growth_rate_1_s", "whirl_frequency_hz", "log_decrement")}
            for run in sorted(direct.get("runs", {}).values(), key=lambda r: r["speed_hz"])
        ],
        "orbit_check": orbit_check(results["orbits"]["by_flowrate_pct"]) if "orbits" in results else None,
        "orbit_check_model": CHOSEN_MODEL,
        "orbit_check_by_mesh": _orbit_checks_by_mesh(results),
        "orbit_mesh_convergence": {
            pct: run["changes"]
            for pct, run in results.get("orbit_mesh", {}).get("by_flowrate_pct", {}).items()
        },
        "starvation": {k: v for k, v in results["starvation"].items() if k != "record"}
        if "starvation" in results
        else None,
        "results_file": str(path),
    }
    table = synchronous_table_path(machine, machine.nominal_speed_hz)
    if table.exists():
        system = build_system(machine, reduced=False, table_path=table)
        nominal = machine.lubrication.nominal_flowrates_m3_s
        figures["table4_frequency_dependent"] = orbit_variation_table(system, nominal, both_bearings=True)
        figures["table5_frequency_dependent"] = orbit_variation_table(system, nominal, both_bearings=False)
    return figures
