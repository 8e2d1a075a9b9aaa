"""The per-case contract of the study: ``run_case(case: Case) -> CaseResult``, and a synthetic case.

A case function runs one identification (truth with noise, estimator, record) and reduces the estimator's
record with :func:`reduce_record`: the identified flowrate is the mean estimate over the record after the
discarded first part (the paper's "average value estimated after the convergence"). It must be a picklable
module-level callable (it runs on Dask workers), deterministic for a given case (the noise comes from
``case.rng_seed``), and raise on failure (never return NaN).

:class:`SyntheticCase` is a cheap stand-in with the same record shape as an EKF's (convergence from the
nominal flowrate, correlated estimate noise growing with the measurement noise, a smooth bias map); it tests
the study machinery, and its numbers say nothing about oilwatch's estimator.
"""

from __future__ import annotations

import os
import socket
import time
from dataclasses import asdict, dataclass

import numpy as np

from .grid import SAMPLE_DT_S, Case


class CaseFailure(RuntimeError):
    """A case ran but gave no usable identification (diverged, non-finite or empty record)."""


@dataclass(frozen=True)
class CaseResult:
    """Outcome of one case; flowrates in ml/min, errors in % of the true flowrate.

    q*_est_ml_min: identified flowrate (mean estimate after ``discard_s``). q*_err_pct: signed relative error
    100 (est - true) / true. q*_std_ml_min: the estimator's own std at the end of the record.
    q*_spread_ml_min: std of the estimate over the averaging window. n_averaged: samples averaged.
    wall_s: wall time of the case [s]. worker: host and process that ran it.
    crlb_q*_ml_min: Cramer-Rao bound on the std of each estimate (NaN when the case model has none).
    """

    case_id: str
    noise_um: float
    q1_pct: float
    q2_pct: float
    seed: int
    q1_true_ml_min: float
    q2_true_ml_min: float
    q1_est_ml_min: float
    q2_est_ml_min: float
    q1_err_pct: float
    q2_err_pct: float
    q1_std_ml_min: float
    q2_std_ml_min: float
    q1_spread_ml_min: float
    q2_spread_ml_min: float
    n_averaged: int
    wall_s: float
    worker: str
    crlb_q1_ml_min: float = float("nan")
    crlb_q2_ml_min: float = float("nan")

    def as_row(self) -> dict:
        """The result as a flat dict (the columns of ``cases.csv``)."""
        return asdict(self)


def worker_name() -> str:
    """``host:pid`` of the running process."""
    return f"{socket.gethostname()}:{os.getpid()}"


def reduce_record(
    case: Case,
    times_s: np.ndarray,
    estimates_ml_min: np.ndarray,
    stds_ml_min: np.ndarray,
    wall_s: float,
) -> CaseResult:
    """Identified flowrates and errors from an estimator's record.

    times_s (n,): sample times [s]; estimates_ml_min (n, 2): estimated q1, q2; stds_ml_min (n, 2): the
    estimator's std of each. The samples at ``t >= case.discard_s`` are averaged.
    """
    times = np.asarray(times_s, dtype=float)
    estimates = np.asarray(estimates_ml_min, dtype=float)
    stds = np.asarray(stds_ml_min, dtype=float)
    if estimates.shape != (times.size, 2) or stds.shape != (times.size, 2):
        raise CaseFailure(
            f"case {case.case_id}: record shapes times {times.shape}, estimates {estimates.shape}, "
            f"stds {stds.shape}; need (n,), (n, 2), (n, 2)"
        )
    # Half a sample of tolerance: recorded times carry rounding from summing steps.
    window = times >= case.discard_s - 0.5 * SAMPLE_DT_S
    if not window.any():
        raise CaseFailure(f"case {case.case_id}: no sample after --discard-s = {case.discard_s:g} s")
    kept = estimates[window]
    if not (np.all(np.isfinite(kept)) and np.all(np.isfinite(stds[-1]))):
        raise CaseFailure(f"case {case.case_id}: the estimate is not finite (estimator diverged)")
    identified = kept.mean(axis=0)
    truth = np.array([case.q1_ml_min, case.q2_ml_min])
    error_pct = 100.0 * (identified - truth) / truth
    spread = kept.std(axis=0)
    return CaseResult(
        case_id=case.case_id,
        noise_um=case.noise_um,
        q1_pct=case.q1_pct,
        q2_pct=case.q2_pct,
        seed=case.seed,
        q1_true_ml_min=float(truth[0]),
        q2_true_ml_min=float(truth[1]),
        q1_est_ml_min=float(identified[0]),
        q2_est_ml_min=float(identified[1]),
        q1_err_pct=float(error_pct[0]),
        q2_err_pct=float(error_pct[1]),
        q1_std_ml_min=float(stds[-1, 0]),
        q2_std_ml_min=float(stds[-1, 1]),
        q1_spread_ml_min=float(spread[0]),
        q2_spread_ml_min=float(spread[1]),
        n_averaged=int(window.sum()),
        wall_s=float(wall_s),
        worker=worker_name(),
    )


