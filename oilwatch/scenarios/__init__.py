"""The paper's real-time oil-starvation scenarios (section 3.2.2, Figs. 10-12) as runnable settings.

Every flowrate is a percentage of its bearing's own nominal flowrate (the machine file's ``[lubrication]`` or
the bearing's ``[[bearings.override]]``; the bundled turbine: the paper's 0.5 bar groove pressure, one figure
for both bearings) and every scenario runs at the machine's nominal speed.
Each bearing's
supply flowrate follows the plant FMU's sigmoid from its initial to its final value, centred at half the
record (``fault_time_s = duration_s / 2``: 10 s for the paper's 20 s) with the 10 %-90 % transition time
``fault_duration_s`` of :data:`oilwatch.models.system.fault.SCENARIO_DURATIONS_S` (slow 4 s, intermediate 1 s,
sudden 0.1 s).

=====================  ==========================  ==========================  =============
scenario               bearing 1                   bearing 2                   transition
=====================  ==========================  ==========================  =============
constant               --q1-pct (100)              --q2-pct (100)              none
slow-drop              100 -> 75 %                 100 -> 75 %                 slow
intermediate-drop      100 -> 75 %                 100 -> 75 %                 intermediate
sudden-drop            100 -> 75 %                 100 -> 75 %                 sudden
drop-b1 / drop-b2      100 -> 75 % (one bearing)   100 % (the other)           intermediate
clog-b1 / clog-b2      100 -> 75 % (one bearing)   100 -> 125 % (the other)    intermediate
operating-ramps        --q1-pct (100)              --q2-pct (100)              none
=====================  ==========================  ==========================  =============

Operating point: a scenario runs at the machine's nominal speed and oil temperature unless it carries
profiles (``oilwatch.models.system.profiles``; ``operating-ramps``: a speed ramp nominal -3 -> +3 Hz
over 10 s and oil temperature ramp +10 degC over 60 s) or ``oilwatch run`` gives them (``--speed-profile``,
``--oil-temperature-profile``). With a profile both FMUs run on the dimensionless bearing table
(``bearing_table = 1``) and their inputs ``speed_hz`` and ``oil_temperature_c`` follow it.

The paper names only the speed of the generalized drops (Fig. 10); for the single-bearing and clogged-line
cases (Figs. 11-12) it says "intermediate", which is used here.

Windows used by the summary (:mod:`oilwatch.scenarios.summary`): the transition starts at
``transition_start_s = fault_time_s - fault_duration_s``, where the sigmoid has done 1/82 = 1.2 % of its
change (``tau = D / (2 ln 9)``, so ``D / tau = 4.39`` and ``1 / (1 + e^4.39) = 0.012``); "before" is the
2 s before it, "after" the last 2 s of the record.
"""

from __future__ import annotations

from dataclasses import dataclass

from oilwatch.experiment_config import SCENARIO_DEFAULTS, ScenarioConfig
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
from oilwatch.models.machine import Machine, is_default_machine, load_machine
from oilwatch.models.system.fault import SCENARIO_DURATIONS_S
from oilwatch.models.system.profiles import OperatingProfile, parse_profile
from oilwatch.models.validation import InputError

STARVED_PCT = 75.0
FLOODED_PCT = 125.0
WINDOW_S = 2.0
"""Length [s] of the before and after error windows."""
SAMPLE_PERIOD_S = 1e-3
"""Macro step = sampling period of the probes [s] (1 kHz, as in the paper)."""
PROTECTED = {
    "plant": {
        "machine_file", "q1_initial_ml_min", "q1_final_ml_min", "q2_initial_ml_min", "q2_final_ml_min",
        "fault_time_s", "fault_duration_s", "noise_um", "seed", "flow_source",
    },
    "ekf": {"noise_um", "q1_nominal_ml_min", "q2_nominal_ml_min", "sample_period_s", "machine_file"},
}  # fmt: skip
"""Parameters a scenario sets itself, per FMU role (``make_run``'s overrides may not touch them)."""
PAPER_TUNING = {"q_std_displacement_um": 10.0, "q_std_velocity_um_s": 10.0, "velocity_channels": 1}
"""The paper's filter (section 2.4): Q stds 10 um, 10 um/s (and the estimator's 0.1 ml/min default), with
the differentiated velocities as extra measurements, R = sigma^2 I."""


