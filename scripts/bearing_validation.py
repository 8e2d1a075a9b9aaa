"""oilwatch's film against Lund & Thomsen (1978) and the Ocvirk limit: the table and the plot of
docs/validation-bearing.md.

    python scripts/bearing_validation.py                       # 72 x 24 and 144 x 48 cells, table + plot
    python scripts/bearing_validation.py --plot docs/validation_bearing.png

The published rows, the bearing and the frame conversion are those of the tests
(tests/fixtures/published_bearings.py, tests/test_published_bearing_tables.py).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from fixtures.published_bearings import (
    COLUMNS,
    LUND_THOMSEN_1978,
    published,
    short_bearing,
    solve,
    two_groove_bearing,
)

from oilwatch.models.bearing.grid import Mesh

MESHES = (Mesh(72, 24), Mesh(144, 48))


def lund_rows():
    """{L/D: [(S, published, {mesh: values}, flow, squeeze-everywhere values)]}."""
    out = {}
    for ld, rows in LUND_THOMSEN_1978.items():
        bearing = two_groove_bearing(ld)
        out[ld] = []
        for row in rows:
            solved = {mesh: solve(bearing, row[0], mesh) for mesh in MESHES}
            everywhere, _, _ = solve(bearing, row[0], MESHES[0], squeeze="everywhere")
            flow = solved[MESHES[0]][1]
            out[ld].append((row[0], published(row), {m: v[0] for m, v in solved.items()}, flow, everywhere))
    return out


def errors(ref: dict, values: dict) -> dict:
    """eps and phi absolute; each K, B entry against its matrix's largest published entry."""
    largest_k = max(abs(ref[n]) for n in COLUMNS[2:6])
    largest_b = max(abs(ref[n]) for n in COLUMNS[6:10])
    out = {"eps": values["eps"] - ref["eps"], "phi": values["phi"] - ref["phi"]}
    out.update({n: (values[n] - ref[n]) / largest_k for n in COLUMNS[2:6]})
    out.update({n: (values[n] - ref[n]) / largest_b for n in COLUMNS[6:10]})
    return out


