"""The discrepancies between a real machine and the estimator's model that ``oilwatch robustness`` plays.

Each case changes the PLANT: its unbalance, its film viscosity, its speed and oil temperature, and its
measurement chain (:mod:`oilwatch.models.system.measurement`: probe zero offsets, sensitivity
errors, 1x/2x runout, faults, the probes' mounting angle). The estimator's model never changes; the estimator
gets only what a user would configure: the probes' mounting angle, the nuisances' priors, a commissioning
baseline (:mod:`oilwatch.estimator.baseline`, from another plant record at 100/100 % with the same probes) and
the slow-roll runout vectors (:mod:`oilwatch.robustness.slow_roll`: the same measurement chain at slow roll).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from oilwatch.models.system.measurement import ProbeErrors
from oilwatch.models.system.structure import PlantStructure

OFFSET_RANGE_M = 25e-6
"""Probe zero offsets are drawn uniformly from +-25 um (ordinary: the bearing centre is known only from the
cold-rest position and a clearance with a tolerance)."""

DRIFT_M = 3e-6
"""Offset drift after the baseline: each probe's offset drifts linearly by 3 um (random sign) over the run,
or (``offset_step``) has moved by 3 um since a baseline ``BASELINE_AGE_DAYS`` old."""

BASELINE_AGE_DAYS = 30.0
"""The age of the baseline in the offset-step case: at the turbine's ``[probes] offset_drift_um_per_day``
of 0.1 the baseline's offsets are trusted to 3 um, the step the case makes."""

RUNOUT_M = (2e-6, 1e-6)
"""Runout amplitudes at 1x and 2x on every probe (phases drawn per probe)."""

FAULT_CHANNEL = 1
"""Probe faults are put on y1, the channel that carries most of bearing 1's information."""

SENSITIVITY_ERROR = 0.05
"""The sensitivity case: every probe's scale factor 5 % off (random sign): API 670 allows +-5 % on the
incremental scale factor of a probe, cable and driver set."""


@dataclass(frozen=True)
class Case:
    """One discrepancy (fields in the field's words; the module docstring says what each changes).

    offsets / drift : the run's probe zero offsets (:func:`probe_errors`), drifting by DRIFT_M over the
        run after the baseline; offset_step : they moved by DRIFT_M between a baseline BASELINE_AGE_DAYS
        old and the run (the estimator widens the baseline's offsets by its age times the machine file's
        ``[probes] offset_drift_um_per_day``); baseline : the estimator is primed with ``oilwatch
        baseline`` on another record at 100/100 % with the same probes (before the drift); coast_down : the
        baseline also measures each bearing's clearance from a coast-down of the plant
        (:mod:`.coast_down`), which the estimator's model takes; runout :
        RUNOUT_M on every probe; compensate_runout : the slow-roll vectors are subtracted; sensitivity :
        SENSITIVITY_ERROR on every probe; fault : the y1 probe's fault (dead, stuck, glitch, huge);
        mounting_angle_deg : their angle
        (told to the estimator; None: the machine file's [probes] layout);
        unbalance : (moment factor, phase shift [deg]); unbalance_change : the same at half the record;
        viscosity_factor : the film's viscosity over the oil law's; temperature_rise_c : a measured oil
        temperature ramp over the record; speed_ramp_hz : a measured speed ramp (start, end) over the
        record; ekf : EKFConfig fields a user would set; operating_point : the case needs the estimator to
        follow speed / temperature / viscosity (the estimator side); listed : the case is in the
        acceptance list (False: an extra the report shows beside them); viscosity_states : in an
        operating-point case, the estimator's viscosity factors are free (prior ``--viscosity-prior``);
        False: taken as 1 (the film as modelled); structure : the plant's model-structure discrepancy
        (:class:`oilwatch.models.system.structure.PlantStructure`; None: the machine file's structure);
        estimator_coefficients : the kind of film coefficients of the estimator's model (None: the machine
        file's); transient_film : the plant on transient p-theta films; runout_range_m : every probe's 1x
        and 2x runout amplitudes drawn from this range, no slow-roll record; points_pct : the truth points
        (None: the report's); duration_s : the record length of this case (None: the run's).
    """

    name: str
    description: str
    offsets: bool = False
    drift: bool = False
    offset_step: bool = False
    baseline: bool = False
    coast_down: bool = False
    runout: bool = False
    compensate_runout: bool = False
    sensitivity: bool = False
    fault: str | None = None
    mounting_angle_deg: float | None = None
    unbalance: tuple[float, float] = (1.0, 0.0)
    unbalance_change: tuple[float, float] | None = None
    viscosity_factor: float = 1.0
    temperature_rise_c: float = 0.0
    speed_ramp_hz: tuple[float, float] | None = None
    ekf: dict = field(default_factory=dict)
    operating_point: bool = False
    all_at_once: bool = False
    listed: bool = True
    viscosity_states: bool = True
    structure: PlantStructure | None = None
    estimator_coefficients: str | None = None
    transient_film: bool = False
    runout_range_m: tuple[float, float] | None = None
    points_pct: tuple[tuple[float, float], ...] | None = None
    duration_s: float | None = None

    @property
    def probe_fault(self) -> int | None:
        """The faulty channel the estimator must flag, if any."""
        return FAULT_CHANNEL if self.fault is not None else None

    @property
    def model_structure(self) -> bool:
        """Whether the case's plant differs from the estimator's model in structure (film, geometry,
        supports, unbalance distribution, bow, runout without a slow-roll record)."""
        return (
            self.structure is not None
            or self.transient_film
            or self.estimator_coefficients is not None
            or self.runout_range_m is not None
        )

    @property
    def tolerance_pct(self) -> float:
        """The error criterion: 3 % for all at once, else 2 %; model-structure cases 5 % and 3 %."""
        if self.model_structure:
            return 5.0 if self.all_at_once else 3.0
        return 3.0 if self.all_at_once else 2.0