@dataclass(frozen=True)
class Scenario:
    """One scenario: each bearing's (initial, final) supply flowrate [% of its own nominal] and the transition
    speed (a key of ``SCENARIO_DURATIONS_S``)."""

    name: str
    title: str
    q1_pct: tuple[float, float]
    q2_pct: tuple[float, float]
    speed: str
    speed_profile: str | None = None
    oil_temperature_profile: str | None = None
    """Operating-point profiles (``oilwatch.models.system.profiles`` text, relative values from the machine's
    nominal speed [Hz] and oil temperature [degC]); None: constant at nominal."""


_DROP = (100.0, STARVED_PCT)
_KEEP = (100.0, 100.0)
_FLOOD = (100.0, FLOODED_PCT)
SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("constant", "Constant flowrates", _KEEP, _KEEP, "sudden"),
        Scenario("slow-drop", "Slow drop of both flowrates", _DROP, _DROP, "slow"),
        Scenario("intermediate-drop", "Intermediate drop of both flowrates", _DROP, _DROP, "intermediate"),
        Scenario("sudden-drop", "Sudden drop of both flowrates", _DROP, _DROP, "sudden"),
        Scenario("drop-b1", "Drop in bearing 1 only", _DROP, _KEEP, "intermediate"),
        Scenario("drop-b2", "Drop in bearing 2 only", _KEEP, _DROP, "intermediate"),
        Scenario(
            "clog-b1", "Line 1 clogged: drop in bearing 1, rise in bearing 2", _DROP, _FLOOD, "intermediate"
        ),
        Scenario(
            "clog-b2", "Line 2 clogged: drop in bearing 2, rise in bearing 1", _FLOOD, _DROP, "intermediate"
        ),
        Scenario(
            "operating-ramps",
            "Constant flowrates while speed and oil temperature ramp",
            _KEEP,
            _KEEP,
            "sudden",
            "ramp:-3:+3:0:10",
            "ramp:+0:+10:0:60",
        ),
    )
}
CONSTANT_FLOW_SCENARIOS = ("constant", "operating-ramps")
"""Scenarios whose flowrates --q1-pct and --q2-pct set."""
SPEED_RANGE_HZ = (1.0, 1000.0)
OIL_TEMPERATURE_RANGE_C = (-50.0, 150.0)


