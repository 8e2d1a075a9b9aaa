"""The paper's model figures, recomputed by oilwatch: weight, flows, critical speeds, Tables 4 and 5.

``paper_comparison`` returns ours and the paper's figures side by side; ``oilwatch report`` prints them.
Tables 4-5 use the machine file's coefficients (``bearings.dynamic_coefficients``: synchronous K(Omega),
C(Omega) for the turbine, the 1x orbit's own frequency) and are also given with the quasi-static table. The
instability threshold of that model is the frequency-dependent one (each root at its own complex frequency,
from the transient results file); the quasi-static thresholds (frozen content, squeeze everywhere) come from
the speed sweeps and the first critical speed from the frozen-content sweep's Campbell crossing.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..bearing.coefficient_kinds import COEFFICIENT_KINDS, QUASI_STATIC, SYNCHRONOUS
from ..bearing.equilibrium import static_equilibrium
from ..bearing.grid import Mesh
from ..bearing.supply import ML_MIN_PER_M3_S, SupplyPressure
from ..machine import load_machine
from .factory import build_system, flowrate_tables_exist, load_speed_sweeps
from .sensitivity import DEFINITIONS, PAPER_TABLE4, PAPER_TABLE5, orbit_variation_table, paper_rows
from .stability import stability_map
from .transient_comparison import transient_figures

PAPER = {
    "rotor_weight_n": 6545.6,
    "flooded_threshold_ml_min": 546.0,
    "nominal_flow_ml_min": 596.3,
    "first_critical_hz": 55.0,
    "instability_threshold_hz": 95.0,
}
SCALAR_KEYS = tuple(PAPER)


def paper_comparison(machine_file: str | Path | None = None) -> dict:
    """Our model figures, the paper's, and their relative differences (JSON-ready, field units).

    Keys: the scalar figures of ``PAPER`` (ours), ``table4`` and ``table5`` (ours, rows of
    ``orbit_variation_table``), ``paper`` (the paper's scalars and tables), ``difference_pct`` (ours vs
    the paper's scalars), ``definitions``, ``mesh`` and ``speeds_hz`` (what the figures were computed with).
    """
    machine = load_machine(machine_file)
    system = build_system(machine, reduced=False)
    rotor = system.rotor
    load = float(rotor.bearing_static_loads_n[0])
    mesh = Mesh(**system.tables[0].metadata["mesh"])
    # the paper's threshold and nominal flowrates are of one bearing: bearing 1 (its geometry and load)
    flows = {
        key: static_equilibrium(machine.bearings[0], load, system.speed_hz, SupplyPressure(pressure), mesh)
        for key, pressure in (("flooded_threshold_ml_min", 0.0), ("nominal_flow_ml_min", 50e3))
    }
    sweeps = load_speed_sweeps(machine, rotor)
    speeds = sweeps[0].speeds_hz
    stability = stability_map(rotor, sweeps, speeds)
    # The same analysis with theta dh/dt applied in every volume: the squeeze-term choice moves the
    # threshold most (see models.bearing.film), so both are shown.
    alternative = load_speed_sweeps(machine, rotor, squeeze="everywhere")
    stability_alt = stability_map(rotor, alternative, alternative[0].speeds_hz)
    nominal = machine.lubrication.nominal_flowrates_m3_s
    transient = transient_figures(machine)
    kind = machine.dynamic_coefficients
    ours = {
        "rotor_weight_n": rotor.weight_n,
        **{key: eq.supply_flow_m3_s * ML_MIN_PER_M3_S for key, eq in flows.items()},
        "first_critical_hz": stability.first_critical_hz,
        "instability_threshold_hz": stability.instability_threshold_hz
        if kind == QUASI_STATIC
        else _frequency_dependent_threshold(transient, mesh),
    }
    quasi_static_tables = {}
    if kind != QUASI_STATIC and flowrate_tables_exist(machine, system.speed_hz, QUASI_STATIC):
        other = build_system(machine, reduced=False, coefficients=QUASI_STATIC)
        quasi_static_tables = {
            "table4_quasi_static": orbit_variation_table(other, nominal, both_bearings=True),
            "table5_quasi_static": orbit_variation_table(other, nominal, both_bearings=False),
        }
    difference = {
        key: None if ours[key] is None else 100.0 * (ours[key] - PAPER[key]) / PAPER[key]
        for key in SCALAR_KEYS
    }
    return {
        **ours,
        "squeeze_everywhere": {
            "first_critical_hz": stability_alt.first_critical_hz,
            "instability_threshold_hz": stability_alt.instability_threshold_hz,
        },
        "instability_threshold_quasi_static_hz": stability.instability_threshold_hz,
        **{
            k: v
            for k, v in transient.items()
            if not (kind == SYNCHRONOUS and k.endswith("_frequency_dependent"))
        },
        "coefficients": kind,
        "coefficients_description": COEFFICIENT_KINDS[kind],
        "table4": orbit_variation_table(system, nominal, both_bearings=True),
        "table5": orbit_variation_table(system, nominal, both_bearings=False),
        **quasi_static_tables,
        "paper": {**PAPER, "table4": paper_rows(PAPER_TABLE4), "table5": paper_rows(PAPER_TABLE5)},
        "difference_pct": difference,
        "definitions": {
            **DEFINITIONS,
            "first_critical": "lowest speed where a forward-whirl damped frequency crosses the 1x line",
            "coefficients": "the machine's kind of bearing coefficients (bearings.dynamic_coefficients), "
            "used by Tables 4-5 and the instability threshold; table4/5_quasi_static: the same with the "
            "quasi-static (frozen-content) table",
            "instability_threshold": "synchronous coefficients: the frequency-dependent linear threshold "
            "(instability_threshold_frequency_dependent, on the production mesh where it was computed); "
            "quasi-static: lowest speed where the least-stable mode's log decrement crosses zero",
            "instability_threshold_quasi_static": "lowest speed where the least-stable mode's log decrement "
            "crosses zero, frozen-content speed sweep",
            "flooded_threshold": "supply flow drawn at zero gauge groove pressure",
            "nominal_flow": "supply flow drawn at 0.5 bar groove pressure",
            "squeeze_everywhere": "speeds recomputed with theta dh/dt in every film volume (the default "
            "freezes the film content of cavitated volumes); both at the nominal flowrate",
            "instability_threshold_direct": "zero crossing of the whirl growth rate between the two "
            "neighbouring simulated speeds of opposite sign (rotor on two transient p-theta films)",
            "instability_threshold_frequency_dependent": "lowest speed where a root of the rotor on the "
            "linearized transient films (impedance Z(s), each mode at its own complex frequency) crosses "
            "into the right half-plane; same film mesh as the direct simulation",
            "orbit_check": "75 Hz 1x orbit of each linear model (same nonlinear static point) against the "
            "nonlinear transient run: largest |amplitude error| [%] and |phase error| [deg] over x1, y1, "
            "x2, y2",
        },
        "speed_hz": system.speed_hz,
        "sweep_speeds_hz": [float(s) for s in speeds],
        "least_log_decrement": [float(v) for v in np.asarray(stability.least_log_decrement)],
        "mesh": {"n_circ": mesh.n_circ, "n_axial": mesh.n_axial},
    }


def _frequency_dependent_threshold(transient: dict, mesh: Mesh) -> float | None:
    """The frequency-dependent linear threshold [Hz] on the tables' film mesh if computed there, else on
    the direct simulations' mesh (None when the results file has neither)."""
    by_mesh = transient.get("frequency_dependent_thresholds_by_mesh_hz") or {}
    return by_mesh.get(
        f"{mesh.n_circ}x{mesh.n_axial}", transient.get("instability_threshold_frequency_dependent_hz")
    )
