"""Run the study's cases on Dask, one task per case, appending each finished case to ``cases.csv`` at once.

By default a local cluster of worker processes is started, one single-threaded worker per core; with a
scheduler address the same study runs on an existing Dask cluster. Cases already in ``DIR/cases.csv`` are
skipped, so a stopped study started again continues where it stopped. A case whose task raises is retried
(``retries``); if it still fails it is listed in the summary's ``failed_cases`` and the study goes on.
"""

from __future__ import annotations

import asyncio
import logging
import os
import re
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from uuid import uuid4

import numpy as np

from oilwatch.models.validation import InputError
from oilwatch.outputs import interrupts, ledger
from oilwatch.outputs.atomic import write_json_atomic
from oilwatch.outputs.lock import output_lock

from .cases import CaseResult
from .grid import Case
from .plots import error_map_name, plot_error_map
from .registry import CaseModel
from .storage import CaseStore, check_manifest
from .summary import summarize

SCHEDULER_ADDRESS = re.compile(r"^(tcp|tls|ucx|ws|wss)://[^\s/:]+:\d{1,5}$")
SINGLE_THREAD_ENV = {"OPENBLAS_NUM_THREADS": 1, "OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1}
"""Set in each local worker before it starts: BLAS must not spread over cores already given to workers."""


def available_cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def check_cluster_options(scheduler: str | None, workers: int | None) -> None:
    """Raise InputError unless ``scheduler`` is None or a Dask address and ``workers`` is valid."""
    if scheduler is not None:
        if workers is not None:
            raise InputError("--workers applies to the local cluster only; drop it with --scheduler")
        if not SCHEDULER_ADDRESS.match(scheduler):
            raise InputError(f"--scheduler must look like tcp://HOST:8786, got {scheduler!r}")
    if workers is not None and (int(workers) != workers or workers < 1):
        raise InputError(f"--workers must be an integer >= 1, got {workers!r}")


@contextmanager
def dask_client(
    scheduler: str | None = None, workers: int | None = None, connect_timeout_s: float = 10.0
) -> Iterator:
    """A ``distributed.Client``: on the cluster at ``scheduler``, else on a new local cluster.

    The local cluster has ``workers`` (default: one per core) single-threaded worker processes, with
    :data:`SINGLE_THREAD_ENV` set before each worker process is spawned (``pre-spawn-environ``; numpy reads
    it at import, so the nanny's ``env`` would come too late).
    """
    import dask
    from distributed import Client, LocalCluster

    check_cluster_options(scheduler, workers)
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=f"{connect_timeout_s}s")
        except (OSError, TimeoutError) as error:
            raise InputError(f"--scheduler {scheduler}: no Dask scheduler answers there ({error})") from None
        try:
            yield client
        finally:
            client.close()
        return
    n_workers = available_cores() if workers is None else int(workers)
    environ = {
        f"distributed.nanny.pre-spawn-environ.{name}": value for name, value in SINGLE_THREAD_ENV.items()
    }
    with dask.config.set(environ):
        cluster = LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
    try:
        with Client(cluster) as client:
            yield client
    finally:
        cluster.close()


def execute_case(model: CaseModel, case: Case) -> dict:
    """The Dask task of one case: run it, attach its Cramer-Rao bound, return the ``cases.csv`` row."""
    from threadpoolctl import threadpool_limits

    # Also on clusters this process did not start, whose workers' environment it cannot set.
    with threadpool_limits(limits=1):
        result: CaseResult = model.run_case(case)
        row = result.as_row()
        if model.crlb is not None:
            bound = np.asarray(model.crlb(case), dtype=float)
            row["crlb_q1_ml_min"], row["crlb_q2_ml_min"] = float(bound[0]), float(bound[1])
    return row


@dataclass
class StudyOutcome:
    """What a call of :func:`run_study` did: the summary, its files, and the cases of this run."""

    summary: dict
    out_dir: Path
    n_new: int
    n_skipped: int
    failed: list[dict] = field(default_factory=list)
    stopped_early: bool = False
    maps: list[Path] = field(default_factory=list)


def _settings(cases: Sequence[Case], model_name: str) -> dict:
    durations = {case.duration_s for case in cases}
    discards = {case.discard_s for case in cases}
    if len(durations) != 1 or len(discards) != 1:
        raise InputError("cases: all cases of a study must share duration_s and discard_s")
    return {
        "case_model": model_name,
        "duration_s": durations.pop(),
        "discard_s": discards.pop(),
        "noise_um": sorted({case.noise_um for case in cases}),
        "grid_pct": sorted({case.q1_pct for case in cases} | {case.q2_pct for case in cases}, reverse=True),
        "n_seeds": len({case.seed for case in cases}),
        "n_cases": len(cases),
    }


def run_study(
    cases: Sequence[Case],
    out_dir: str | Path,
    model: CaseModel,
    model_name: str,
    *,
    client=None,
    scheduler: str | None = None,
    workers: int | None = None,
    retries: int = 2,
    max_cases: int | None = None,
    progress: bool = True,
) -> StudyOutcome:
    """Run the cases not yet in ``out_dir/cases.csv``, then write ``summary.json`` and the error maps.

    client: an existing ``distributed.Client`` to use (else one is made from ``scheduler``/``workers``,
    see :func:`dask_client`). retries: extra attempts of a failing task. max_cases: stop after this many
    new cases (the rest stay for a later run), e.g. to run a long study in slices.
    """
    if not cases:
        raise InputError("cases: the study has no case")
    if int(retries) != retries or retries < 0:
        raise InputError(f"--retries must be an integer >= 0, got {retries!r}")
    if client is None:
        check_cluster_options(scheduler, workers)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with output_lock(out, "study"):
        return _run_locked(
            cases, out, model, model_name, client, scheduler, workers, retries, max_cases, progress
        )