@dataclass(frozen=True)
class ScenarioRun:
    """A scenario with everything a run needs; times in s, flowrates in ml/min (the FMUs' units).

    nominal_ml_min (each bearing's) and nominal_speed_hz are the machine's (``machine_file``, empty: the
    bundled turbine); the plant runs at ``speed_hz`` (the nominal speed unless ``--set plant.speed_hz``
    changed it, which the estimator follows unless ``--set ekf.speed_hz`` says otherwise).
    """

    scenario: Scenario
    noise_um: float
    duration_s: float
    seed: int
    q1_ml_min: tuple[float, float]
    q2_ml_min: tuple[float, float]
    nominal_ml_min: tuple[float, float]
    nominal_speed_hz: float
    machine_file: str = ""
    overrides: tuple[tuple[str, str, object], ...] = ()
    """Further FMU parameters as (``plant`` or ``ekf``, name, value), e.g. the estimator's tuning."""
    speed_profile: OperatingProfile | None = None
    oil_temperature_profile: OperatingProfile | None = None
    """The measured operating point fed to both FMUs' inputs (None: constant at nominal)."""

    @property
    def follows_operating_point(self) -> bool:
        """Whether the run has a speed or oil-temperature profile."""
        return self.speed_profile is not None or self.oil_temperature_profile is not None

    def input_signals(self, roles: dict[str, str]) -> dict[str, OperatingProfile]:
        """``Master.run``'s input signals: each profile to both FMUs' input (instance names by role)."""
        signals = {}
        for variable, profile in (
            ("speed_hz", self.speed_profile),
            ("oil_temperature_c", self.oil_temperature_profile),
        ):
            if profile is not None:
                signals.update({f"{roles[role]}.{variable}": profile for role in ("plant", "ekf")})
        return signals

    def _operating(self, role: str) -> dict[str, object]:
        return {"bearing_table": 1} if self.follows_operating_point else {}

    def speed_hz(self, role: str = "plant") -> float:
        """The spin speed [Hz] the ``plant`` or the ``ekf`` instance is given."""
        plant = float(self._extra("plant").get("speed_hz", self.nominal_speed_hz))
        return plant if role == "plant" else float(self._extra("ekf").get("speed_hz", plant))

    @property
    def fault_time_s(self) -> float:
        """Centre of the sigmoid (half the change done) [s]: half the record."""
        return 0.5 * self.duration_s

    @property
    def fault_duration_s(self) -> float:
        """10 %-90 % transition time [s]."""
        return SCENARIO_DURATIONS_S[self.scenario.speed]

    @property
    def transition_start_s(self) -> float:
        """Where the transition starts: centre minus the 10 %-90 % time (1.2 % of the change done) [s]."""
        return self.fault_time_s - self.fault_duration_s

    def starving(self, bearing: int, on_fraction: float = 0.90) -> bool:
        """Whether bearing 1 or 2 ends below ``on_fraction`` of its nominal (the alarm's default level)."""
        return self._below(bearing, -1, on_fraction)

    def starved_initially(self, bearing: int, on_fraction: float = 0.90) -> bool:
        """Whether bearing 1 or 2 starts below ``on_fraction`` of its nominal (a constant starved run)."""
        return self._below(bearing, 0, on_fraction)

    def _below(self, bearing: int, end: int, on_fraction: float) -> bool:
        flowrates = self.q1_ml_min if bearing == 1 else self.q2_ml_min
        return flowrates[end] < on_fraction * self.nominal_ml_min[bearing - 1]

    def plant_parameters(self) -> dict[str, float]:
        """Parameter values of the RotorBearingPlant FMU."""
        return {
            "machine_file": self.machine_file,
            "q1_initial_ml_min": self.q1_ml_min[0],
            "q1_final_ml_min": self.q1_ml_min[1],
            "q2_initial_ml_min": self.q2_ml_min[0],
            "q2_final_ml_min": self.q2_ml_min[1],
            "fault_time_s": self.fault_time_s,
            "fault_duration_s": self.fault_duration_s,
            "noise_um": self.noise_um,
            "seed": self.seed,
            **self._operating("plant"),
            **self._extra("plant"),
            "speed_hz": self.speed_hz("plant"),
        }

    def _extra(self, role: str) -> dict[str, object]:
        return {name: value for who, name, value in self.overrides if who == role}

    def ekf_parameters(self) -> dict[str, float]:
        """Parameter values of the OilFlowEKF FMU (initial estimates: the nominals, as in the paper)."""
        return {
            "machine_file": self.machine_file,
            "noise_um": self.noise_um,
            **{f"q{b}_initial_ml_min": q for b, q in enumerate(self.nominal_ml_min, start=1)},
            **{f"q{b}_nominal_ml_min": q for b, q in enumerate(self.nominal_ml_min, start=1)},
            "preset": "paper",  # the paper's scenarios run its calibrated filter
            **self._operating("ekf"),
            **self._extra("ekf"),
            "speed_hz": self.speed_hz("ekf"),
        }