def ocvirk_rows():
    rows = []
    for ld in (0.25, 0.125, 0.0625):
        for eps in (0.1, 0.3, 0.5, 0.7):
            eq, k, b, flow, reference = short_bearing(ld, eps)
            rows.append(
                (
                    ld,
                    eps,
                    eq.eccentricity_ratio,
                    eq.attitude_deg - reference["phi"],
                    flow / eq.eccentricity_ratio - 1.0,
                    np.abs(k - reference["K"]).max() / np.abs(reference["K"]).max(),
                    np.abs(b - reference["B"]).max() / np.abs(reference["B"]).max(),
                )
            )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--plot", default="docs/validation_bearing.png", help="PNG to write")
    args = parser.parse_args()
    lund = lund_rows()
    fine, coarse = MESHES[1], MESHES[0]
    print("## Lund & Thomsen (1978), oilwatch on 72 x 24 (144 x 48 in brackets)\n")
    print("| L/D | S | quantity | Lund | oilwatch | error | error 144 x 48 |")
    print("|---|---|---|---|---|---|---|")
    for ld, rows in lund.items():
        for s, ref, values, _, _ in rows:
            e0, e1 = errors(ref, values[coarse]), errors(ref, values[fine])
            for n in COLUMNS:
                unit = "" if n in ("eps", "phi") else " %"
                scale = 1.0 if n in ("eps", "phi") else 100.0
                print(
                    f"| {ld} | {s} | {n} | {ref[n]:.3f} | {values[coarse][n]:.3f} | "
                    f"{e0[n] * scale:+.3f}{unit} | {e1[n] * scale:+.3f}{unit} |"
                )
    print("\n## Worst per table (K, B errors in % of the matrix's largest published entry)\n")
    print(
        "| L/D | mesh | eps | phi [deg] | K | B | worst entry | squeeze everywhere moves "
        "| flow q/(R c L omega) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for ld, rows in lund.items():
        for mesh in MESHES:
            worst = {n: 0.0 for n in COLUMNS}
            where = {}
            for s, ref, values, _, _ in rows:
                for n, v in errors(ref, values[mesh]).items():
                    if abs(v) >= abs(worst[n]):
                        worst[n], where[n] = v, s
            k_name = max(COLUMNS[2:6], key=lambda n: abs(worst[n]))
            b_name = max(COLUMNS[6:10], key=lambda n: abs(worst[n]))
            entry = max(COLUMNS[2:], key=lambda n: abs(worst[n]))
            squeeze = (
                max(abs(v[mesh][n] - e[n]) for _, _, v, _, e in rows for n in COLUMNS)
                if mesh == coarse
                else 0
            )
            flows = ", ".join(f"{f:.4f}" for _, _, _, f, _ in rows) if mesh == coarse else ""
            print(
                f"| {ld} | {mesh.n_circ} x {mesh.n_axial} | {abs(worst['eps']):.4f} | "
                f"{abs(worst['phi']):.2f} | "
                f"{abs(worst[k_name]) * 100:.2f} % ({k_name}, S {where[k_name]}) | "
                f"{abs(worst[b_name]) * 100:.2f} % ({b_name}, S {where[b_name]}) | {entry} | "
                f"{squeeze:.1e} | {flows} |"
            )
    print("\n## Ocvirk limit (line feed at the thickest film, 120 x 12)\n")
    print("| L/D | eps Ocvirk | eps oilwatch | attitude error [deg] | flow / (eps R c L omega) - 1 | K | B |")
    print("|---|---|---|---|---|---|---|")
    ocv = ocvirk_rows()
    for ld, eps, e, dphi, dflow, ek, eb in ocv:
        print(
            f"| {ld} | {eps} | {e:.4f} | {dphi:+.2f} | {dflow * 100:+.2f} % | {ek * 100:.2f} % | "
            f"{eb * 100:.2f} % |"
        )
    plot(lund, ocv, args.plot)
    print(f"\nplot: {args.plot}")


def plot(lund, ocv, path) -> None:
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 4, figsize=(16, 7.5))
    for r, (ld, rows) in enumerate(lund.items()):
        s = np.array([row[0] for row in rows])
        groups = [("eps", "phi"), COLUMNS[2:6], COLUMNS[6:10]]
        for c, names in enumerate(groups):
            ax = axes[r, c]
            for n in names:
                ref = np.array([row[1][n] for row in rows])
                ours = np.array([row[2][MESHES[0]][n] for row in rows])
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
    for ld in sorted({row[0] for row in ocv}):
        sel = [row for row in ocv if row[0] == ld]
        ax.plot([row[1] for row in sel], [row[5] * 100 for row in sel], "o-", label=f"K, L/D = {ld}")
        ax.plot([row[1] for row in sel], [row[6] * 100 for row in sel], "s--", label=f"B, L/D = {ld}")
    ax.set_xlabel("eccentricity ratio")
    ax.set_ylabel("% of the largest entry")
    ax.set_title("Ocvirk limit: oilwatch - closed form")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    ax = axes[1, 3]
    for ld, rows in lund.items():
        s = np.array([row[0] for row in rows])
        worst = [
            max(abs(v) for n, v in errors(row[1], row[2][MESHES[0]]).items() if n not in ("eps", "phi"))
            for row in rows
        ]
        worst_fine = [
            max(abs(v) for n, v in errors(row[1], row[2][MESHES[1]]).items() if n not in ("eps", "phi"))
            for row in rows
        ]
        ax.plot(s, np.array(worst) * 100, "o-", label=f"L/D {ld}, 72 x 24")
        ax.plot(s, np.array(worst_fine) * 100, "s--", label=f"L/D {ld}, 144 x 48")
    ax.set_xscale("log")
    ax.set_xlabel("Sommerfeld number S")
    ax.set_ylabel("worst K, B error, % of largest entry")
    ax.set_title("Lund & Thomsen: worst coefficient per row")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.suptitle("Flooded two-axial-groove bearing: lines oilwatch (72 x 24), circles Lund & Thomsen (1978)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
