"""The nuisance Cramer-Rao bound of each robustness case in the case's own configuration.

"error / bound" compares a row's error with what any unbiased estimator could do with the same record and
the same unknowns. The unknowns are the estimator's: the probe offsets (``offset_prior_um`` > 0), the complex
unbalance (``unbalance_prior`` > 0) and, in an operating-point case with viscosity states, the two viscosity
factors; a case with a baseline adds the information of its 60 s commissioning record at 100/100 % (flowrates
known) as a prior on those nuisances, widened by the offsets' drift since (3 um in ``offsets-drift`` and
``offsets-step``). The truth is the case's plant: its unbalance (size and phase) and film viscosity factor.

* Cases at constant conditions: the full model at the machine's speed
  (:func:`oilwatch.models.system.nuisance_bound.nuisance_bound`, closed-form harmonic Fisher information).
* Operating-point cases (viscosity, ramps, all at once): the estimator's own operating maps on the
  dimensionless table, which the plant of these cases shares, summed along the case's speed and oil
  temperature trajectory (:func:`oilwatch.models.system.trajectory_bound.trajectory_information`, quasi-steady
  segments).

Both treat the nuisances and flowrates as constant over the record: the filter's random walks make its own
best std larger than this bound, never smaller.
"""

from __future__ import annotations

import math

import numpy as np

from oilwatch.models.system.factory import build_system
from oilwatch.models.system.nuisance_bound import nuisance_bound
from oilwatch.models.system.trajectory_bound import (
    OperatingSegment,
    nuisance_prior,
    trajectory_bound_pct,
    trajectory_information,
)

from .cases import DRIFT_M, Case

SEGMENTS = 12
"""Quasi-steady segments along a record (5 s each for 60 s): 24 move the bound by < 1 % (a test)."""


def free_groups(case: Case, settings: dict) -> tuple[str, ...]:
    """The nuisance groups the case's estimator estimates."""
    groups = []
    if settings["offset_prior_um"] > 0.0:
        groups.append("offsets")
    if settings["unbalance_prior"] > 0.0:
        groups.append("unbalance")
    if case.operating_point and case.viscosity_states and settings["viscosity_prior"] > 0.0:
        groups.append("viscosity")
    return tuple(groups)


def configuration_label(case: Case, settings: dict) -> str:
    """What the bound assumes, e.g. ``offsets+unbalance+viscosity, ramp, baseline, drift 3 um``."""
    parts = ["+".join(free_groups(case, settings)) or "all known"]
    if case.speed_ramp_hz is not None or case.temperature_rise_c:
        parts.append("along the ramp")
    if case.baseline:
        parts.append("baseline")
    if case.drift or case.offset_step:
        parts.append(f"drift {DRIFT_M * 1e6:g} um")
    return ", ".join(parts)


class CaseBounds:
    """Bounds of the cases of one robustness run (``settings`` as :func:`run_robustness` writes them)."""

    def __init__(self, machine, settings: dict, dt_s: float) -> None:
        self.machine = machine
        self.settings = settings
        self.dt_s = dt_s
        self.duration_s = float(settings["duration_s"])
        self.noise_m = float(settings["noise_um"]) * 1e-6
        self.n_samples = round(self.duration_s / dt_s)
        self._systems: dict = {}
        self._maps = None
        self._cache: dict = {}

    def bound_pct(self, case: Case, point_pct) -> np.ndarray:
        """(2,) the bound on (q1, q2) [% of the true flowrates] for the case at the truth point."""
        key = (case.name, tuple(point_pct))
        if key not in self._cache:
            groups = free_groups(case, self.settings)
            q = np.asarray(point_pct, dtype=float) / 100.0 * self.machine.lubrication.nominal_flowrates_m3_s
            if not groups:
                groups_bound = self._constant(case, q, ())
            elif case.operating_point:
                groups_bound = self._trajectory(case, q, groups)
            else:
                groups_bound = self._constant(case, q, groups)
            self._cache[key] = groups_bound
        return self._cache[key]

    def _drift(self, case: Case) -> dict[str, float]:
        return {"offset": DRIFT_M * 1e6} if case.drift or case.offset_step else {}

    def _constant(self, case: Case, q: np.ndarray, groups) -> np.ndarray:
        unbalance = case.unbalance
        if unbalance not in self._systems:
            rotor_system = build_system(self.machine, reduced=False)
            self._systems[unbalance] = build_system(
                self.machine,
                reduced=False,
                unbalance_moment_kg_m=rotor_system.unbalance_moment_kg_m * unbalance[0],
                unbalance_phase_rad=rotor_system.unbalance_phase_rad + math.radians(unbalance[1]),
            )
        nominal = tuple(float(q) for q in self.machine.lubrication.nominal_flowrates_m3_s)
        bound = nuisance_bound(
            self._systems[unbalance],
            q,
            self.noise_m,
            self.n_samples,
            groups,
            dt_s=self.dt_s,
            baseline_flowrates_m3_s=nominal if case.baseline else None,
            baseline_samples=self.n_samples,
            drift_std=self._drift(case),
        )
        return bound.std_pct

    def operating_maps(self):
        """(maps, output matrix) of the estimator's operating model (built once)."""
        if self._maps is None:
            from oilwatch.models.system.operating_model import build_operating_model

            model = build_operating_model(build_system(self.machine, reduced=True), self.machine, self.dt_s)
            self._maps = (model.maps, np.asarray(model.output_matrix))
        return self._maps

    def point(self, case: Case, t: float, duration_s: float) -> OperatingSegment:
        """The case's speed and oil viscosity at time ``t`` of its record, held for ``duration_s``."""
        machine = self.machine
        speed = machine.nominal_speed_hz
        if case.speed_ramp_hz is not None:
            start, end = case.speed_ramp_hz
            speed = start + (end - start) * t / self.duration_s
        temperature = machine.nominal_oil_temperature_c + case.temperature_rise_c * t / self.duration_s
        return OperatingSegment(speed, machine.oil.dynamic_viscosity_pa_s(temperature), duration_s)

    def segments(self, case: Case, count: int = SEGMENTS) -> list[OperatingSegment]:
        """The case's operating point at the middle of ``count`` equal segments of the record."""
        length = self.duration_s / count
        return [self.point(case, (i + 0.5) * length, length) for i in range(count)]

    def _trajectory(self, case: Case, q: np.ndarray, groups) -> np.ndarray:
        maps, h = self.operating_maps()
        factors = (case.viscosity_factor, case.viscosity_factor)
        unbalance = case.unbalance[0] * complex(math.cos(math.radians(case.unbalance[1])), 0.0)
        unbalance += 1j * case.unbalance[0] * math.sin(math.radians(case.unbalance[1]))
        information = trajectory_information(
            maps, h, self.dt_s, q, self.segments(case), self.noise_m, factors, unbalance
        )
        prior = None
        if case.baseline:
            # the commissioning record: 100/100 %, at the ramp's start conditions, as long as the run
            start = self.point(case, 0.0, self.duration_s)
            nominal = np.array(self.machine.lubrication.nominal_flowrates_m3_s)
            baseline = trajectory_information(
                maps, h, self.dt_s, nominal, [start], self.noise_m, factors, unbalance
            )
            prior = nuisance_prior(baseline, groups, self._drift(case))
        return trajectory_bound_pct(information, groups, prior)
