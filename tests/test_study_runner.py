"""The study runner on a real local Dask cluster: stop and restart, torn lines, failing and flaky cases."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import cloudpickle
import pytest

from oilwatch.models.validation import InputError
from oilwatch.study import CaseModel, SyntheticCase, make_cases, run_study
from oilwatch.study.runner import dask_client
from oilwatch.study.storage import CaseStore

# The flaky case below lives in this test module, which the workers may not be able to import.
cloudpickle.register_pickle_by_value(sys.modules[__name__])

MODEL = CaseModel(SyntheticCase(), SyntheticCase().crlb, "synthetic")
CASES = make_cases([1.0, 2.0], grid_step_pct=12.5)  # 3 x 3 grid at two noise levels: 18 cases


@pytest.fixture(scope="module")
def client():
    with dask_client(workers=2) as dask:
        yield dask


def _comparable(summary: dict) -> dict:
    """The summary without its run-dependent timing."""
    return {key: value for key, value in summary.items() if key != "timing"}


@pytest.fixture(scope="module")
def reference(client, tmp_path_factory):
    """An uninterrupted run of the grid."""
    return run_study(
        CASES, tmp_path_factory.mktemp("reference"), MODEL, "synthetic", client=client, progress=False
    )


@pytest.mark.slow
def test_uninterrupted_study_is_complete(reference):
    summary = reference.summary
    assert summary["complete"] and reference.n_new == len(CASES) and not summary["failed_cases"]
    assert [level["n_cases"] for level in summary["noise_levels"]] == [9, 9]
    rows = CaseStore(reference.out_dir / "cases.csv").load()
    assert sorted(rows) == sorted(case.case_id for case in CASES)
    assert [path.name for path in reference.maps] == ["error_map_sigma1.png", "error_map_sigma2.png"]
    assert all(path.stat().st_size > 10_000 for path in reference.maps)


@pytest.mark.slow
def test_study_stopped_part_way_and_restarted_gives_the_same_summary(client, reference, tmp_path):
    first = run_study(CASES, tmp_path, MODEL, "synthetic", client=client, max_cases=5, progress=False)
    assert first.stopped_early and first.n_new == 5 and not first.summary["complete"]
    # A crash in the middle of a write leaves a torn last line.
    with open(tmp_path / "cases.csv", "a") as handle:
        handle.write("n2_q1-75_q2-75_s0,2.0,75.0,75")
    second = run_study(CASES, tmp_path, MODEL, "synthetic", client=client, progress=False)
    assert second.n_skipped == 5 and second.n_new == len(CASES) - 5
    assert _comparable(second.summary) == _comparable(reference.summary)
    lines = (tmp_path / "cases.csv").read_text().splitlines()
    assert len(lines) == 1 + len(CASES)


@pytest.mark.slow
def test_killed_study_restarts_where_it_stopped(client, reference, tmp_path):
    """Kill the process running a study (and its local cluster) part-way, then run it again."""
    script = textwrap.dedent(
        """
        import sys
        from oilwatch.study import CaseModel, SyntheticCase, make_cases, run_study
        slow = SyntheticCase(cpu_s=0.4)  # the same numbers as SyntheticCase(), only slower
        run_study(make_cases([1.0, 2.0], grid_step_pct=12.5), sys.argv[1], CaseModel(slow, slow.crlb),
                  "synthetic", workers=2, progress=False)
        """
    )
    process = subprocess.Popen(
        [sys.executable, "-c", script, str(tmp_path)],
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    csv_path = tmp_path / "cases.csv"
    deadline = time.monotonic() + 60.0
    try:
        while time.monotonic() < deadline and process.poll() is None:
            if csv_path.exists() and len(csv_path.read_text().splitlines()) >= 4:
                break
            time.sleep(0.02)
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    done = len(CaseStore(csv_path).load())
    assert 3 <= done < len(CASES), "the study was not stopped part-way"
    resumed = run_study(CASES, tmp_path, MODEL, "synthetic", client=client, progress=False)
    assert resumed.n_skipped == done and resumed.n_new == len(CASES) - done
    assert _comparable(resumed.summary) == _comparable(reference.summary)


@pytest.mark.slow
def test_case_that_always_fails_is_reported_and_the_study_completes(client, tmp_path):
    bad = CASES[4].case_id
    failing = SyntheticCase(fail_case_ids=frozenset({bad}))
    outcome = run_study(
        CASES, tmp_path, CaseModel(failing), "synthetic", client=client, retries=1, progress=False
    )
    assert [item["case_id"] for item in outcome.summary["failed_cases"]] == [bad]
    assert "CaseFailure" in outcome.summary["failed_cases"][0]["error"]
    assert outcome.n_new == len(CASES) - 1
    level = outcome.summary["noise_levels"][0]
    assert level["n_cases"] == 8 and not level["complete"] and level["mean_crlb_ratio"] is None
    assert bad not in CaseStore(tmp_path / "cases.csv").load()


@dataclass(frozen=True)
class FlakyCase:
    """Fails (or kills its worker) on the first attempt of every case, then behaves as SyntheticCase."""

    marker_dir: str
    kill_worker: bool = False

    def __call__(self, case):
        marker = Path(self.marker_dir) / case.case_id
        if not marker.exists():
            marker.touch()
            if self.kill_worker:
                os._exit(3)
            raise OSError(f"transient failure of {case.case_id}")
        return SyntheticCase()(case)


@pytest.mark.slow
def test_transient_failures_are_retried(client, reference, tmp_path):
    markers = tmp_path / "markers"
    markers.mkdir()
    cases = CASES[:9]
    outcome = run_study(
        cases,
        tmp_path / "out",
        CaseModel(FlakyCase(str(markers)), MODEL.crlb),
        "synthetic",
        client=client,
        retries=1,
        progress=False,
    )
    assert not outcome.failed and outcome.n_new == 9 and len(list(markers.iterdir())) == 9
    assert outcome.summary["noise_levels"][0] == reference.summary["noise_levels"][0]


@pytest.mark.slow
def test_a_dying_worker_is_replaced_and_its_case_rerun(client, tmp_path):
    markers = tmp_path / "markers"
    markers.mkdir()
    cases = CASES[:2]
    model = CaseModel(FlakyCase(str(markers), kill_worker=True))
    outcome = run_study(cases, tmp_path / "out", model, "synthetic", client=client, progress=False)
    assert not outcome.failed and outcome.n_new == 2 and len(list(markers.iterdir())) == 2
    client.wait_for_workers(2, timeout=30)


@pytest.mark.slow
def test_a_restart_with_other_record_settings_is_refused(client, reference):
    longer = make_cases([1.0, 2.0], grid_step_pct=12.5, duration_s=12.0)
    with pytest.raises(InputError, match="--duration-s"):
        run_study(longer, reference.out_dir, MODEL, "synthetic", client=client, progress=False)


def test_unreachable_scheduler_is_an_input_error():
    with (
        pytest.raises(InputError, match="--scheduler"),
        dask_client("tcp://127.0.0.1:9", connect_timeout_s=1.0),
    ):
        pass


@pytest.mark.slow
def test_study_runs_unchanged_on_an_existing_cluster(client, reference, tmp_path):
    """``--scheduler ADDRESS``: the runner connects its own client to a running scheduler."""
    outcome = run_study(
        CASES, tmp_path, MODEL, "synthetic", scheduler=client.scheduler.address, progress=False
    )
    assert _comparable(outcome.summary) == _comparable(reference.summary)