def probe_offsets(seed: int) -> np.ndarray:
    """(4,) the probe zero offsets of a run [m], the same for every offset case of that run's seed."""
    return np.random.default_rng([seed, 25]).uniform(-OFFSET_RANGE_M, OFFSET_RANGE_M, 4)


def probe_errors(case: Case, seed: int, duration_s: float, after_baseline: bool) -> tuple[ProbeErrors, ...]:
    """The four probes' errors of a case: the run's (``after_baseline``) or the baseline record's."""
    rng = np.random.default_rng([seed, 7])
    signs = np.where(rng.uniform(size=4) < 0.5, -1.0, 1.0)
    runout_phases = rng.uniform(-math.pi, math.pi, (2, 4))
    sensitivity_signs = np.where(rng.uniform(size=4) < 0.5, -1.0, 1.0)
    offsets = probe_offsets(seed) if case.offsets else np.zeros(4)
    runout_draws = np.random.default_rng([seed, 13]).uniform(size=(2, 4))
    drift = DRIFT_M * signs / duration_s if case.drift and after_baseline else np.zeros(4)
    if case.offset_step and after_baseline:
        offsets = offsets + DRIFT_M * signs
    probes = []
    for k in range(4):
        values = {"zero_offset_m": float(offsets[k]), "zero_drift_m_s": float(drift[k])}
        if case.runout_range_m is not None:
            low, high = case.runout_range_m
            values.update(
                runout_1x_m=float(runout_draws[0, k]) * (high - low) + low,
                runout_1x_phase_rad=float(runout_phases[0, k]),
                runout_2x_m=float(runout_draws[1, k]) * (high - low) + low,
                runout_2x_phase_rad=float(runout_phases[1, k]),
            )
        if case.runout:
            values.update(
                runout_1x_m=RUNOUT_M[0],
                runout_1x_phase_rad=float(runout_phases[0, k]),
                runout_2x_m=RUNOUT_M[1],
                runout_2x_phase_rad=float(runout_phases[1, k]),
            )
        if case.sensitivity:
            values["sensitivity_error"] = SENSITIVITY_ERROR * float(sensitivity_signs[k])
        if after_baseline and case.fault is not None and k == FAULT_CHANNEL:
            values.update(_fault(case.fault, duration_s))
        probes.append(ProbeErrors(**values))
    return tuple(probes)