def make_run(
    name: str,
    noise_um: float = SCENARIO_DEFAULTS.noise_um,
    duration_s: float = SCENARIO_DEFAULTS.duration_s,
    seed: int = SCENARIO_DEFAULTS.seed,
    q1_pct: float = SCENARIO_DEFAULTS.q1_pct,
    q2_pct: float = SCENARIO_DEFAULTS.q2_pct,
    overrides: dict[str, dict[str, object]] | None = None,
    machine: Machine | None = None,
    speed_profile: str | None = None,
    oil_temperature_profile: str | None = None,
) -> ScenarioRun:
    """Resolve scenario ``name`` into a :class:`ScenarioRun`; ``q1_pct``/``q2_pct`` only for ``constant``.

    machine: the machine (default: the bundled turbine) whose bearings' nominal flowrates the percentages
    refer to (``q1_pct`` bearing 1's, ``q2_pct`` bearing 2's) and whose nominal speed the scenario runs at
    (``--set plant.speed_hz=...`` runs it at another speed).

    overrides: further FMU parameters, ``{"plant" or "ekf": {name: value}}``; the ones the scenario sets
    (flowrates, fault timing, noise, seed, nominal flowrate) cannot be overridden. The FMU checks names
    and values when the run starts.

    speed_profile, oil_temperature_profile: ``oilwatch.models.system.profiles`` texts (``--speed-profile``,
    ``--oil-temperature-profile``) replacing the scenario's own; values may be relative to the machine's
    nominal (``+d``/``-d``).

    Raises InputError naming the input (unknown scenario; noise, duration, seed or percentage outside the
    ranges of :class:`~oilwatch.experiment_config.ScenarioConfig`; a bad profile).
    """
    if name not in SCENARIOS:
        raise InputError(f"scenario {name!r} is unknown; choose one of {', '.join(SCENARIOS)}")
    scenario = SCENARIOS[name]
    ScenarioConfig(noise_um, duration_s, seed, q1_pct, q2_pct)  # checks each against its range
    steps = round(duration_s / SAMPLE_PERIOD_S)
    if abs(steps * SAMPLE_PERIOD_S - duration_s) > 1e-9:
        raise InputError(f"--duration-s must be a multiple of {SAMPLE_PERIOD_S:g} s, got {duration_s:g}")
    if name in CONSTANT_FLOW_SCENARIOS:
        scenario = Scenario(
            name,
            scenario.title,
            (q1_pct, q1_pct),
            (q2_pct, q2_pct),
            scenario.speed,
            scenario.speed_profile,
            scenario.oil_temperature_profile,
        )
    elif (q1_pct, q2_pct) != (SCENARIO_DEFAULTS.q1_pct, SCENARIO_DEFAULTS.q2_pct):
        raise InputError(
            f"--q1-pct and --q2-pct apply to the {' and '.join(CONSTANT_FLOW_SCENARIOS)} scenarios only, "
            f"not {name!r}"
        )
    extra = []
    for role, values in (overrides or {}).items():
        if role not in PROTECTED:
            raise InputError(f"--set: unknown FMU instance {role!r}; use plant.NAME=VALUE or ekf.NAME=VALUE")
        for parameter, value in values.items():
            if parameter in PROTECTED[role]:
                raise InputError(
                    f"--set {role}.{parameter}: set by the scenario (use the scenario's own options)"
                )
            extra.append((role, parameter, value))
    machine = machine if machine is not None else load_machine()
    profiles = _profiles(
        machine,
        speed_profile if speed_profile is not None else scenario.speed_profile,
        oil_temperature_profile if oil_temperature_profile is not None else scenario.oil_temperature_profile,
    )
    # Python floats: round() of a numpy float rounds otherwise than of a float
    nominal_ml_min = [float(q) * ML_MIN_PER_M3_S for q in machine.lubrication.nominal_flowrates_m3_s]
    to_ml_min = [q / 100.0 for q in nominal_ml_min]
    return ScenarioRun(
        scenario,
        float(noise_um),
        float(duration_s),
        int(seed),
        tuple(round(p * to_ml_min[0], 6) for p in scenario.q1_pct),
        tuple(round(p * to_ml_min[1], 6) for p in scenario.q2_pct),
        tuple(round(q, 6) for q in nominal_ml_min),
        machine.nominal_speed_hz,
        "" if is_default_machine(machine) else str(machine.source_path.resolve()),
        tuple(extra),
        *profiles,
    )


def _profiles(
    machine: Machine, speed: str | None, temperature: str | None
) -> tuple[OperatingProfile | None, OperatingProfile | None]:
    """The speed and oil-temperature profiles from their texts, checked against the allowed ranges."""
    out = []
    for text, nominal, name, (low, high), unit in (
        (speed, machine.nominal_speed_hz, "--speed-profile", SPEED_RANGE_HZ, "Hz"),
        (temperature, machine.nominal_oil_temperature_c, "--oil-temperature-profile", OIL_TEMPERATURE_RANGE_C,
         "degC"),
    ):  # fmt: skip
        if text is None:
            out.append(None)
            continue
        if nominal is None:
            raise InputError(f"{name} needs the machine's oil ([oil] in the machine file)")
        profile = parse_profile(text, nominal, name)
        lowest, highest = profile.extremes
        if lowest < low or highest > high:
            raise InputError(
                f"{name} must stay within [{low:g}, {high:g}] {unit}, got {lowest:g} to {highest:g} {unit} "
                f"({text!r})"
            )
        out.append(profile)
    return out[0], out[1]
