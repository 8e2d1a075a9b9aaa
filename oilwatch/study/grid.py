"""The case grid of the constant-flowrate study (the paper's Sec. 3.2.1, Figs. 7-8, Table 6).

q1 and q2 each run from 100 % down to 75 % of their bearing's own nominal flowrate (its machine file's
``[lubrication]`` or the bearing's ``[[bearings.override]]``; the bundled turbine: the paper's 596.3 ml/min)
in steps of ``grid_step_pct`` (1 % gives 26 x 26 = 676 cases per noise level); every (q1, q2) pair is run at
each noise level and with each noise seed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cache

import numpy as np

from oilwatch.experiment_config import STUDY_DEFAULTS
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
from oilwatch.models.machine import Machine, is_default_machine, load_machine
from oilwatch.models.validation import InputError, require_positive


@cache
def bundled_nominal_ml_min() -> tuple[float, float]:
    """The bundled turbine's nominal supply flowrate of each bearing [ml/min] (its machine file)."""
    return _nominal_ml_min(load_machine())


def _nominal_ml_min(machine: Machine) -> tuple[float, float]:
    """(bearing 1's, bearing 2's) nominal supply flowrate of ``machine`` [ml/min]: the two the study
    estimates."""
    first, second = (float(q) * ML_MIN_PER_M3_S for q in machine.lubrication.nominal_flowrates_m3_s[:2])
    return first, second


HIGH_PCT = 100.0
LOW_PCT = 75.0
SAMPLE_DT_S = 1e-3
"""The measurement sampling interval [s] (1 kHz)."""


@dataclass(frozen=True)
class Case:
    """One run of the study: true flowrates (each in % of its bearing's nominal), noise, seed, record length.

    noise_um: std of the white noise on each displacement channel [um]. seed: index of the noise
    realization (0, 1, ...). duration_s: record length [s]; discard_s: initial part left out of the average.
    machine_file: the machine ("": the bundled turbine); nominal_ml_min: each bearing's nominal flowrate
    [ml/min], which its percentage refers to.
    """

    q1_pct: float
    q2_pct: float
    noise_um: float
    seed: int = 0
    duration_s: float = STUDY_DEFAULTS.duration_s
    discard_s: float = STUDY_DEFAULTS.discard_s
    machine_file: str = ""
    nominal_ml_min: tuple[float, float] = field(default_factory=bundled_nominal_ml_min)

    @property
    def case_id(self) -> str:
        """Stable identifier, e.g. ``n1_q1-98_q2-85_s0``; the record length is a study setting, not in it."""
        return f"n{self.noise_um:g}_q1-{self.q1_pct:g}_q2-{self.q2_pct:g}_s{self.seed}"

    @property
    def settings_text(self) -> str:
        """The case in the user's terms: noise, grid point and seed index, as the study's flags name them."""
        return (
            f"--noise-um {self.noise_um:g}, q1 = {self.q1_pct:g} %, q2 = {self.q2_pct:g} % of each bearing's "
            "nominal, "
            f"--seeds index {self.seed}"
        )

    @property
    def q1_ml_min(self) -> float:
        """True supply flowrate of bearing 1 [ml/min]."""
        return self.nominal_ml_min[0] * self.q1_pct / 100.0

    @property
    def q2_ml_min(self) -> float:
        """True supply flowrate of bearing 2 [ml/min]."""
        return self.nominal_ml_min[1] * self.q2_pct / 100.0

    @property
    def n_samples(self) -> int:
        """Samples in the whole record at 1 kHz."""
        return round(self.duration_s / SAMPLE_DT_S)

    @property
    def rng_seed(self) -> int:
        """A 63-bit seed for this case's noise, the same in every process and on every machine."""
        words = [round(self.q1_pct * 1000), round(self.q2_pct * 1000), round(self.noise_um * 1000), self.seed]
        high, low = (int(word) for word in np.random.SeedSequence(words).generate_state(2, dtype=np.uint32))
        return (high << 31) ^ low


def grid_percents(grid_step_pct: float) -> np.ndarray:
    """The flowrate levels [% of nominal] from 100 down to 75 with the given step (which must divide 25)."""
    step = require_positive("--grid-step-pct", grid_step_pct, "%")
    n_steps = (HIGH_PCT - LOW_PCT) / step
    if abs(n_steps - round(n_steps)) > 1e-9 or step > HIGH_PCT - LOW_PCT:
        raise InputError(f"--grid-step-pct must divide 25 % (e.g. 1, 2.5, 5, 12.5), got {step:g}")
    return np.round(HIGH_PCT - step * np.arange(round(n_steps) + 1), 9)


def make_cases(
    noise_um: Sequence[float],
    grid_step_pct: float = STUDY_DEFAULTS.grid_step_pct,
    n_seeds: int = STUDY_DEFAULTS.seeds,
    duration_s: float = STUDY_DEFAULTS.duration_s,
    discard_s: float = STUDY_DEFAULTS.discard_s,
    machine: Machine | None = None,
) -> list[Case]:
    """All cases of a study, ordered by noise, seed, q1 (falling), q2 (falling), on ``machine`` (default:
    the bundled turbine)."""
    levels = [require_positive("--noise-um", value, "um") for value in noise_um]
    if not levels:
        raise InputError("--noise-um: give at least one noise level")
    if len(set(levels)) != len(levels):
        raise InputError(f"--noise-um: levels repeat: {levels}")
    if int(n_seeds) != n_seeds or n_seeds < 1:
        raise InputError(f"--seeds must be an integer >= 1, got {n_seeds!r}")
    duration = require_positive("--duration-s", duration_s, "s")
    if not (math.isfinite(discard_s) and 0.0 <= discard_s < duration):
        raise InputError(f"--discard-s must lie in [0, duration = {duration:g}) s, got {discard_s:g}")
    if round(duration / SAMPLE_DT_S) - round(discard_s / SAMPLE_DT_S) < 1:
        raise InputError("--duration-s: the record after --discard-s holds no 1 ms sample")
    percents = grid_percents(grid_step_pct)
    machine_file, nominal = "", bundled_nominal_ml_min()
    if machine is not None and not is_default_machine(machine):
        machine_file = str(machine.source_path.resolve())
        nominal = _nominal_ml_min(machine)
    return [
        Case(float(q1), float(q2), noise, seed, duration, float(discard_s), machine_file, nominal)
        for noise in levels
        for seed in range(int(n_seeds))
        for q1 in percents
        for q2 in percents
    ]
