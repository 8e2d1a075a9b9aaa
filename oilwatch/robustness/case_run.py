"""One robustness case at one truth point: the plant with the case's discrepancy against the estimator.

Per case and truth point: the plant (:class:`oilwatch.models.system.plant.RotorBearingPlant`, full model,
Newmark, constant flowrates) makes the record through its own measurement chain with the case's probe errors,
unbalance, viscosity and operating point; the EKF (reduced grid model; recommended tuning; probe offsets and
the complex unbalance as states with the configured priors; the baseline and the slow-roll vectors when the
case has them) estimates; the identified value is the mean estimate over the second half of the record.
Reported: error and the filter's own std (% of the true flowrate), their ratio, whether the truth lies within
+-2 std at the end, false alarms (any alarm, after the first tenth, at a bearing at 95 % of nominal or more),
detections (the alarm set at the end for a bearing below 90 %), the probes flagged faulty, the share of the
second half with a consistent model and the share with a model-mismatch status (the published estimate then
the static change's or held: :mod:`oilwatch.estimator.baseline_change`), the filter's own error beside the
published one, whether every alarm was raised under a consistent model, and the error
over the nuisance Cramer-Rao bound of the case's own configuration (:mod:`.bounds`: the nuisances its
estimator estimates, its baseline, its speed and temperature trajectory; the whole record). The estimator is
the product's, built by :func:`oilwatch.estimator.factory.make_estimator` and run through ``run_batch`` as
``oilwatch estimate`` runs it: with nuisances that no baseline primed the start bank
(:class:`oilwatch.estimator.start_bank.StartBank`: several starts along the flowrates' prior, the record's NIS
picks one), else one :class:`oilwatch.estimator.ekf.OilFlowEKF`.
"""

from __future__ import annotations

import dataclasses
import inspect
import math

import numpy as np

from oilwatch.estimator.baseline import baseline_prior, estimate_baseline
from oilwatch.estimator.baseline_change import CONSISTENT
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.estimator.factory import make_estimator
from oilwatch.estimator.runout import runout_of_probes
from oilwatch.models.machine import load_machine
from oilwatch.models.probes import read_probes
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.augmented import GridAugmentedModel
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.measurement import MeasurementChain, UnbalanceChange
from oilwatch.models.system.operating_point import operating_system
from oilwatch.models.system.plant import RotorBearingPlant
from oilwatch.models.system.structure import structural_system
from oilwatch.models.validation import InputError

from .bounds import CaseBounds, configuration_label
from .cases import BASELINE_AGE_DAYS, Case, probe_errors
from .coast_down import measured_clearances
from .slow_roll import slow_roll_vectors

DT_S = 1e-3
ALARM_LEVEL_PCT = 90.0
HEALTHY_PCT = 95.0
"""A bearing at or above the alarm's clearing level (95 % of nominal) must never be alarmed; one at 90 %, the
setting level itself, is not judged."""


def _accepts(function, name: str) -> bool:
    return name in inspect.signature(function).parameters


def case_bounds(cache: dict, machine, settings: dict, case: Case) -> CaseBounds:
    """The :class:`CaseBounds` of the case's own record length (a case may run shorter than the run), kept
    in ``cache``."""
    duration = settings["duration_s"]
    if case.duration_s is not None:
        duration = min(case.duration_s, duration)
    if duration not in cache:
        cache[duration] = CaseBounds(machine, {**settings, "duration_s": duration}, DT_S)
    return cache[duration]


