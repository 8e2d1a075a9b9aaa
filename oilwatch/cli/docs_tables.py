"""Documentation tables generated from the code's own declarations or from a command's run, written into a
page's generated blocks:

    python -m oilwatch.cli.docs_tables --page docs/machine-file.md
    python -m oilwatch.cli.docs_tables --page docs/performance.md --outputs [NAME ...]

``machine-keys``: every key of a machine file (:data:`oilwatch.models.machine_keys.MACHINE_KEYS`).
``presets``: the estimator's named configurations (:data:`oilwatch.estimator.ekf_config.PRESETS`).
``scenarios``: the runnable scenarios (:data:`oilwatch.scenarios.SCENARIOS`).
``output-NAME``: with ``--outputs``, the command written in the block's own marker
(``<!-- generated output-NAME: COMMAND -->``) is run from the repository's top, and its standard output
replaces the block as a text block (a benchmark's table: the marker says how to rerun it). The other tables of
runs are written by the commands that make them (``oilwatch report --readme``, ``oilwatch robustness
--readme``, ``python -m oilwatch.cosim.fmu_docs --readme``).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
from pathlib import Path

from oilwatch.estimator.ekf_config import PRESETS
from oilwatch.experiment_config import SCENARIO_DEFAULTS
from oilwatch.models.machine_keys import markdown_table
from oilwatch.models.system.fault import SCENARIO_DURATIONS_S
from oilwatch.models.validation import InputError
from oilwatch.scenarios import CONSTANT_FLOW_SCENARIOS, SCENARIOS

from .readme_block import replace_block, replace_blocks

COMMAND = "python -m oilwatch.cli.docs_tables"
OUTPUT_BLOCK = re.compile(r"<!-- generated (output-[\w-]+): ([^\n]*?) -->")
REPOSITORY = Path(__file__).resolve().parents[2]


MACHINE_LOAD = (
    (re.compile(r"^\s*load average[^\n]*\n", re.M), ""),
    (re.compile(r";?\s*1-min load average [\d.\-]+"), ""),
    (re.compile(r",\s*load \d+(?:\.\d+)?(?=\s*$)", re.M), ""),
)
"""What a benchmark prints of the machine's load average: left out of a page, which states the machine once
(the load of the moment is no figure of the code)."""


def presets_table() -> str:
    """The estimator's presets as a markdown table: name, whether it is the default, what it is, its
    configuration fields over the recommended ones, the probes and the bearing model it assumes."""
    lines = [
        "| preset | default | what it is | configuration over the recommended | probes | bearing model |",
        "|---|---|---|---|---|---|",
    ]
    for index, preset in enumerate(PRESETS):
        fields = ", ".join(f"`{name} = {value}`" for name, value in preset.fields) or "-"
        probes = (
            "offsets estimated (the machine file's `[probes]` prior, or the baseline); scale factors "
            "known to the file's tolerance"
            if preset.offsets_from_machine
            else "offsets zero, scale factors exact"
        )
        model = (
            "follows the measured speed and oil temperature (`bearing_table = 1`)"
            if preset.follow_operating_point
            else "the flowrate grid at one speed (`bearing_table = 0`)"
        )
        default = "yes" if index == 0 else "no"
        lines.append(
            f"| `{preset.name}` | {default} | {preset.description} | {fields} | {probes} | {model} |"
        )
    return "\n".join(lines)


def scenarios_table() -> str:
    """The scenarios of ``oilwatch run`` as a markdown table: each bearing's flowrate (initial -> final, % of
    nominal), the 10 %-90 % transition time and the operating-point profiles."""

    def flow(scenario, bearing: int) -> str:
        if scenario.name in CONSTANT_FLOW_SCENARIOS:
            default = SCENARIO_DEFAULTS.q1_pct if bearing == 1 else SCENARIO_DEFAULTS.q2_pct
            return f"`--q{bearing}-pct` ({default:g})"
        initial, final = scenario.q1_pct if bearing == 1 else scenario.q2_pct
        return f"{initial:g} %" if initial == final else f"{initial:g} -> {final:g} %"

    lines = [
        "| scenario | what happens | bearing 1 | bearing 2 | transition (10-90 %) | speed, oil temperature |",
        "|---|---|---|---|---|---|",
    ]
    for scenario in SCENARIOS.values():
        changes = scenario.q1_pct[0] != scenario.q1_pct[1] or scenario.q2_pct[0] != scenario.q2_pct[1]
        transition = f"{SCENARIO_DURATIONS_S[scenario.speed]:g} s ({scenario.speed})" if changes else "-"
        profiles = [
            f"{label} `{text}`"
            for label, text in (
                ("speed", scenario.speed_profile),
                ("oil", scenario.oil_temperature_profile),
            )
            if text
        ]
        operating = ", ".join(profiles) or "nominal"
        lines.append(
            f"| `{scenario.name}` | {scenario.title} | {flow(scenario, 1)} | {flow(scenario, 2)} | "
            f"{transition} | {operating} |"
        )
    return "\n".join(lines)


GENERATED_TABLES = {
    "machine-keys": markdown_table,
    "presets": presets_table,
    "scenarios": scenarios_table,
}
"""The tables a page's blocks take from the code's declarations, by block name."""


def without_machine_load(text: str) -> str:
    for pattern, replacement in MACHINE_LOAD:
        text = pattern.sub(replacement, text)
    return text


def output_blocks(page: str | Path) -> dict[str, str]:
    """{block name: its command} of a page's ``output-NAME`` blocks."""
    return dict(OUTPUT_BLOCK.findall(Path(page).read_text(encoding="utf-8")))


def run_outputs(page: str | Path, names: list[str]) -> list[str]:
    """Run the command of each ``output-NAME`` block of ``page`` (all when ``names`` is empty) and write its
    standard output into the block; return the names written."""
    blocks = output_blocks(page)
    chosen = names or list(blocks)
    for name in chosen:
        if name not in blocks:
            raise InputError(f"--outputs: {page} has no block {name!r}; it has {', '.join(blocks) or 'none'}")
        done = subprocess.run(blocks[name], shell=True, cwd=REPOSITORY, capture_output=True, text=True)
        if done.returncode != 0:
            raise InputError(
                f"{name}: {blocks[name]!r} exited {done.returncode}: {done.stderr.strip()[-400:]}"
            )
        output = without_machine_load(done.stdout).rstrip()
        replace_block(page, name, f"```text\n{output}\n```", blocks[name])
    return chosen


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--page", action="append", required=True, metavar="FILE", help="page to update")
    parser.add_argument(
        "--outputs",
        nargs="*",
        default=None,
        metavar="NAME",
        help="rerun the page's output blocks (all, or named)",
    )
    args = parser.parse_args(argv)
    try:
        for page in args.page:
            if args.outputs is not None:
                run_outputs(page, args.outputs)
            else:
                bodies = {name: make() for name, make in GENERATED_TABLES.items()}
                replace_blocks(page, bodies, f"{COMMAND} --page {page}")
    except (InputError, OSError) as error:
        print(f"{COMMAND}: error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