def _fault(kind: str, duration_s: float) -> dict:
    if kind in ("dead", "stuck"):
        return {"fault": kind, "fault_time_s": duration_s / 6.0}  # 10 s of 60 s
    size, length = (500e-6, 0.1) if kind == "glitch" else (1.0, 0.5)  # "huge": 1e6 um
    return {
        "fault": "glitch",
        "fault_time_s": duration_s / 3.0,
        "glitch_m": size,
        "glitch_duration_s": length,
    }


PEDESTALS = dict(pedestal_mass_kg=150.0, pedestal_stiffness_n_m=2.0e8, pedestal_damping_n_s_m=6.9e3)
"""A realistic flexible pedestal under each bearing: 150 kg modal mass (a quarter of the rotor's), 2e8 N/m
(of the order of the film's own stiffness, so the support shares the 1x motion), 2 % of critical damping:
its own resonance sqrt(k/m) / 2 pi = 184 Hz, 2.45 times the running speed and above 2x, close enough that
the support moves with the 1x orbit."""

UNBALANCE_DISCS = ((10, 0.6, math.radians(60.0)), (13, 0.4, 0.0), (15, 0.6, math.radians(-150.0)))
"""The unbalance over the three discs: 60 % of the machine's moment on the first disc at +60 deg, 40 % on the
central one at 0, 60 % on the third at -150 deg (the estimator's model has it on the central disc only)."""

BOW_M = 10e-6
"""A mild bent shaft: 10 um of bow between the bearings (20 um total indicated runout at mid-span), at
+45 deg from the keyphasor."""

SIDE_LOAD = dict(side_load_fraction=0.3, side_load_angle_deg=270.0)
"""A steady horizontal force (+x) of 30 % of each bearing's share of the weight that the machine file does not
give (coupling misalignment, a belt, a process force): the load turned by 16.7 deg from down and 4.4 %
larger."""

RUNOUT_RANGE_M = (1e-6, 3e-6)
"""1x and 2x runout amplitudes of each probe, drawn from 1-3 um, with no slow-roll record."""

_STRUCTURE = dict(offsets=True, baseline=True, coast_down=True, operating_point=True, listed=False)
"""Every model-structure case: unknown probe offsets, a commissioning baseline at nominal flow and a
commissioning coast-down on the same plant, the estimator that follows the operating point with its viscosity
factors free and the clearances the coast-down measured."""

_ALL_STRUCTURE = PlantStructure(
    film_coefficients="quasi-static",
    clearance_factor=1.1,
    length_factor=1.05,
    load_split="reactions",
    unbalance_discs=UNBALANCE_DISCS,
    bow_m=BOW_M,
    bow_phase_rad=math.radians(45.0),
    **PEDESTALS,
)

_GROUPS = dict(offsets=True, baseline=True, unbalance=(3.0, 90.0), viscosity_factor=1.1, runout=True)

