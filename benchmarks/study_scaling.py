"""Throughput of ``oilwatch study`` on a local Dask cluster: cases per minute with 1 and with 2 workers.

For each worker count a local cluster is started (not timed), warmed up with a few cases (imports, model or
FMU loading), then ``--cases`` cases of the 1 % grid at 1 um are run ``--repeats`` times, each into a fresh
folder; the time is the study's dispatch loop (submission to last row synced to disk; summary and plots are
not timed). Prints the median cases per minute for each worker count and the ratio 2 workers / 1 worker
(ideal 2.0 on a 2-core machine with nothing else running).

``--case`` picks the case model from the registry (``cosim``: the two FMUs through the master, as
``oilwatch study`` runs by default; ``direct``: the same models in-process; ``synthetic``: ``--cpu-s`` of CPU
per case, with 0 the figure is Dask's own per-task overhead).

Usage: ``python benchmarks/study_scaling.py [--case cosim] [--cpu-s 0.5] [--cases 24] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from oilwatch.study import CaseModel, SyntheticCase, get_case_model, make_cases, run_study
from oilwatch.study.runner import dask_client


def case_model(name: str, cpu_s: float) -> CaseModel:
    """The registered case model, with the synthetic one's CPU cost set to ``cpu_s``."""
    if name == "synthetic":
        synthetic = SyntheticCase(cpu_s=cpu_s)
        return CaseModel(synthetic, synthetic.crlb, "synthetic")
    return get_case_model(name)


def cases_per_minute(workers: int, model: CaseModel, name: str, n_cases: int, repeats: int) -> list[float]:
    """Cases per minute of ``repeats`` runs of ``n_cases`` cases on a local cluster of ``workers``."""
    cases = make_cases([1.0], grid_step_pct=1.0)
    rates = []
    with dask_client(workers=workers) as client, tempfile.TemporaryDirectory() as scratch:
        run_study(
            cases, Path(scratch) / "warmup", model, name, client=client, max_cases=2 * workers, progress=False
        )
        for repeat in range(repeats):
            outcome = run_study(
                cases,
                Path(scratch) / f"run{repeat}",
                model,
                name,
                client=client,
                max_cases=n_cases,
                progress=False,
            )
            rates.append(outcome.summary["timing"]["cases_per_min"])
    return rates


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", default="cosim", help="case model name (default: cosim)")
    parser.add_argument(
        "--cpu-s", type=float, default=0.5, help="CPU seconds per synthetic case (default: 0.5)"
    )
    parser.add_argument("--cases", type=int, default=24, help="cases per timed run (default: 24)")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per worker count (default: 3)")
    args = parser.parse_args()
    model = case_model(args.case, args.cpu_s)
    detail = f", {args.cpu_s:g} CPU s per case" if args.case == "synthetic" else ""
    print(f"study scaling: case model {args.case}{detail}, {args.cases} cases x {args.repeats} runs, "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} before the run")  # fmt: skip
    medians = {}
    for workers in (1, 2):
        rates = cases_per_minute(workers, model, args.case, args.cases, args.repeats)
        medians[workers] = statistics.median(rates)
        runs = ", ".join(f"{rate:.1f}" for rate in rates)
        print(f"  {workers} worker(s): median {medians[workers]:8.1f} cases/min   (runs: {runs})")
    print(f"  ratio 2 workers / 1 worker: {medians[2] / medians[1]:.2f} (ideal 2.00)")


if __name__ == "__main__":
    main()
