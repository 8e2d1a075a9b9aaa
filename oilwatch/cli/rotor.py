"""``oilwatch rotor``: the rotor model's summary (masses, weight, nodes, discs, unbalance)."""

from __future__ import annotations

import argparse
import json
import math

from .machine_option import add_machine_option
from .modes import load_rotor


def register(subparsers) -> None:
    """Add the ``rotor`` subcommand."""
    parser = subparsers.add_parser(
        "rotor",
        help="rotor summary: total mass, weight, node table, discs, unbalance moment",
        description="Summary of the finite-element rotor built from the machine file.",
    )
    add_machine_option(parser)
    parser.add_argument("--json", action="store_true", help="print JSON on stdout")
    parser.set_defaults(func=run)


def summary(machine, rotor) -> dict:
    """JSON-ready summary in the field's units (mm, kg, N, g mm)."""
    lengths = machine.element_lengths_m
    diameters = machine.element_diameters_m
    nodes = []
    for node in range(1, rotor.n_nodes + 1):
        nodes.append(
            {
                "node": node,
                "z_mm": 1e3 * float(rotor.node_positions_m[node - 1]),
                "element_length_mm": 1e3 * float(lengths[node - 1]) if node <= lengths.size else None,
                "element_diameter_mm": (1e3 * float(diameters[node - 1]) if node <= diameters.size else None),
                "bearing": node in rotor.bearing_nodes,
                "disc": any(n == node for n, _ in rotor.discs),
            }
        )
    discs = [
        {
            "node": spec.node,
            "width_mm": 1e3 * spec.width_m,
            "outer_diameter_mm": 1e3 * spec.outer_diameter_m,
            "bore_diameter_mm": 1e3 * spec.bore_diameter_m,
            "mass_kg": disc.mass_kg,
            "diametral_inertia_kg_m2": disc.diametral_inertia_kg_m2,
            "polar_inertia_kg_m2": disc.polar_inertia_kg_m2,
        }
        for spec, (_, disc) in zip(machine.discs, rotor.discs, strict=True)
    ]
    return {
        "machine": machine.name,
        "file": str(machine.source_path),
        "n_elements": machine.n_elements,
        "n_nodes": rotor.n_nodes,
        "n_dof": rotor.n_dof,
        "length_mm": 1e3 * float(rotor.node_positions_m[-1]),
        "shaft_mass_kg": rotor.shaft_mass_kg,
        "total_mass_kg": rotor.total_mass_kg,
        "weight_n": rotor.weight_n,
        "bearing_nodes": list(rotor.bearing_nodes),
        "load_split": machine.load_split,
        "bearing_static_loads_n": rotor.bearing_static_loads_n.tolist(),
        "bearing_load_angles_deg": [math.degrees(a) for a in rotor.bearing_load_angles_rad],
        "nominal_speed_hz": machine.nominal_speed_hz,
        "unbalance_node": rotor.unbalance_node,
        "unbalance_iso_grade_mm_s": 1e3 * machine.unbalance.iso_grade_m_s,
        "unbalance_moment_g_mm": 1e6 * rotor.unbalance_moment_kg_m,
        "unbalance_phase_deg": math.degrees(machine.unbalance.phase_rad),
        "structural_damping_s": machine.structural_damping_s,
        "discs": discs,
        "nodes": nodes,
    }


def run(args: argparse.Namespace) -> int:
    """Print the summary; returns the exit code."""
    machine, rotor = load_rotor(args)
    info = summary(machine, rotor)
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    print(f"{info['machine']}  ({info['file']})")
    print(
        f"{info['n_elements']} Timoshenko elements, {info['n_nodes']} nodes, {info['n_dof']} dof, "
        f"length {info['length_mm']:.1f} mm"
    )
    disc_masses = " + ".join(f"{d['mass_kg']:.2f}" for d in info["discs"]) or "0"
    print(
        f"mass: shaft {info['shaft_mass_kg']:.2f} kg + discs {disc_masses} kg "
        f"= {info['total_mass_kg']:.2f} kg; weight {info['weight_n']:.1f} N"
    )
    bearings = zip(
        info["bearing_nodes"], info["bearing_static_loads_n"], info["bearing_load_angles_deg"], strict=True
    )
    loads = ", ".join(
        f"node {n}: {w:.1f} N" + ("" if a == 180.0 else f" along {a:g} deg") for n, w, a in bearings
    )
    print(f"bearing static loads ({info['load_split']} split): {loads}")
    print(
        f"unbalance: G{info['unbalance_iso_grade_mm_s']:g} at {info['nominal_speed_hz']:g} Hz, "
        f"{info['unbalance_moment_g_mm']:.1f} g mm at node {info['unbalance_node']}, "
        f"phase {info['unbalance_phase_deg']:g} deg"
    )
    print(f"structural damping: C = {info['structural_damping_s']:g} s x K")
    print()
    print(f"{'node':>4}  {'z [mm]':>8}  {'elem L [mm]':>11}  {'elem D [mm]':>11}  support")
    for n in info["nodes"]:
        length = "" if n["element_length_mm"] is None else f"{n['element_length_mm']:.1f}"
        diameter = "" if n["element_diameter_mm"] is None else f"{n['element_diameter_mm']:.1f}"
        tags = " ".join(t for t, on in (("bearing", n["bearing"]), ("disc", n["disc"])) if on)
        print(f"{n['node']:>4}  {n['z_mm']:>8.1f}  {length:>11}  {diameter:>11}  {tags}")
    print()
    print(
        f"{'disc':>4}  {'node':>4}  {'width':>6}  {'D out':>6}  {'bore':>6}  {'mass [kg]':>9}  "
        f"{'Id [kg m2]':>10}  {'Ip [kg m2]':>10}"
    )
    for i, d in enumerate(info["discs"], start=1):
        print(
            f"{i:>4}  {d['node']:>4}  {d['width_mm']:>6.1f}  {d['outer_diameter_mm']:>6.1f}  "
            f"{d['bore_diameter_mm']:>6.1f}  {d['mass_kg']:>9.2f}  "
            f"{d['diametral_inertia_kg_m2']:>10.4f}  {d['polar_inertia_kg_m2']:>10.4f}"
        )
    return 0
