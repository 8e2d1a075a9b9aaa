"""``oilwatch validate``: the bearing model against independent references, as the docs show them.

``bearing-tables``: the film's flooded solution against Lund & Thomsen's (1978) two-axial-groove tables and
the Ocvirk short-bearing limit (:mod:`oilwatch.models.bearing.published_tables`), the tables and the plot of
docs/validation-bearing.md. ``bearing-map``: the machine's dimensionless operating table against direct solves
off its nodes (:mod:`oilwatch.models.bearing.operating_accuracy`), the figures of docs/bearings.md.
``reduction``: the machine's reduced rotor model against all its dofs, as the flowrate its error is worth
(:mod:`oilwatch.models.system.reduction_check`), at the machine file's ``reduced_model.cutoff_hz`` and
higher ones.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from oilwatch.models.validation import InputError

from .machine_option import add_bearing_option, add_machine_option, bearing_index, load_machine_option

TARGETS = ("bearing-tables", "bearing-map", "reduction")

MAP_POINTS = ((60.0, 0.07, 0.8), (60.0, 0.07, 1.0), (90.0, 0.12, 0.8), (90.0, 0.12, 1.0))
"""(speed [Hz], viscosity [Pa s], fraction of the flooded threshold q_t) where ``bearing-map`` compares: off
the bundled turbine's table nodes in Sommerfeld number, starved and at the threshold, low and high speed."""
MAP_SPREAD = (
    (48.0, 0.05, 0.55),
    (50.0, 0.17, 0.75),
    (66.0, 0.10, 1.25),
    (72.0, 0.09, 0.95),
    (80.0, 0.15, 1.05),
    (84.0, 0.06, 1.45),
    (100.0, 0.18, 0.75),
    (104.0, 0.06, 1.25),
)
"""More points over the table's range, off its flowrate nodes too (left out by ``--quick``)."""
NEAR_THRESHOLD_FRACTIONS = (0.95, 0.99, 1.0, 1.01, 1.05)
"""Fractions of q_t of ``--near-threshold``, at the speeds and viscosities of :data:`MAP_POINTS`."""
ONE_D_FLOWRATES = 41
"""Flowrates between the 1-D table's nodes where ``bearing-map`` compares the two tables."""