CASES: tuple[Case, ...] = (
    Case("none", "plant and probes as the model"),
    Case("offsets", "probe zero offsets drawn from +-25 um, no baseline", offsets=True),
    Case(
        "offsets-baseline",
        "the same offsets, baseline from another 100/100 record",
        offsets=True,
        baseline=True,
    ),
    Case(
        "offsets-drift",
        "the same offsets, baseline, then each offset drifting by 3 um over the record",
        offsets=True,
        drift=True,
        baseline=True,
    ),
    Case(
        "offsets-step",
        "the same offsets, each moved by 3 um since a baseline 30 days old",
        offsets=True,
        offset_step=True,
        baseline=True,
        listed=False,
    ),
    Case("unbalance-x0.5", "unbalance moment x0.5", unbalance=(0.5, 0.0)),
    Case("unbalance-x3", "unbalance moment x3", unbalance=(3.0, 0.0)),
    Case("phase-90", "unbalance phase +90 deg", unbalance=(1.0, 90.0)),
    Case("phase-180", "unbalance phase +180 deg", unbalance=(1.0, 180.0)),
    Case("phase-270", "unbalance phase +270 deg", unbalance=(1.0, 270.0)),
    Case("unbalance-change", "unbalance x2 and +120 deg at half the record", unbalance_change=(2.0, 120.0)),
    Case(
        "viscosity-0.9",
        "film viscosity x0.9, baseline",
        viscosity_factor=0.9,
        baseline=True,
        operating_point=True,
    ),
    Case(
        "viscosity-1.1",
        "film viscosity x1.1, baseline",
        viscosity_factor=1.1,
        baseline=True,
        operating_point=True,
    ),
    Case(
        "temperature-ramp",
        "oil temperature +10 degC over the record, measured",
        temperature_rise_c=10.0,
        operating_point=True,
    ),
    Case(
        "speed-ramp",
        "speed 72 -> 78 Hz over the record, measured",
        speed_ramp_hz=(72.0, 78.0),
        operating_point=True,
    ),
    Case(
        "temperature-ramp-known-film",
        "the same temperature ramp, the estimator's viscosity factors taken as 1",
        temperature_rise_c=10.0,
        operating_point=True,
        viscosity_states=False,
        listed=False,
    ),
    Case(
        "speed-ramp-known-film",
        "the same speed ramp, the estimator's viscosity factors taken as 1",
        speed_ramp_hz=(72.0, 78.0),
        operating_point=True,
        viscosity_states=False,
        listed=False,
    ),
    Case(
        "temperature-ramp-baseline",
        "the same temperature ramp, baseline (factors, unbalance, offsets) at the ramp's start conditions",
        temperature_rise_c=10.0,
        operating_point=True,
        baseline=True,
        listed=False,
    ),
    Case(
        "speed-ramp-baseline",
        "the same speed ramp, baseline (factors, unbalance, offsets) at the ramp's start speed (72 Hz)",
        speed_ramp_hz=(72.0, 78.0),
        operating_point=True,
        baseline=True,
        listed=False,
    ),
    Case(
        "runout",
        "runout 2 um at 1x and 1 um at 2x on every probe, slow-roll compensation",
        runout=True,
        compensate_runout=True,
    ),
    Case("runout-uncompensated", "the same runout, not compensated", runout=True, listed=False),
    Case(
        "sensitivity",
        "every probe's scale factor 5 % off (API 670 tolerance)",
        sensitivity=True,
        listed=False,
    ),
    Case(
        "sensitivity-baseline",
        "every probe's scale factor 5 % off, offsets, baseline at nominal flow with the same probes",
        offsets=True,
        sensitivity=True,
        baseline=True,
        listed=False,
    ),
    Case("api670", "probes at 45 deg either side of the top (API 670), angle given", mounting_angle_deg=45.0),
    Case("dead", "probe y1 dead (NaN) from 1/6 of the record", fault="dead"),
    Case("stuck", "probe y1 stuck from 1/6 of the record", fault="stuck"),
    Case("glitch", "probe y1 +500 um for 0.1 s at 1/3 of the record", fault="glitch"),
    Case("huge", "probe y1 reads 1e6 um for 0.5 s at 1/3 of the record", fault="huge"),
    Case(
        "structure-reference",
        "model-structure reference: the machine's own structure, offsets, baseline on the same plant",
        **_STRUCTURE,
    ),
    Case(
        "film-quasi-static",
        "plant's 1x film on the quasi-static table, estimator on the synchronous one",
        structure=PlantStructure(film_coefficients="quasi-static"),
        **_STRUCTURE,
    ),
    Case(
        "estimator-quasi-static",
        "plant on the synchronous table, estimator on the quasi-static one",
        estimator_coefficients="quasi-static",
        **_STRUCTURE,
    ),
    Case(
        "transient-film",
        "plant on transient p-theta films (60 x 16), 10 s baseline and record, equal flows",
        transient_film=True,
        points_pct=((100.0, 100.0), (80.0, 80.0)),
        duration_s=10.0,
        **_STRUCTURE,
    ),
    *(
        Case(
            f"{quantity}{percent:+d}",
            f"bearing {quantity} {percent:+d} % in the plant",
            structure=PlantStructure(**{f"{quantity}_factor": 1.0 + percent / 100.0}),
            **_STRUCTURE,
        )
        for quantity, percent in (("clearance", 10), ("clearance", -10), ("length", 5), ("length", -5))
    ),
    Case(
        "unbalance-discs",
        "unbalance over three discs (0.6 at +60, 0.4 at 0, 0.6 at -150 deg)",
        structure=PlantStructure(unbalance_discs=UNBALANCE_DISCS),
        **_STRUCTURE,
    ),
    Case(
        "pedestals",
        "flexible pedestals: 150 kg, 2e8 N/m, 2 % damping (184 Hz) under each bearing",
        structure=PlantStructure(**PEDESTALS),
        **_STRUCTURE,
    ),
    Case(
        "load-reactions",
        "static load split by the support reactions instead of equally",
        structure=PlantStructure(load_split="reactions"),
        **_STRUCTURE,
    ),
    Case(
        "threshold-one-sided",
        "film coefficients at their one-sided limits on the flooded threshold (the jump); the estimator "
        "interpolates across it",
        structure=PlantStructure(threshold_one_sided=True),
        **_STRUCTURE,
    ),
    Case(
        "side-load",
        "a horizontal side force of 30 % of each bearing's weight share that the machine file does not give",
        structure=PlantStructure(**SIDE_LOAD),
        **_STRUCTURE,
    ),
    Case(
        "runout-1-3um",
        "1x and 2x runout of 1-3 um on every probe, keyphasor, no slow-roll record",
        runout_range_m=RUNOUT_RANGE_M,
        **_STRUCTURE,
    ),
    Case(
        "bow",
        "bent shaft: 10 um bow between the bearings at +45 deg",
        structure=PlantStructure(bow_m=BOW_M, bow_phase_rad=math.radians(45.0)),
        **_STRUCTURE,
    ),
    *(
        Case(
            f"{name}-known-film",
            f"{description}; the estimator's viscosity factors taken as 1",
            viscosity_states=False,
            **changes,
            **_STRUCTURE,
        )
        for name, description, changes in (
            (
                "unbalance-discs",
                "the same three-disc unbalance",
                {"structure": PlantStructure(unbalance_discs=UNBALANCE_DISCS)},
            ),
            ("runout-1-3um", "the same 1-3 um runout", {"runout_range_m": RUNOUT_RANGE_M}),
        )
    ),
    Case(
        "structure-all",
        "all model-structure discrepancies at once (quasi-static film, clearance +10 %, length +5 %, "
        "reactions, three discs, pedestals, bow, 1-3 um runout)",
        structure=_ALL_STRUCTURE,
        runout_range_m=RUNOUT_RANGE_M,
        all_at_once=True,
        **_STRUCTURE,
    ),
    Case(
        "all-at-once",
        "offsets, baseline, unbalance x3 at +90 deg, viscosity x1.1, runout (compensated), within 3 %",
        compensate_runout=True,
        operating_point=True,
        all_at_once=True,
        **_GROUPS,
    ),
)
"""The acceptance list (and four more: the ramps with the film known, runout uncompensated,
sensitivity errors)."""


def case_by_name(name: str) -> Case:
    """The case called ``name`` (InputError naming the choices otherwise)."""
    from oilwatch.models.validation import InputError

    for case in CASES:
        if case.name == name:
            return case
    raise InputError(f"--cases: unknown case {name!r}; choose from {', '.join(c.name for c in CASES)}")
