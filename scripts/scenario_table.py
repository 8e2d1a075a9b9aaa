"""Run every scenario at 1 and 2 um with both tunings and print the README's scenario table (Markdown).

Each run is ``oilwatch run SCENARIO --noise-um N [--paper-tuning]`` (20 s, seed 1) through the two FMUs;
their folders go to ``OUT/<scenario>-<noise>um[-paper]/``. About 5 minutes on a 2-core machine.

Usage: ``OPENBLAS_NUM_THREADS=1 python scripts/scenario_table.py [--out scenario_runs] [--machine FILE]``
(``--machine``: another machine file, e.g. a copy of the turbine's with ``bearings.dynamic_coefficients =
"quasi-static"`` and its tables beside it, to compare the coefficient kinds).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from oilwatch.models.machine import load_machine
from oilwatch.scenarios import PAPER_TUNING, SCENARIOS, make_run
from oilwatch.scenarios.fmus import ensure_fmus
from oilwatch.scenarios.runner import run_scenario

PAPER_TEXT = {
    ("constant", 1): "-",
    ("constant", 2): "-",
    ("drop-b1", 1): "b1 ~4 / <1; b2 ~4 / ~2",
    ("drop-b1", 2): "b1 ~9 / ~2; b2 ~9 / ~1",
    ("drop-b2", 1): "b1 ~4 / ~2; b2 ~4 / <1",
    ("drop-b2", 2): "b1 ~9 / ~1; b2 ~9 / ~2",
    ("clog-b1", 1): "b1 ~4 / ~1; b2 (125 %) ~4 / ~9",
    ("clog-b1", 2): "b1 ~9 / ~1; b2 (125 %) ~9 / ~14",
    ("clog-b2", 1): "b1 (125 %) ~4 / ~12; b2 ~4 / ~1",
    ("clog-b2", 2): "b1 (125 %) ~9 / ~14; b2 ~9 / ~1",
}
"""The paper's rounded errors before / after the transition [%] (section 3.2.2), where it gives them per
bearing; the three drops of both bearings share ``~4 / <1`` (1 um) and ``~9 / ~2`` (2 um)."""


def _pct(value) -> str:
    return "-" if value is None else f"{value:.2f}"


def _errors(summary: dict) -> str:
    return (
        f"{_pct(summary['q1_err_pct_before'])} / {_pct(summary['q1_err_pct_after'])}; "
        f"{_pct(summary['q2_err_pct_before'])} / {_pct(summary['q2_err_pct_after'])}"
    )


def _alarms(summary: dict) -> str:
    delays = [summary[f"alarm_delay_s_b{b}"] for b in (1, 2)]
    return ", ".join("none" if d is None else f"{d:+.2f}" for d in delays)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="scenario_runs", help="folder of the runs (default: scenario_runs)")
    parser.add_argument("--machine", help="machine file (default: the bundled turbine)")
    parser.add_argument("--recommended-only", action="store_true", help="skip the paper-tuning runs")
    args = parser.parse_args()
    machine = load_machine(args.machine)
    fmu_dir = ensure_fmus(machine=machine if args.machine else None)
    rows = []
    for name in SCENARIOS:
        if SCENARIOS[name].speed_profile or SCENARIOS[name].oil_temperature_profile:
            continue  # the paper's scenarios only (at the nominal operating point)
        for noise in (1, 2):
            summaries = []
            for paper in (False,) if args.recommended_only else (False, True):
                overrides = {"ekf": dict(PAPER_TUNING)} if paper else None
                run = make_run(name, noise_um=float(noise), overrides=overrides, machine=machine)
                folder = Path(args.out) / f"{name}-{noise}um{'-paper' if paper else ''}"
                summaries.append(run_scenario(run, folder, fmu_dir=fmu_dir, progress=False, plot=True))
            ours, papers = summaries if len(summaries) == 2 else (summaries[0], None)
            paper_text = PAPER_TEXT.get((name, noise), "~4 / <1" if noise == 1 else "~9 / ~2")
            rows.append(
                f"| `{name}` | {noise} | {paper_text} | {_errors(ours)} | {_alarms(ours)} | "
                f"{_errors(papers) if papers else '-'} | {_alarms(papers) if papers else '-'} |"
            )
            print(rows[-1], flush=True)
    print()
    print(
        "| scenario | noise [um] | paper: before / after [%] "
        "| oilwatch: b1 before / after; b2 before / after [%] | alarm b1, b2 [s from centre] "
        "| oilwatch, paper's tuning: b1; b2 [%] | alarm b1, b2 [s] |"
    )
    print("|---|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
