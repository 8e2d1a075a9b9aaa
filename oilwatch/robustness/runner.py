"""Run every robustness case (:mod:`oilwatch.robustness.cases`) at both truth points, in worker processes.

Each case's row comes from :meth:`.case_run.RobustnessRun.run_case` (plant record, the product's estimator,
the row's figures: see :mod:`.case_run`). Cases run in worker processes (``workers``), each building the
models once; each finished row is written at once to ``robustness.json``, so nothing is lost when the run is
stopped, and ``resume`` keeps an earlier run's rows when the same settings and the same oilwatch
(:func:`sources_digest`) made them, so that a table never mixes rows of two versions. The table and the
coverage line are :mod:`.report_table`'s.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from oilwatch.models.validation import InputError
from oilwatch.outputs.atomic import write_json_atomic

from .case_run import RobustnessRun
from .cases import Case, case_by_name

POINTS_PCT = ((100.0, 100.0), (80.0, 90.0))
REPORT_SETTINGS = {
    "machine_file": None,
    "duration_s": 60.0,
    "noise_um": 1.0,
    "seed": 1,
    "offset_prior_um": 25.0,
    "unbalance_prior": 2.0,
    "viscosity_prior": 0.1,
}
"""The settings of the README's robustness report (:func:`run_robustness`'s defaults)."""

_RUN: RobustnessRun | None = None
_PACKAGE = Path(__file__).resolve().parents[1]
_SOURCE_SUFFIXES = (".py", ".json", ".toml")


def sources_digest(root: Path = _PACKAGE) -> str:
    """SHA-256 (first 16 hex digits) of the names and contents of every Python source, table and machine file
    of the oilwatch package at ``root``: what a robustness row depends on besides its settings."""
    digest = hashlib.sha256()
    files = []
    for folder, subfolders, names in os.walk(root, followlinks=True):  # the source tree links subpackages
        subfolders[:] = sorted(d for d in subfolders if d != "__pycache__")
        files += [Path(folder) / name for name in names if name.endswith(_SOURCE_SUFFIXES)]
    for path in sorted(files, key=lambda path: path.relative_to(root).as_posix()):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(hashlib.sha256(path.read_bytes()).digest())
    return digest.hexdigest()[:16]


def _worker_row(settings: dict, name: str, point) -> dict:
    global _RUN
    if _RUN is None or _RUN.settings != settings:
        _RUN = RobustnessRun(settings)
    try:
        return _RUN.run_case(case_by_name(name), tuple(point))
    except InputError as error:  # a case the models cannot run (e.g. outside a table) is reported, not fatal
        return {"case": name, "q1_pct": point[0], "q2_pct": point[1], "error": str(error)}


def run_robustness(
    cases: Sequence[Case],
    machine_file: str | None = None,
    duration_s: float = 60.0,
    noise_um: float = 1.0,
    seed: int = 1,
    offset_prior_um: float = 25.0,
    unbalance_prior: float = 2.0,
    viscosity_prior: float = 0.1,
    out_dir: str | Path | None = None,
    workers: int = 1,
    progress: Callable[[str], None] | None = None,
    resume: bool = False,
) -> list[dict]:
    """Every case at both truth points, in ``workers`` processes (1: in this process); each finished row is
    written to ``out_dir/robustness.json`` at once, with the settings and the :func:`sources_digest`. Rows
    come back in the cases' order. ``resume``: the rows an earlier run with the same settings and sources
    wrote there are kept and not run again (rows that could not run are run again)."""
    settings = {
        "machine_file": machine_file,
        "duration_s": duration_s,
        "noise_um": noise_um,
        "seed": seed,
        "offset_prior_um": offset_prior_um,
        "unbalance_prior": unbalance_prior,
        "viscosity_prior": viscosity_prior,
    }
    jobs = [(case.name, point) for case in cases for point in (case.points_pct or POINTS_PCT)]
    order = {job: k for k, job in enumerate(jobs)}
    rows: dict[int, dict] = {}
    path = Path(out_dir) / "robustness.json" if out_dir is not None else None
    sources = sources_digest() if path is not None else None
    if resume and path is not None:
        earlier, reason = _earlier_rows(path, settings, sources)
        for row in earlier:
            job = (row["case"], (row["q1_pct"], row["q2_pct"]))
            if job in order and "error" not in row:
                rows[order[job]] = row
        if progress is not None:
            progress(f"{len(rows)} of {len(jobs)} rows kept from {path}{reason}")

    def finished(job, row) -> None:
        rows[order[job]] = row
        if progress is not None:
            progress(f"{job[0]} at {job[1][0]:g}/{job[1][1]:g} % done ({len(rows)}/{len(jobs)})")
        if path is not None:
            document = {"settings": settings, "sources": sources, "rows": [rows[k] for k in sorted(rows)]}
            document["completed"] = len(rows) == len(jobs)  # the last row written says the run is whole
            write_json_atomic(path, document)

    todo = [job for job in jobs if order[job] not in rows]
    if workers <= 1:
        for job in todo:
            finished(job, _worker_row(settings, *job))
    elif todo:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(_worker_row, settings, *job): job for job in todo}
            for future in as_completed(futures):
                finished(futures[future], future.result())
    return [rows[k] for k in sorted(rows)]


def _earlier_rows(path: Path, settings: dict, sources: str) -> tuple[list[dict], str]:
    """The rows of an earlier ``robustness.json`` made with the same settings and sources (none otherwise),
    and why none were kept ("" when they were, or there was none)."""
    try:
        document = json.loads(path.read_text())
    except (OSError, ValueError):
        return [], ""
    if not isinstance(document, dict) or document.get("settings") != settings:
        return [], " (it was made with other settings)"
    if document.get("sources") != sources:
        return [], " (another version of oilwatch made it)"
    return [row for row in document.get("rows", []) if isinstance(row, dict) and "case" in row], ""
