"""Run the plant with each discrepancy of :mod:`oilwatch.robustness.cases` against the estimator.

Per case and truth point: the plant (full model, Newmark, constant flowrates) makes the record, the case's
discrepancy is applied, the EKF (reduced grid model; recommended tuning; probe offsets and the complex
unbalance as states with the configured priors) estimates, and the identified value is the mean estimate
over the second half of the record. Reported: error and the filter's own std (% of the true flowrate),
their ratio, whether the truth lies
within +-2 std at the end, false alarms (any alarm at a bearing at 95 % of nominal or more), detections (the
alarm set at the end for a bearing below 90 %), the probes flagged faulty, the share of the second half with a
consistent model, and the error over the nuisance Cramer-Rao bound (offsets and unbalance unknown, no
baseline, the whole record).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from estimator.baseline import estimate_baseline
from estimator.config import EKFConfig, OffsetBaseline
from estimator.ekf import OilFlowEKF
from models.machine import load_machine
from models.probes import read_probes
from models.rotor.assembly import Rotor
from models.system.augmented import GridAugmentedModel
from models.system.factory import build_system
from models.system.nuisance_bound import nuisance_bound
from models.system.plant import RotorBearingPlant

from .cases import Case, apply_offsets

DT_S = 1e-3
POINTS_PCT = ((100.0, 100.0), (80.0, 90.0))
ALARM_LEVEL_PCT = 90.0
HEALTHY_PCT = 95.0
"""A bearing at or above the alarm's clearing level (95 % of nominal) must never be alarmed; one at 90 %, the
setting level itself, is not judged."""


class RobustnessRun:
    """The models and plant records of one robustness run, built once and shared by the cases."""

    def __init__(
        self,
        machine_file: str | None,
        duration_s: float,
        noise_um: float,
        seed: int,
        offset_prior_um: float,
        unbalance_prior: float,
    ) -> None:
        self.machine = load_machine(machine_file)
        self.nominal_m3_s = self.machine.lubrication.nominal_flowrate_m3_s
        self.duration_s = duration_s
        self.noise_m = noise_um * 1e-6
        self.seed = seed
        self.offset_prior_m = offset_prior_um * 1e-6
        self.unbalance_prior = unbalance_prior
        self.probes = read_probes(self.machine)
        self.model = GridAugmentedModel(build_system(self.machine, reduced=True), DT_S)
        rotor = Rotor.from_machine(self.machine)
        self._unbalance = (rotor.unbalance_moment_kg_m, rotor.unbalance_phase_rad)
        self._systems: dict[tuple[float, float], object] = {}
        self._records: dict[tuple, np.ndarray] = {}
        self._bounds: dict[tuple[float, float], np.ndarray] = {}
        self._baseline: OffsetBaseline | None = None
        self.n_samples = round(duration_s / DT_S)

    def _system(self, unbalance: tuple[float, float]):
        if unbalance not in self._systems:
            moment, phase = self._unbalance
            self._systems[unbalance] = build_system(
                self.machine,
                reduced=False,
                unbalance_moment_kg_m=moment * unbalance[0],
                unbalance_phase_rad=phase + np.radians(unbalance[1]),
            )
        return self._systems[unbalance]

    def record(
        self,
        unbalance: tuple[float, float],
        point_pct: tuple[float, float],
        change: tuple[float, float] | None = None,
    ) -> np.ndarray:
        """Measured positions (K, 4) [m] of the plant at constant flowrates, samples at t = dt ... T; with
        ``change`` the unbalance switches to it at half the record (the plant continues from its state)."""
        key = (unbalance, point_pct, change)
        if key not in self._records:
            q = tuple(p / 100.0 * self.nominal_m3_s for p in point_pct)
            plant = RotorBearingPlant(
                self._system(unbalance), DT_S, None, self.noise_m, self.seed, initial_flowrates_m3_s=q
            )
            first = self.n_samples // 2 if change is not None else self.n_samples
            samples = [plant.step(q).measured_position_m for _ in range(first)]
            if change is not None:
                changed = RotorBearingPlant(
                    self._system(change), DT_S, None, self.noise_m, self.seed, initial_flowrates_m3_s=q
                )
                snapshot = plant.snapshot()
                # the cached constant-flow propagator carries the old unbalance's response: rebuild it
                snapshot["integrator"].update(propagator=None, propagator_flowrates=None, last_flowrates=None)
                changed.restore(snapshot)
                samples += [changed.step(q).measured_position_m for _ in range(self.n_samples - first)]
            self._records[key] = np.array(samples)
        return self._records[key]

    def baseline(self, config: EKFConfig) -> OffsetBaseline:
        """The offsets from a commissioning record at 100/100 % (another noise draw, the run's offsets)."""
        if self._baseline is None:
            q = (self.nominal_m3_s, self.nominal_m3_s)
            plant = RotorBearingPlant(
                self._system((1.0, 0.0)), DT_S, None, self.noise_m, self.seed + 1, initial_flowrates_m3_s=q
            )
            record = np.array([plant.step(q).measured_position_m for _ in range(self.n_samples)])
            times = DT_S * np.arange(1, len(record) + 1)
            document = estimate_baseline(self.model, apply_offsets(record, times, self.seed), q, config)
            self._baseline = OffsetBaseline(
                tuple(v * 1e-6 for v in document["offsets_um"]),
                tuple(v * 1e-6 for v in document["offset_std_um"]),
            )
        return self._baseline

    def bound_pct(self, point_pct: tuple[float, float]) -> np.ndarray:
        """(2,) nuisance Cramer-Rao bound [% of q] with offsets and unbalance unknown, no baseline."""
        if point_pct not in self._bounds:
            q = np.array(point_pct) / 100.0 * self.nominal_m3_s
            bound = nuisance_bound(
                self._system((1.0, 0.0)), q, self.noise_m, self.n_samples, ("offsets", "unbalance"), dt_s=DT_S
            )
            self._bounds[point_pct] = bound.std_pct
        return self._bounds[point_pct]

    def run_case(self, case: Case, point_pct: tuple[float, float]) -> dict:
        """The row of one case at one truth point (module docstring)."""
        data = self.record(case.unbalance, point_pct, case.unbalance_change)
        times = DT_S * np.arange(1, len(data) + 1)
        rng = np.random.default_rng([self.seed, sum(map(ord, case.name))])
        signals = case.inject(data, times, rng, self.model.system.omega_rad_s) if case.inject else data
        if case.offsets:
            signals = apply_offsets(signals, times, self.seed, case.drift_m)
        config = EKFConfig.recommended(
            speed_hz=self.machine.nominal_speed_hz,
            first_sample_time_s=DT_S,
            noise_std_m=self.noise_m,
            offset_prior_std_m=self.offset_prior_m,
            offset_random_walk_m_sqrt_s=self.probes.offset_random_walk_m_sqrt_s,
            unbalance_prior_std=self.unbalance_prior,
            **case.ekf,
        )
        if case.baseline:
            config = dataclasses.replace(config, offset_baseline=self.baseline(config))
        trace = OilFlowEKF(self.model, config).run(signals)
        truth = np.array(point_pct) / 100.0 * self.nominal_m3_s
        half = len(data) // 2
        error_pct = 100.0 * (trace.q_m3_s[half:].mean(axis=0) / truth - 1.0)
        std_pct = 100.0 * trace.q_std_m3_s[-1] / truth
        settled = trace.starved[len(data) // 10 :]
        low = np.array(point_pct) < ALARM_LEVEL_PCT
        healthy = np.array(point_pct) >= HEALTHY_PCT
        flagged = sorted({int(c) for c in np.flatnonzero(trace.probe_faulty.any(axis=0))})
        bound = self.bound_pct(point_pct)
        return {
            "case": case.name,
            "description": case.description,
            "q1_pct": point_pct[0],
            "q2_pct": point_pct[1],
            "error_pct": error_pct.tolist(),
            "std_pct": std_pct.tolist(),
            "error_over_std": (np.abs(error_pct) / std_pct).tolist(),
            "within_2_std": bool((np.abs(error_pct) <= 2.0 * std_pct).all()),
            "false_alarm": bool(settled[:, healthy].any()),
            "detected": [bool(trace.starved[-1, b]) for b in range(2) if low[b]],
            "flagged_probes": flagged,
            "fault_flagged": None if case.probe_fault is None else case.probe_fault in flagged,
            "consistent_fraction": float(trace.model_consistent[half:].mean()),
            "bound_pct": bound.tolist(),
            "error_over_bound": (np.abs(error_pct) / bound).tolist(),
        }


def run_robustness(
    cases: Sequence[Case],
    machine_file: str | None = None,
    duration_s: float = 60.0,
    noise_um: float = 1.0,
    seed: int = 1,
    offset_prior_um: float = 25.0,
    unbalance_prior: float = 2.0,
    out_dir: str | Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[dict]:
    """Every case at both truth points; each finished row is appended to ``out_dir/robustness.json``."""
    run = RobustnessRun(machine_file, duration_s, noise_um, seed, offset_prior_um, unbalance_prior)
    rows: list[dict] = []
    path = Path(out_dir) / "robustness.json" if out_dir is not None else None
    for case in cases:
        for point in POINTS_PCT:
            if progress is not None:
                progress(f"{case.name} at {point[0]:g}/{point[1]:g} %")
            rows.append(run.run_case(case, point))
            if path is not None:
                settings = {
                    "duration_s": duration_s,
                    "noise_um": noise_um,
                    "seed": seed,
                    "offset_prior_um": offset_prior_um,
                    "machine_file": machine_file,
                }
                path.write_text(json.dumps({"settings": settings, "rows": rows}, indent=1) + "\n")
    return rows


def format_table(rows: Sequence[dict]) -> list[str]:
    """The rows as a Markdown table (errors and stds in % of the true flowrate, q1 / q2)."""
    lines = [
        "| case | truth % | error % | filter std % | within 2 std | false alarm | 80 % alarmed "
        "| flagged probes | consistent | error / bound |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        detected = "-" if not r["detected"] else ("yes" if all(r["detected"]) else "NO")
        flagged = ",".join(("x1", "y1", "x2", "y2")[c] for c in r["flagged_probes"]) or "-"
        error, std, ratio = r["error_pct"], r["std_pct"], r["error_over_bound"]
        cells = [
            r["case"],
            f"{r['q1_pct']:g}/{r['q2_pct']:g}",
            f"{error[0]:+.2f} / {error[1]:+.2f}",
            f"{std[0]:.2f} / {std[1]:.2f}",
            "yes" if r["within_2_std"] else "NO",
            "YES" if r["false_alarm"] else "no",
            detected,
            flagged,
            f"{r['consistent_fraction']:.2f}",
            f"{ratio[0]:.1f} / {ratio[1]:.1f}",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return lines