def register(subparsers) -> None:
    """Add the ``validate`` subcommand."""
    parser = subparsers.add_parser(
        "validate",
        help="the bearing model against published tables and direct solves, the reduced rotor model against "
        "the full one (the docs' validation figures)",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("target", choices=TARGETS, metavar="TARGET", help=f"one of: {', '.join(TARGETS)}")
    parser.add_argument(
        "--mesh",
        action="append",
        metavar="N_CIRCxN_AXIAL",
        help="bearing-tables: a mesh to solve on (repeatable; default 72x24 and 144x48)",
    )
    parser.add_argument("--plot", metavar="FILE", help="bearing-tables: write the comparison's figure (PNG)")
    parser.add_argument(
        "--readme",
        metavar="FILE",
        help="bearing-tables: also write the tables into FILE's generated blocks (lund-worst, ocvirk, "
        "lund-rows); bearing-map --near-threshold: the table of both interpolations against the direct "
        "solves into the block near-threshold-KIND (KIND: the table's coefficients)",
    )
    parser.add_argument("--quick", action="store_true", help="bearing-map: only the four main points")
    parser.add_argument(
        "--near-threshold",
        action="store_true",
        help="bearing-map: 0.95, 0.99, 1, 1.01 and 1.05 of q_t at the main points' speeds and viscosities",
    )
    parser.add_argument(
        "--one-sided",
        action="store_true",
        help="bearing-map: interpolate each side of the flooded threshold separately",
    )
    parser.add_argument(
        "--coefficients",
        choices=("synchronous", "quasi-static"),
        help="bearing-map: the table's kind (default: the machine file's bearings.dynamic_coefficients)",
    )
    add_bearing_option(parser, "bearing-map: the table of its geometry, at its load", "bearing 1")
    add_machine_option(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.bearing is not None and args.target != "bearing-map":
        raise InputError("--bearing is bearing-map's")
    if args.target == "bearing-tables":
        if args.quick or args.near_threshold or args.one_sided or args.coefficients:
            raise InputError("--quick, --near-threshold, --one-sided and --coefficients are bearing-map's")
        return bearing_tables(args)
    if args.mesh or args.plot:
        raise InputError("--mesh and --plot are bearing-tables'")
    if args.target == "reduction":
        if args.quick or args.near_threshold or args.one_sided or args.coefficients or args.readme:
            raise InputError(
                "--quick, --near-threshold, --one-sided and --coefficients are bearing-map's, --readme "
                "bearing-tables' and bearing-map's"
            )
        return reduction(args)
    if args.readme and not args.near_threshold:
        raise InputError("bearing-map --readme writes the --near-threshold table: add --near-threshold")
    if args.readme and args.one_sided:
        raise InputError("bearing-map --readme compares both interpolations: leave --one-sided out")
    return bearing_map(args)


REDUCTION_CUTOFFS_HZ = (500.0, 700.0, 1000.0, 2000.0)
"""Cutoffs ``reduction`` compares beside the machine file's."""


def reduction(args: argparse.Namespace) -> int:
    """Print the reduced model's flow-equivalent error per cutoff and truth point (markdown table)."""
    from oilwatch.models.system.factory import build_system
    from oilwatch.models.system.reduction_check import reduction_flow_bias

    machine = load_machine_option(args)
    full = build_system(machine, reduced=False)
    own = machine.reduction_cutoff_hz
    print(
        f"reduced model against all {full.n_coordinates} coordinates; the machine file's cutoff: {own:g} Hz"
    )
    print("flow-equivalent error with probe offsets and unbalance free [% of nominal], bearing 1 / 2\n")
    print(
        "| cutoff [Hz] | coordinates | flowrates % | 1x error, worst probe [um] "
        "| 1x per 1 % flow, least [um] | flow error % |"
    )
    print("|---|---|---|---|---|---|")
    for cutoff in sorted({own, *REDUCTION_CUTOFFS_HZ}):
        for e in reduction_flow_bias(machine, cutoff, full=full):
            mark = " (file)" if cutoff == own else ""
            print(
                f"| {cutoff:g}{mark} | {e.n_coordinates} | {e.flowrates_pct[0]:g}/{e.flowrates_pct[1]:g} "
                f"| {e.orbit_error_um.max():.4f} | {e.orbit_sensitivity_um.min():.3f} "
                f"| {e.flow_bias_pct[0]:+.3f} / {e.flow_bias_pct[1]:+.3f} |"
            )
    return 0


def bearing_tables(args: argparse.Namespace) -> int:
    """Print the Lund & Thomsen and Ocvirk comparisons (markdown tables); plot them with ``--plot``; write
    them into a page's generated blocks with ``--readme``."""
    from oilwatch.models.bearing import published_tables as pt
    from oilwatch.models.bearing.grid import Mesh

    meshes = tuple(Mesh.from_text(text) for text in args.mesh) if args.mesh else pt.MESHES
    lund = pt.lund_rows(meshes)
    ocvirk = pt.ocvirk_rows()
    names = [f"{m.n_circ} x {m.n_axial}" for m in meshes]
    blocks = {
        "lund-worst": lund_worst_table(lund, meshes),
        "ocvirk": ocvirk_table(ocvirk),
        "lund-rows": lund_rows_table(lund, meshes),
    }
    print(f"## Lund & Thomsen (1978), oilwatch on {names[0]}\n")
    print(blocks["lund-rows"])
    print("\n## Worst per table (K, B errors in % of the matrix's largest published entry)\n")
    print(blocks["lund-worst"])
    print("\n## Ocvirk limit (line feed at the thickest film, 120 x 12)\n")
    print(blocks["ocvirk"])
    if args.plot:
        plot_bearing_tables(lund, ocvirk, meshes, args.plot)
        print(f"\nplot: {args.plot}")
    if args.readme:
        from .readme_block import replace_blocks

        options = [f"--mesh {m.n_circ}x{m.n_axial}" for m in meshes] if args.mesh else []
        if args.plot:
            options.append(f"--plot {args.plot}")
        command = " ".join(["oilwatch validate bearing-tables", *options, f"--readme {args.readme}"])
        replace_blocks(args.readme, blocks, command)
    return 0


def lund_rows_table(lund, meshes) -> str:
    """Every Lund & Thomsen row: the published value, oilwatch's on the first mesh, the error on each mesh
    (eccentricity and attitude absolute, K and B in % of the matrix's largest published entry)."""
    from oilwatch.models.bearing import published_tables as pt

    first = meshes[0]
    names = [f"{m.n_circ} x {m.n_axial}" for m in meshes]
    header = ["L/D", "S", "quantity", "Lund", "oilwatch", "error", *(f"error {n}" for n in names[1:])]
    lines = ["| " + " | ".join(header) + " |", "|---|---|---|---|---|" + "---|" * len(meshes)]
    for ld, rows in lund.items():
        for s, ref, values, _, _ in rows:
            errors = [pt.relative_errors(ref, values[m]) for m in meshes]
            for n in pt.COLUMNS:
                unit, scale = ("", 1.0) if n in ("eps", "phi") else (" %", 100.0)
                cells = " | ".join(f"{e[n] * scale:+.3f}{unit}" for e in errors)
                lines.append(f"| {ld} | {s} | {n} | {ref[n]:.3f} | {values[first][n]:.3f} | {cells} |")
    return "\n".join(lines)


def lund_worst_table(lund, meshes) -> str:
    """The worst quantity of each Lund & Thomsen table (L/D) on each mesh, what the squeeze term in the
    cavitated cells moves, and oilwatch's flooded flow at each row."""
    from oilwatch.models.bearing import published_tables as pt

    first = meshes[0]
    lines = [
        "| L/D | mesh | eps | phi [deg] | K | B | worst entry | squeeze everywhere moves "
        "| flow q/(R c L omega) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for ld, rows in lund.items():
        for mesh in meshes:
            worst = {n: 0.0 for n in pt.COLUMNS}
            where = {}
            for s, ref, values, _, _ in rows:
                for n, v in pt.relative_errors(ref, values[mesh]).items():
                    if abs(v) >= abs(worst[n]):
                        worst[n], where[n] = v, s
            k_name = max(pt.COLUMNS[2:6], key=lambda n: abs(worst[n]))
            b_name = max(pt.COLUMNS[6:10], key=lambda n: abs(worst[n]))
            entry = max(pt.COLUMNS[2:], key=lambda n: abs(worst[n]))
            on_first = mesh == first
            squeeze = (
                max(abs(v[mesh][n] - e[n]) for _, _, v, _, e in rows for n in pt.COLUMNS) if on_first else 0
            )
            flows = ", ".join(f"{f:.4f}" for _, _, _, f, _ in rows) if on_first else ""
            lines.append(
                f"| {ld} | {mesh.n_circ} x {mesh.n_axial} | {abs(worst['eps']):.4f} | "
                f"{abs(worst['phi']):.2f} | {abs(worst[k_name]) * 100:.2f} % ({k_name}, S {where[k_name]}) | "
                f"{abs(worst[b_name]) * 100:.2f} % ({b_name}, S {where[b_name]}) | {entry} | "
                f"{squeeze:.1e} | {flows} |"
            )
    return "\n".join(lines)


def ocvirk_table(ocvirk) -> str:
    """oilwatch against the Ocvirk closed forms at each (L/D, eccentricity ratio)."""
    lines = [
        "| L/D | eps Ocvirk | eps oilwatch | attitude error [deg] | flow / (eps R c L omega) - 1 | K | B |",
        "|---|---|---|---|---|---|---|",
    ]
    for ld, eps, e, dphi, dflow, ek, eb in ocvirk:
        lines.append(
            f"| {ld} | {eps} | {e:.4f} | {dphi:+.2f} | {dflow * 100:+.2f} % | {ek * 100:.2f} % | "
            f"{eb * 100:.2f} % |"
        )
    return "\n".join(lines)


def plot_bearing_tables(lund, ocvirk, meshes, path) -> None:
    """The comparison's figure: oilwatch's lines over Lund's circles, the Ocvirk errors, the worst entries."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from oilwatch.models.bearing.published_tables import COLUMNS, relative_errors

    first = meshes[0]
    fig, axes = plt.subplots(2, 4, figsize=(16, 7.5))
    for r, (ld, rows) in enumerate(lund.items()):
        s = np.array([row[0] for row in rows])
        for c, names in enumerate([("eps", "phi"), COLUMNS[2:6], COLUMNS[6:10]]):
            ax = axes[r, c]
            for n in names:
                ref = np.array([row[1][n] for row in rows])
                ours = np.array([row[2][first][n] for row in rows])
                if n == "phi":
                    ref, ours = ref / 100.0, ours / 100.0
                line = ax.plot(s, ours, "-", label=f"{n}{' / 100 deg' if n == 'phi' else ''}")[0]
                ax.plot(s, ref, "o", mfc="none", color=line.get_color())
            ax.set_xscale("log")
            ax.set_xlabel("Sommerfeld number S")
            ax.set_title(f"L/D = {ld}")
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.legend(fontsize=7)
            ax.grid(alpha=0.3)
    ax = axes[0, 3]
    for ld in sorted({row[0] for row in ocvirk}):
        chosen = [row for row in ocvirk if row[0] == ld]
        ax.plot([row[1] for row in chosen], [row[5] * 100 for row in chosen], "o-", label=f"K, L/D = {ld}")
        ax.plot([row[1] for row in chosen], [row[6] * 100 for row in chosen], "s--", label=f"B, L/D = {ld}")
    ax.set_xlabel("eccentricity ratio")
    ax.set_ylabel("% of the largest entry")
    ax.set_title("Ocvirk limit: oilwatch - closed form")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    ax = axes[1, 3]
    for ld, rows in lund.items():
        s = np.array([row[0] for row in rows])
        for mesh, style in zip(meshes, ("o-", "s--", "^:", "v-."), strict=False):
            worst = [
                max(
                    abs(v)
                    for n, v in relative_errors(row[1], row[2][mesh]).items()
                    if n not in ("eps", "phi")
                )
                for row in rows
            ]
            ax.plot(s, np.array(worst) * 100, style, label=f"L/D {ld}, {mesh.n_circ} x {mesh.n_axial}")
    ax.set_xscale("log")
    ax.set_xlabel("Sommerfeld number S")
    ax.set_ylabel("worst K, B error, % of largest entry")
    ax.set_title("Lund & Thomsen: worst coefficient per row")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.suptitle(
        f"Flooded two-axial-groove bearing: lines oilwatch ({first.n_circ} x {first.n_axial}), "
        "circles Lund & Thomsen (1978)"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def bearing_map(args: argparse.Namespace) -> int:
    """Print the dimensionless table's errors against direct solves, then against the 1-D nominal-speed
    table between its flowrate nodes."""
    from oilwatch.models.bearing.grid import Mesh
    from oilwatch.models.bearing.operating_accuracy import table_error
    from oilwatch.models.bearing.operating_table import OperatingTable, operating_table_path
    from oilwatch.models.bearing.sommerfeld import sommerfeld_number
    from oilwatch.models.bearing.table import CoefficientTable
    from oilwatch.models.rotor.assembly import Rotor
    from oilwatch.models.system.factory import flowrate_table_path, geometry_number

    machine = load_machine_option(args)
    index = 0 if args.bearing is None else bearing_index(machine, args.bearing)
    kind = args.coefficients or machine.dynamic_coefficients
    path = operating_table_path(machine.source_path, kind, geometry_number(machine, index))
    if not path.is_file():
        raise InputError(f"{kind} dimensionless table: {path} does not exist (oilwatch bearing-map makes it)")
    table = OperatingTable.load(path)
    print(f"{kind} coefficients: {path}")
    mesh = Mesh(**table.metadata["mesh"])
    bearing = machine.bearings[index]
    load = float(Rotor.from_machine(machine).bearing_static_loads_n[index])
    points = MAP_POINTS + (() if args.quick else MAP_SPREAD)
    if args.near_threshold:
        corners = tuple(dict.fromkeys((speed, mu) for speed, mu, _ in MAP_POINTS))
        if args.readme:
            from .readme_block import replace_block

            body = near_threshold_table(table, bearing, load, mesh, corners)
            print(body)
            machine_flag = [] if args.machine is None else [f"--machine {args.machine}"]
            bearing_flag = [] if args.bearing is None else [f"--bearing {args.bearing}"]
            command = " ".join(
                ["oilwatch validate bearing-map --near-threshold", *machine_flag, *bearing_flag,
                 f"--coefficients {kind}", f"--readme {args.readme}"]
            )  # fmt: skip
            replace_block(args.readme, f"near-threshold-{kind}", body, command)
            return 0
        points = tuple((v, m, f) for v, m in corners for f in NEAR_THRESHOLD_FRACTIONS)
    print("speed_Hz  mu_Pa_s  q/q_t   S      e_direct  err_e %  err_K %max  err_C %max")
    worst = np.zeros(3)
    for speed, mu, fraction in points:
        error = table_error(table, bearing, speed, mu, load, fraction, mesh, args.one_sided)
        sommerfeld = sommerfeld_number(bearing, mu, speed, load)
        row = np.array([error.eccentricity_ratio, error.stiffness, error.damping]) * 100
        worst = np.maximum(worst, row)
        print(
            f"{speed:8.1f}  {mu:7.3f}  {fraction:5.2f}  {sommerfeld:6.3f}  "
            f"{error.direct_eccentricity_ratio:8.4f}  {row[0]:7.3f}  {row[1]:10.3f}  {row[2]:10.3f}"
        )
        sys.stdout.flush()
    print(
        f"worst: eccentricity ratio {worst[0]:.3f} %, K {worst[1]:.3f} %, C {worst[2]:.3f} % "
        "of the largest entry"
    )
    one_d = CoefficientTable.load(flowrate_table_path(machine, machine.nominal_speed_hz, kind, index))
    q_low, q_high = one_d.flowrate_range_m3_s
    worst = np.zeros(3)
    for q in np.linspace(q_low, q_high, ONE_D_FLOWRATES):
        reference = one_d.evaluate(q)
        point = table.evaluate(one_d.speed_hz, bearing.viscosity_pa_s, one_d.load_n, q)
        k, c = point.coefficients.stiffness, point.coefficients.damping
        e_reference = np.hypot(*reference.eccentricity_m) / bearing.clearance_m
        worst = np.maximum(
            worst,
            [
                abs(point.eccentricity_ratio - e_reference) / e_reference * 100,
                np.max(np.abs(k - reference.stiffness)) / np.max(np.abs(reference.stiffness)) * 100,
                np.max(np.abs(c - reference.damping)) / np.max(np.abs(reference.damping)) * 100,
            ],
        )
    print(
        f"against the 1-D {one_d.speed_hz:g} Hz table at {ONE_D_FLOWRATES} flowrates: eccentricity ratio "
        f"{worst[0]:.3f} %, K {worst[1]:.3f} %, C {worst[2]:.3f} % of the largest entry"
    )
    return 0


def near_threshold_table(table, bearing, load_n, mesh, corners) -> str:
    """The dimensionless table against direct solves at :data:`NEAR_THRESHOLD_FRACTIONS` of each corner's
    (speed, viscosity) flooded threshold, interpolated across the threshold and one-sided: the worst K
    entry in % of the largest K, the worst C entry's in brackets."""
    from oilwatch.models.bearing.operating_accuracy import table_errors

    head = " | ".join(f"{'f = ' if i == 0 else ''}{f:g}" for i, f in enumerate(NEAR_THRESHOLD_FRACTIONS))
    lines = [f"| point | {head} |", "|---|" + "---|" * len(NEAR_THRESHOLD_FRACTIONS)]
    for speed, mu in corners:
        rows = ([], [])
        for fraction in NEAR_THRESHOLD_FRACTIONS:
            errors = table_errors(table, bearing, speed, mu, load_n, fraction, mesh, (False, True))
            for cells, error in zip(rows, errors, strict=True):
                cells.append(f"{error.stiffness * 100:.2f} ({error.damping * 100:.2f})")
        for label, cells in zip(("interpolated across the threshold", "one-sided"), rows, strict=True):
            lines.append(f"| {speed:g} Hz, {mu:g} Pa s, {label} | {' | '.join(cells)} |")
    return "\n".join(lines)