def _run_locked(cases, out, model, model_name, client, scheduler, workers, retries, max_cases, progress):
    """:func:`run_study` while holding the folder's lock."""
    settings = _settings(cases, model_name)
    check_manifest(out, settings)
    log = _CaseLog(CaseStore(out / "cases.csv"))
    remaining = [case for case in cases if case.case_id not in log.rows]
    todo = remaining if max_cases is None else remaining[: int(max_cases)]
    n_done = len(cases) - len(remaining)
    start = time.perf_counter()
    # summary.json is the study's last word: until then it says that the study is under way
    write_json_atomic(out / "summary.json", {"completed": False, "status": "running"})
    ledger.keep("cases.csv", lambda: f"{log.store.path} keeps {len(log.rows)} whole case rows")
    try:
        if todo and client is None:
            with dask_client(scheduler, workers) as own_client:
                _run_cases(own_client, todo, model, log, retries, progress, len(cases), n_done)
        elif todo:
            _run_cases(client, todo, model, log, retries, progress, len(cases), n_done)
    except BaseException as error:
        status = (
            f"interrupted ({interrupts.signal_name(error)})"
            if isinstance(error, KeyboardInterrupt)
            else f"failed: {error}"
        )
        partial = {"completed": False, "status": status, "cases_done": len(log.rows), "cases": len(cases)}
        try:
            write_json_atomic(out / "summary.json", partial)
            ledger.keep("summary", lambda: "summary.json says partial; the same command continues")
        except OSError:
            pass
        raise
    finally:
        log.store.close()
    wall_s = time.perf_counter() - start
    summary = summarize(log.rows, cases, log.failed, settings)
    summary["timing"] = {
        "wall_s": wall_s,
        "cases_run": len(log.new_rows),
        "cases_per_min": 60.0 * len(log.new_rows) / wall_s if log.new_rows and wall_s > 0 else None,
        "mean_case_wall_s": float(np.mean([row["wall_s"] for row in log.new_rows])) if log.new_rows else None,
        # over every run of a resumed study: the cases' own times (with one worker, its wall time)
        "case_wall_s_total": float(
            sum(log.rows[case.case_id]["wall_s"] for case in cases if case.case_id in log.rows)
        ),
    }
    maps = _plot_maps(log.rows, cases, out, model_name)
    summary["completed"] = all(case.case_id in log.rows for case in cases)
    summary["status"] = "completed" if summary["completed"] else "partial: cases left for a later run"
    write_json_atomic(out / "summary.json", summary)
    ledger.forget("cases.csv")
    return StudyOutcome(
        summary,
        out,
        n_new=len(log.new_rows),
        n_skipped=len(cases) - len(remaining),
        failed=log.failed,
        stopped_early=len(todo) < len(remaining),
        maps=maps,
    )


class _CaseLog:
    """The study's finished rows (on disk and in memory) and this run's failures."""

    def __init__(self, store: CaseStore) -> None:
        self.store = store
        self.rows = store.load()
        self.new_rows: list[dict] = []
        self.failed: list[dict] = []

    def finished(self, row: dict) -> None:
        self.store.append(row)
        self.rows[row["case_id"]] = row
        self.new_rows.append(row)

    def failure(self, case: Case, error: BaseException) -> None:
        self.failed.append({"case_id": case.case_id, "error": f"{type(error).__name__}: {error}"[:500]})


def _run_cases(
    client,
    todo: Sequence[Case],
    model: CaseModel,
    log: _CaseLog,
    retries: int,
    progress: bool,
    n_total: int,
    n_done: int,
) -> None:
    """Submit one task per case and record each as it completes."""
    from distributed import as_completed
    from tqdm import tqdm

    tag = uuid4().hex[:8]
    futures = {
        client.submit(
            execute_case, model, case, key=f"oilwatch-case-{case.case_id}-{tag}", retries=retries, pure=False
        ): case
        for case in todo
    }
    n_workers = len(client.scheduler_info().get("workers", {}))
    bar = tqdm(
        total=n_total,
        initial=n_done,
        unit="case",
        desc=f"study on {n_workers} workers",
        file=sys.stderr,
        disable=not progress,
        dynamic_ncols=True,
    )
    try:
        for future in as_completed(futures):
            case = futures[future]
            if future.status == "finished":
                log.finished(future.result())
            else:
                log.failure(case, _task_error(future))
                bar.set_postfix(failed=len(log.failed))
            future.release()
            bar.update(1)
    finally:
        client.cancel(list(futures))
        bar.close()


def _task_error(future) -> BaseException:
    """The exception of a failed or cancelled task."""
    try:
        return future.exception()
    except (Exception, asyncio.CancelledError) as error:
        # A cancelled task (scheduler restarted, cluster shut down) has no exception of its own.
        return error


def _plot_maps(rows: dict, cases: Sequence[Case], out: Path, model_name: str) -> list[Path]:
    """One error map per noise level that has finished cases."""
    percents = np.array(sorted({case.q1_pct for case in cases} | {case.q2_pct for case in cases}))
    note = "" if model_name == "cosim" else f"case model: {model_name}"
    paths = []
    for noise in sorted({case.noise_um for case in cases}):
        ids = {case.case_id for case in cases if case.noise_um == noise}
        level_rows = [row for case_id, row in rows.items() if case_id in ids]
        if level_rows:
            nominal = cases[0].nominal_ml_min
            path = out / error_map_name(noise)
            paths.append(plot_error_map(level_rows, percents, noise, path, note, nominal))
    return paths
