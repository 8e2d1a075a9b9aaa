"""The bundled machines side by side: the table of docs/compressor.md, written by

    python -m oilwatch.cli.machine_comparison --readme docs/compressor.md

Each machine's rotor, bearings, speed, load and flows come from its machine file (the flooded threshold by a
steady solve on the production mesh at the nominal speed, viscosity and load); then, in a temporary folder,
``oilwatch demo`` and the README's quick start (a) (its commands, read from the README, with ``--machine``),
a minute or two a machine, more where the demo must build the FMUs first; and the robustness subset's counts
from the committed result files (``docs/results/robustness/``: the compressor's folder, and the turbine's
rows of the same cases, a later file's row replacing an earlier one's as ``oilwatch robustness --from-json``
does). Groove angles are the machine file's (0 deg: top).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import re
import shlex
import sys
import tempfile
from pathlib import Path

from oilwatch.models.bearing.grid import PRODUCTION_MESH
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
from oilwatch.models.bearing.table import flooded_threshold
from oilwatch.models.machine import BUNDLED_MACHINES, Machine, load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.validation import InputError

from .readme_block import replace_block

COMMAND = "python -m oilwatch.cli.machine_comparison"
BLOCK = "machine-comparison"
REPOSITORY = Path(__file__).resolve().parents[2]
ROBUSTNESS_RESULTS = REPOSITORY / "docs" / "results" / "robustness"
COMPRESSOR_RESULTS = "compressor"
"""The compressor's folder under :data:`ROBUSTNESS_RESULTS`; every other folder there is the turbine's."""
NUMBERS = {1: "one", 2: "two", 3: "three", 4: "four"}


def machine_rows(machine: Machine) -> list[str]:
    """The machine file's cells: rotor and bearings; speed and load per bearing; nominal supply and flooded
    threshold."""
    rotor = Rotor.from_machine(machine)
    bearing = machine.bearing
    angles = [bearing.groove_angle_rad, *(groove.angle_rad for groove in bearing.more_grooves)]
    count = len(angles)
    degrees = " and ".join(f"{math.degrees(a):g}" for a in angles)
    grooves = f"{NUMBERS.get(count, count)} axial groove{'s' if count > 1 else ''} at {degrees} deg"
    if bearing.circumferential_groove_m > 0.0:
        grooves += ", a circumferential groove"
    loads = sorted({round(float(w), 1) for w in rotor.bearing_static_loads_n})
    load = " / ".join(f"{w:.1f}" for w in loads)
    load_n = float(rotor.bearing_static_loads_n[0])
    threshold, _ = flooded_threshold(bearing, load_n, machine.nominal_speed_hz, PRODUCTION_MESH)
    nominal = machine.shared_nominal_flowrate_m3_s("the machine comparison") * ML_MIN_PER_M3_S
    return [
        f"{len(machine.element_lengths_m)} elements, {rotor.total_mass_kg:.0f} kg; {grooves}",
        f"{machine.nominal_speed_hz:g} Hz, {load} N",
        f"{nominal:.1f} / {threshold * ML_MIN_PER_M3_S:.1f} ml/min",
    ]


MACHINE_LABELS = (
    "rotor, bearings (groove angles from the top)",
    "speed, load per bearing",
    "nominal supply / flooded threshold",
)


def demo_cells(summary: dict) -> list[str]:
    """``oilwatch demo``'s summary: the error after the drop and the alarm's delay, bearing 1 / 2."""
    errors = " / ".join(f"{summary[f'q{b}_err_pct_after']:.2f}" for b in (1, 2))
    delays = [summary[f"alarm_delay_s_b{b}"] for b in (1, 2)]
    alarms = " / ".join("none" if d is None else f"{d:.2f}" for d in delays)
    return [f"{errors} %", f"{alarms} s"]


DEMO_LABELS = (
    "`oilwatch demo`: error after the drop, bearing 1 / 2",
    "`oilwatch demo`: alarm after the drop's centre",
)


def quick_start_cells(summary: dict) -> list[str]:
    """``oilwatch estimate``'s summary at the end of quick start (a): each bearing's flowrate and its share
    of nominal, and the alarms."""
    cells = []
    for b in (1, 2):
        q, nominal = summary[f"q{b}_final_ml_min"], summary[f"q{b}_nominal_ml_min"]
        cells.append(f"{q:.1f} ml/min ({100.0 * q / nominal:.1f} % of nominal)")
    alarms = [f"bearing {a['bearing']} at {a['time_s']:.3f} s" for a in summary["alarms"]]
    cells.append(", ".join(alarms) or "none")
    return cells


QUICK_START_LABELS = (
    "quick start (a), bearing 1 at 80 %",
    "quick start (a), bearing 2 at 100 %",
    "quick start (a), alarms",
)


def robustness_counts(turbine: bool) -> str:
    """Rows of the robustness subset with the truth within 2 std / the error within tolerance / a false
    alarm: the compressor's result file, or the turbine's rows of the same cases."""
    compressor = _rows([ROBUSTNESS_RESULTS / COMPRESSOR_RESULTS / "robustness.json"])
    if turbine:
        cases = {row["case"] for row in compressor.values()}
        files = sorted(
            p for p in ROBUSTNESS_RESULTS.glob("*/robustness.json") if p.parent.name != COMPRESSOR_RESULTS
        )
        rows = {key: row for key, row in _rows(files).items() if key[0] in cases}
    else:
        rows = compressor
    counts = [
        sum(bool(row[k]) for row in rows.values())
        for k in ("within_2_std", "within_tolerance", "false_alarm")
    ]
    return f"{' / '.join(map(str, counts))} of {len(rows)} rows"


def _rows(paths) -> dict[tuple, dict]:
    rows = {}
    for path in paths:
        for row in json.loads(Path(path).read_text(encoding="utf-8"))["rows"]:
            rows[row["case"], row["q1_pct"], row["q2_pct"]] = row
    return rows


ROBUSTNESS_LABEL = "robustness subset below: truth within 2 std / error within tolerance / false alarms"


def quick_start_commands(readme: Path = REPOSITORY / "README.md") -> list[list[str]]:
    """The oilwatch commands of the README's quick start (a), without the leading ``oilwatch``."""
    text = readme.read_text(encoding="utf-8")
    found = re.search(r"## Quick start \(a\).*?```sh\n(.*?)```", text, re.S)
    if found is None:
        raise InputError(f"{readme}: no sh block under '## Quick start (a)'")
    commands = []
    for line in found.group(1).splitlines():
        words = shlex.split(line, comments=True)
        if words:
            commands.append(words[1:])
    return commands