@dataclass(frozen=True)
class SyntheticCase:
    """A deterministic, cheap stand-in for the co-simulated case (for tests and benchmarks).

    The estimate of each flowrate starts at the nominal value, converges with time constant
    ``convergence_s`` to ``truth + bias``, and carries AR(1) noise (coefficient ``noise_memory``) whose
    stationary std is ``noise_gain_ml_min_per_um`` per um of measurement noise. The bias is a smooth map
    of (q1, q2) of amplitude ``bias_pct_per_um`` per um of noise. ``cpu_s`` burns that much CPU time per
    case (to benchmark scaling with a known cost); a case whose id is in ``fail_case_ids`` always raises.
    """

    convergence_s: float = 1.0
    noise_gain_ml_min_per_um: float = 6.0
    noise_memory: float = 0.995
    bias_pct_per_um: float = 0.6
    cpu_s: float = 0.0
    fail_case_ids: frozenset[str] = frozenset()

    def bias_pct(self, case: Case) -> np.ndarray:
        """(2,) the synthetic estimator's relative bias [%] at the case's flowrates and noise."""
        u, v = np.deg2rad(14.0 * case.q1_pct), np.deg2rad(9.0 * case.q2_pct)
        shape = np.array([np.sin(u) * np.cos(v), np.cos(u + 0.5) * np.sin(v + 1.0)])
        return self.bias_pct_per_um * case.noise_um * shape

    def noise_std_ml_min(self, case: Case) -> float:
        """Stationary std of the synthetic estimate's noise [ml/min]."""
        return self.noise_gain_ml_min_per_um * case.noise_um

    def __call__(self, case: Case) -> CaseResult:
        """Run the synthetic case."""
        from scipy.signal import lfilter  # half a second to import: only where it is used

        start = time.perf_counter()
        if case.case_id in self.fail_case_ids:
            raise CaseFailure(f"case {case.case_id}: synthetic failure (listed in fail_case_ids)")
        _burn_cpu(self.cpu_s)
        rng = np.random.default_rng(case.rng_seed)
        times = SAMPLE_DT_S * np.arange(1, case.n_samples + 1)
        truth = np.array([case.q1_ml_min, case.q2_ml_min])
        settled = truth * (1.0 + self.bias_pct(case) / 100.0)
        decay = np.exp(-times / self.convergence_s)[:, None]
        a = self.noise_memory
        innovation = self.noise_std_ml_min(case) * np.sqrt(1.0 - a * a)
        noise = lfilter([1.0], [1.0, -a], innovation * rng.standard_normal((times.size, 2)), axis=0)
        estimates = settled + (np.array(case.nominal_ml_min) - settled) * decay + noise
        stds = np.full((times.size, 2), self.noise_std_ml_min(case)) * (1.0 + 20.0 * decay)
        return reduce_record(case, times, estimates, stds, time.perf_counter() - start)

    def crlb(self, case: Case) -> np.ndarray:
        """(2,) std [ml/min] of the mean of the synthetic AR(1) noise over the window: its efficient error."""
        n = case.n_samples - round(case.discard_s / SAMPLE_DT_S)
        a = self.noise_memory
        return np.full(2, self.noise_std_ml_min(case) * np.sqrt((1.0 + a) / ((1.0 - a) * n)))


def _burn_cpu(seconds: float) -> None:
    """Spend ``seconds`` of this thread's CPU time on small matrix products."""
    if seconds <= 0.0:
        return
    end = time.thread_time() + seconds
    block = np.eye(40)
    while time.thread_time() < end:
        block = np.tanh(block @ block)