class RobustnessRun:
    """The models of one robustness run, built once per process and shared by its cases."""

    def __init__(self, settings: dict) -> None:
        self.settings = settings
        self.machine = load_machine(settings["machine_file"])
        # each bearing's: a case's percentages are of its own bearing's nominal
        self.nominal_m3_s = tuple(float(q) for q in self.machine.lubrication.nominal_flowrates_m3_s)
        self.duration_s = settings["duration_s"]
        self.noise_m = settings["noise_um"] * 1e-6
        self.seed = settings["seed"]
        self.probes = read_probes(self.machine)
        self.model = GridAugmentedModel(build_system(self.machine, reduced=True), DT_S)
        rotor = Rotor.from_machine(self.machine)
        self._unbalance = (rotor.unbalance_moment_kg_m, rotor.unbalance_phase_rad)
        self.clearances_m = tuple(bearing.clearance_m for bearing in self.machine.bearings)
        self._motions: dict = {}  # true_motion's, per plant variant, point and seed
        self._other_models: dict = {}  # the estimator's models on another kind of film coefficients
        self._bounds: dict = {}  # CaseBounds per record length
        self._clearances: dict = {}  # the clearance factors each coast-down case measured
        # the estimator side: a step that takes the measured operating point, viscosity-factor states
        self.follows_operating_point = _accepts(OilFlowEKF.step, "speed_hz") and (
            "viscosity_factor_prior_std" in {f.name for f in dataclasses.fields(EKFConfig)}
        )

    def case_duration_s(self, case: Case) -> float:
        """The record length of the case [s]: its own (at most the run's), else the run's."""
        return self.duration_s if case.duration_s is None else min(case.duration_s, self.duration_s)

    def plant_system(self, case: Case):
        """The plant's full system for the case: its unbalance, its model structure, and its operating
        point at t = 0."""
        moment, phase = self._unbalance
        unbalance = {
            "unbalance_moment_kg_m": moment * case.unbalance[0],
            "unbalance_phase_rad": phase + math.radians(case.unbalance[1]),
        }
        if case.structure is not None:
            return structural_system(self.machine, case.structure, **unbalance)
        if not case.operating_point:
            return build_system(self.machine, reduced=False, **unbalance)
        viscosity = self.machine.oil.dynamic_viscosity_pa_s(self.machine.nominal_oil_temperature_c)
        return operating_system(self.machine, self.speed_hz(case, 0.0), viscosity, **unbalance)

    def speed_hz(self, case: Case, t: float) -> float:
        """The plant's speed [Hz] at time t [s] of the record: nominal, or along the case's ramp."""
        if case.speed_ramp_hz is None:
            return self.machine.nominal_speed_hz
        start, end = case.speed_ramp_hz
        return start + (end - start) * t / self.duration_s

    def temperature_c(self, case: Case, t: float) -> float:
        """The oil temperature [degC] at time t [s] of the record: nominal plus the case's rise so far."""
        return self.machine.nominal_oil_temperature_c + case.temperature_rise_c * t / self.duration_s

    def mounting_angle_deg(self, case: Case) -> float:
        """The probes' angle: the case's, else the machine file's ([probes] layout)."""
        return self.probes.angle_deg if case.mounting_angle_deg is None else case.mounting_angle_deg

    def chain(self, case: Case, after_baseline: bool) -> MeasurementChain:
        """The plant's probes for the case (the run's, or the baseline record's)."""
        return MeasurementChain(
            probe_errors(case, self.seed, self.duration_s, after_baseline),
            math.radians(self.mounting_angle_deg(case)),
            self.noise_m,
        )

    def record(self, case: Case, point_pct, seed: int, after_baseline: bool = True):
        """(measured (K, 4) [m], speed (K,) [Hz], oil temperature (K,) [degC]) at t = dt ... T.

        The plant's true motion does not depend on its probes, so it is simulated once per plant variant,
        truth point and seed (:meth:`true_motion`) and the case's measurement chain is applied to it with
        the plant's own noise generator, draw for draw as :meth:`RotorBearingPlant.current_sample` does:
        bit-identical to a plant built with that chain (tests/test_robustness_cli.py)."""
        true, angle, times = self.true_motion(case, point_pct, seed, after_baseline)
        chain = self.chain(case, after_baseline)
        rng = np.random.default_rng(seed)
        held = np.zeros(4)
        measured = np.array(
            [chain.measure(true[k], angle[k], times[k], rng, held) for k in range(len(times))]
        )
        times = DT_S * np.arange(1, len(times) + 1)
        speed = np.array([self.speed_hz(case, t - DT_S) for t in times])
        temperature = np.array([self.temperature_c(case, t - DT_S) for t in times])
        return measured, speed, temperature

    def true_motion(self, case: Case, point_pct, seed: int, after_baseline: bool = True):
        """(true positions (K, 4) [m], rotor angle (K,) [rad], times (K,) [s]) of the case's plant (its
        unbalance, change, film and operating point; ideal probes), kept for the other cases of the run."""
        change = case.unbalance_change if after_baseline else None
        key = (
            case.structure,
            case.transient_film,
            self.case_duration_s(case),
            case.unbalance,
            change,
            case.viscosity_factor,
            case.temperature_rise_c,
            case.speed_ramp_hz,
            case.operating_point,
            tuple(point_pct),
            seed,
        )
        if key not in self._motions:
            self._motions[key] = self._simulate(case, point_pct, seed, change)
        return self._motions[key]

    def _simulate(self, case: Case, point_pct, seed: int, change_of_case):
        q = tuple(p / 100.0 * nominal for p, nominal in zip(point_pct, self.nominal_m3_s, strict=True))
        n_samples = round(self.case_duration_s(case) / DT_S)
        if case.transient_film:
            return self._simulate_transient(q, seed, n_samples)
        change = UnbalanceChange()
        if change_of_case is not None:
            moment, phase = self._unbalance
            change = UnbalanceChange(
                self.duration_s / 2.0, moment * change_of_case[0], phase + math.radians(change_of_case[1])
            )
        conditions = {}
        if case.operating_point:
            conditions = {
                "oil": self.machine.oil,
                "oil_temperature_c": self.temperature_c(case, 0.0),
                "viscosity_factor": case.viscosity_factor,
            }
        plant = RotorBearingPlant(
            self.plant_system(case),
            DT_S,
            None,
            self.noise_m,
            seed,
            initial_flowrates_m3_s=q,
            unbalance_change=change,
            **conditions,
        )
        times = DT_S * np.arange(1, n_samples + 1)
        ramps = case.speed_ramp_hz is not None or case.temperature_rise_c != 0.0
        true, angle, clock = np.zeros((n_samples, 4)), np.zeros(n_samples), np.zeros(n_samples)
        for k in range(n_samples):
            extra = {}
            if ramps:
                extra = {"speed_hz": self.speed_hz(case, times[k] - DT_S)}
                extra["oil_temperature_c"] = self.temperature_c(case, times[k] - DT_S)
            true[k] = plant.step(q, **extra).true_position_m
            angle[k], clock[k] = plant.rotor_angle_rad, plant.time_s
        return true, angle, clock

    def _simulate_transient(self, q, seed: int, n_samples: int):
        """The true motion on transient p-theta films (ideal probes: the chain is applied afterwards)."""
        from oilwatch.models.bearing.grid import Mesh
        from oilwatch.models.system.nonlinear_plant import TRANSIENT_PLANT_MESH, TransientFilmPlant

        plant = TransientFilmPlant(
            self.machine,
            Mesh(*TRANSIENT_PLANT_MESH),
            DT_S,
            None,
            self.noise_m,
            seed,
            initial_flowrates_m3_s=q,
        )
        true, angle, clock = np.zeros((n_samples, 4)), np.zeros(n_samples), np.zeros(n_samples)
        for k in range(n_samples):
            true[k] = plant.step(q).true_position_m
            angle[k], clock[k] = plant.rotor_angle_rad, plant.time_s
        return true, angle, clock

    def config(self, case: Case) -> EKFConfig:
        """What a user would configure for this machine and case."""
        values = dict(
            speed_hz=self.machine.nominal_speed_hz,
            first_sample_time_s=DT_S,
            noise_std_m=self.noise_m,
            offset_prior_std_m=self.settings["offset_prior_um"] * 1e-6,
            offset_random_walk_m_sqrt_s=self.probes.offset_random_walk_m_sqrt_s,
            probe_scale_factor_std=self.probes.scale_factor_std,
            unbalance_prior_std=self.settings["unbalance_prior"],
            probe_angle_deg=self.mounting_angle_deg(case),
        )
        if case.operating_point and self.follows_operating_point and case.viscosity_states:
            values["viscosity_factor_prior_std"] = self.settings["viscosity_prior"]
        config = EKFConfig.recommended(**values, runout=runout_of_probes(self.probes), **case.ekf)
        if case.compensate_runout:
            runout = slow_roll_vectors(
                self.chain(case, False),
                self.clearances_m,
                self.machine.nominal_speed_hz,
                60.0,
                DT_S,
                self.seed,
            )
            config = dataclasses.replace(config, runout=runout)
        if case.baseline:
            # the commissioning record: at 100/100 %, the run's start conditions held (a ramp's start speed)
            start = None if case.speed_ramp_hz is None else (case.speed_ramp_hz[0],) * 2
            healthy = dataclasses.replace(
                case, unbalance_change=None, speed_ramp_hz=start, temperature_rise_c=0.0
            )
            record, speed, temperature = self.record(
                healthy, (100.0, 100.0), self.seed + 1, after_baseline=False
            )
            q = self.nominal_m3_s
            # the estimator's own model: with viscosity states, the baseline separates them from the offsets
            model = (
                self.case_operating_model(case)
                if case.operating_point and self.follows_operating_point
                else self.grid_model(case.estimator_coefficients)
            )
            measured = {}
            if start is not None or case.temperature_rise_c:
                # the baseline at a ramp's start conditions: the model is told them (the viscosity cases'
                # baselines run at the reference point, where the model needs no operating point)
                measured = {"speed_hz": speed, "oil_temperature_c": temperature}
            document = estimate_baseline(model, record, q, config, **measured)
            # the baseline record ends where the run's begins (no drift beyond the run's own), or is
            # BASELINE_AGE_DAYS old in the offset-step case
            age_s = BASELINE_AGE_DAYS * 86400.0 if case.offset_step else 0.0
            prior = baseline_prior(document, age_s, self.probes.offset_drift_m_per_day)
            config = dataclasses.replace(config, offset_baseline=prior)
        return config

    def bound_pct(self, case: Case, point_pct) -> np.ndarray:
        """(2,) nuisance Cramer-Rao bound [% of q] in the case's own configuration (:mod:`.bounds`)."""
        return case_bounds(self._bounds, self.machine, self.settings, case).bound_pct(case, point_pct)

    def estimate(self, case: Case, config: EKFConfig, signals, speed, temperature, single: bool = False):
        """(trace, follows): the estimator's record, and whether it was fed the measured speed and oil
        temperature (an estimator whose step takes them). ``single``: one
        filter from the configured start even where the start bank applies (diagnostics)."""
        if not (case.operating_point and self.follows_operating_point):
            return make_estimator(self.grid_model(case.estimator_coefficients), config).run_batch(
                signals
            ), False
        model = self.case_operating_model(case)
        estimator = OilFlowEKF(model, config) if single else make_estimator(model, config)
        return estimator.run_batch(signals, speed_hz=speed, oil_temperature_c=temperature), True

    def grid_model(self, coefficients: str | None = None):
        """The estimator's model at the nominal operating point, on the machine file's kind of film
        coefficients or on ``coefficients``."""
        if coefficients is None or coefficients == self.machine.dynamic_coefficients:
            return self.model
        if coefficients not in self._other_models:
            machine = dataclasses.replace(self.machine, dynamic_coefficients=coefficients)
            self._other_models[coefficients] = GridAugmentedModel(build_system(machine, reduced=True), DT_S)
        return self._other_models[coefficients]

    def clearance_factors(self, case: Case) -> tuple[float, ...] | None:
        """The clearance factors the case's commissioning coast-down gives the estimator's model (None
        without one; 1 for a bearing whose centreline the fit does not explain, as ``oilwatch baseline``)."""
        if not case.coast_down:
            return None
        if case.name not in self._clearances:
            fits = measured_clearances(
                self.machine,
                case.structure,
                self.chain(case, after_baseline=False),
                self.seed,
                self.probes.scale_factor_std,
            )
            self._clearances[case.name] = tuple(round(f.applied_clearance_factor, 6) for f in fits)
        return self._clearances[case.name]

    def case_operating_model(self, case: Case):
        """The estimator's model that follows speed and temperature for the case: on its kind of film
        coefficients, with the clearances its coast-down measured."""
        factors = self.clearance_factors(case)
        if factors is None:
            return self.operating_model(case.estimator_coefficients)
        from oilwatch.models.system.operating_model import build_operating_model

        key = ("clearance", case.estimator_coefficients, factors)
        if key not in self._other_models:
            machine = self.machine
            if case.estimator_coefficients is not None:
                machine = dataclasses.replace(machine, dynamic_coefficients=case.estimator_coefficients)
            reduced = build_system(machine, reduced=True)
            self._other_models[key] = build_operating_model(reduced, machine, DT_S, clearance_factors=factors)
        return self._other_models[key]

    def operating_model(self, coefficients: str | None = None):
        """The estimator's model that follows speed and temperature, built once (or the one given
        to :meth:`use_operating_model`); on another kind of film coefficients with ``coefficients``."""
        from oilwatch.models.system.operating_model import build_operating_model

        if coefficients is not None and coefficients != self.machine.dynamic_coefficients:
            key = ("operating", coefficients)
            if key not in self._other_models:
                machine = dataclasses.replace(self.machine, dynamic_coefficients=coefficients)
                reduced = build_system(machine, reduced=True)
                self._other_models[key] = build_operating_model(reduced, machine, DT_S)
            return self._other_models[key]
        if not hasattr(self, "_operating"):
            reduced = build_system(self.machine, reduced=True)
            self._operating = build_operating_model(reduced, self.machine, DT_S)
        return self._operating

    def use_operating_model(self, model) -> None:
        """Run the estimator of the operating-point cases on ``model`` instead of the default one (a
        diagnostic's variant, e.g. other re-centring thresholds)."""
        self._operating = model

    def run_case(self, case: Case, point_pct) -> dict:
        """The row of one case at one truth point (module docstring)."""
        signals, speed, temperature = self.record(case, point_pct, self.seed)
        try:
            config = self.config(case)
        except InputError as error:
            raise InputError(f"in the baseline or the configuration: {error}") from None
        try:
            trace, follows = self.estimate(case, config, signals, speed, temperature)
        except InputError as error:
            raise InputError(f"in the estimator's run: {error}") from None
        truth = np.array(point_pct) / 100.0 * np.array(self.nominal_m3_s)
        half = len(signals) // 2
        error_pct = 100.0 * (trace.q_m3_s[half:].mean(axis=0) / truth - 1.0)
        filter_error_pct = 100.0 * (trace.filter_q_m3_s[half:].mean(axis=0) / truth - 1.0)
        std_pct = 100.0 * trace.q_std_m3_s[-1] / truth
        settled = trace.starved[len(signals) // 10 :]
        low = np.array(point_pct) < ALARM_LEVEL_PCT
        healthy = np.array(point_pct) >= HEALTHY_PCT
        flagged = sorted({int(c) for c in np.flatnonzero(trace.probe_faulty.any(axis=0))})
        alarmed = trace.starved.any(axis=1)
        bound = self.bound_pct(case, tuple(point_pct))
        factors = self.clearance_factors(case)
        return {
            "case": case.name,
            "description": case.description,
            "q1_pct": point_pct[0],
            "q2_pct": point_pct[1],
            "error_pct": error_pct.tolist(),
            "std_pct": std_pct.tolist(),
            "error_over_std": (np.abs(error_pct) / std_pct).tolist(),
            "within_2_std": bool((np.abs(error_pct) <= 2.0 * std_pct).all()),
            "within_tolerance": bool((np.abs(error_pct) <= case.tolerance_pct).all()),
            "tolerance_pct": case.tolerance_pct,
            "false_alarm": bool(settled[:, healthy].any()),
            "detected": [bool(trace.starved[-1, b]) for b in range(2) if low[b]],
            "flagged_probes": flagged,
            "fault_flagged": None if case.probe_fault is None else case.probe_fault in flagged,
            "consistent_fraction": float(trace.model_consistent[half:].mean()),
            "mismatch_fraction": float((trace.model_mismatch[half:] != CONSISTENT).mean()),
            "filter_error_pct": filter_error_pct.tolist(),
            "alarms_consistent": bool(trace.starved_consistent[alarmed].all()) if alarmed.any() else None,
            "bound_pct": bound.tolist(),
            "bound_configuration": configuration_label(case, self.settings),
            "error_over_bound": (np.abs(error_pct) / bound).tolist(),
            "estimator_follows_operating_point": follows if case.operating_point else None,
            "measured_clearance_factors": None if factors is None else list(factors),
        }