def run_machine(name: str, folder: Path) -> tuple[dict, dict]:
    """``oilwatch demo`` and the quick start (a) for the bundled machine ``name`` in ``folder``: (the demo's
    summary, the estimate's summary)."""
    from oilwatch.cli import main

    machine = [] if name == "turbine" else ["--machine", name]
    steps = [["demo", *machine, "--out", "demo", "--no-progress"]]
    steps += [[words[0], *machine, *words[1:]] for words in quick_start_commands()]
    with contextlib.chdir(folder):
        for words in steps:
            print(f"{name}: oilwatch {shlex.join(words)}", file=sys.stderr)
            with contextlib.redirect_stdout(io.StringIO()):
                code = main(words)
            if code not in (0, None):
                raise InputError(f"{name}: oilwatch {shlex.join(words)} exited with {code}")
    estimate = next(words for words in steps if words[0] == "estimate")
    out = estimate[estimate.index("--out") + 1]
    return (
        json.loads((folder / "demo" / "summary.json").read_text(encoding="utf-8")),
        json.loads((folder / out / "summary.json").read_text(encoding="utf-8")),
    )


def comparison_table(columns: dict[str, list[str]]) -> str:
    """The markdown table: one row per label, one column per machine (its cells in label order)."""
    labels = (*MACHINE_LABELS, *DEMO_LABELS, *QUICK_START_LABELS, ROBUSTNESS_LABEL)
    names = list(columns)
    heads = [f"{n} (the default)" if n == "turbine" else n for n in names]
    lines = [f"| | {' | '.join(heads)} |", "|---|" + "---|" * len(names)]
    for row, label in enumerate(labels):
        lines.append(f"| {label} | {' | '.join(columns[n][row] for n in names)} |")
    return "\n".join(lines)


def machine_column(name: str, folder: Path) -> list[str]:
    """Every cell of the bundled machine ``name``'s column (runs its demo and quick start in ``folder``)."""
    demo, estimate = run_machine(name, folder)
    return [
        *machine_rows(load_machine(BUNDLED_MACHINES[name])),
        *demo_cells(demo),
        *quick_start_cells(estimate),
        robustness_counts(turbine=name == "turbine"),
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--readme", required=True, metavar="FILE", help="page to update (block machine-comparison)"
    )
    args = parser.parse_args(argv)
    try:
        columns = {}
        for name in BUNDLED_MACHINES:
            with tempfile.TemporaryDirectory(prefix=f"oilwatch_{name}_") as folder:
                columns[name] = machine_column(name, Path(folder))
        table = comparison_table(columns)
        print(table)
        replace_block(args.readme, BLOCK, table, f"{COMMAND} --readme {args.readme}")
    except (InputError, OSError) as error:
        print(f"{COMMAND}: error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
