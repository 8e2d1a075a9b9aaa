"""The user's settings of a scenario run (``oilwatch run``) and of an identification study
(``oilwatch study``).

Each is a frozen dataclass whose fields carry their unit, allowed range and description as field metadata
(as :mod:`oilwatch.estimator.ekf_config` does for the estimator): the defaults live here once, the scenario
and study code read them, and the CLI options and their help are generated from them
(:func:`oilwatch.cli.config_options.add_config_options`). These are settings of an experiment, not facts of
a machine: a machine's nominal flowrate and speed come from its machine file.

The module imports only the standard library and :mod:`oilwatch.models.validation`, so that ``--help`` stays
fast.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from numbers import Real

from oilwatch.models.validation import MAX_SEED, InputError, require_in_range


def setting(
    default, unit: str, description: str, low: float | None = None, high: float | None = None, **extra
):
    """A field with its unit (``"1"``: none), description and allowed range [low, high] (None: open).

    extra: ``allowed`` (a phrase for a rule a range cannot say, e.g. ``"must divide 25"``), ``nargs``
    (``"+"`` for a tuple setting: the option takes several values) and ``metavar`` for the CLI.
    """
    metadata = {"unit": unit, "description": description, "low": low, "high": high, **extra}
    return field(default=default, metadata=metadata)


def flag(name: str) -> str:
    """The CLI flag of a setting: ``noise_um`` -> ``--noise-um``."""
    return "--" + name.replace("_", "-")


def allowed_text(spec) -> str:
    """What a setting allows, in its unit: ``1 to 200 %``, ``>= 0``, or its ``allowed`` phrase."""
    meta = spec.metadata
    if "allowed" in meta:
        return meta["allowed"]
    unit = "" if meta["unit"] == "1" else f" {meta['unit']}"
    low, high = meta["low"], meta["high"]
    if low is not None and high is not None:
        return f"{low:g} to {high:g}{unit}"
    if low is not None:
        return f">= {low:g}{unit}"
    if high is not None:
        return f"<= {high:g}{unit}"
    return ""


def check_ranges(config) -> None:
    """InputError naming the flag of the first field of ``config`` outside its range, not finite, or (an
    integer setting) not an integer."""
    for spec in fields(config):
        meta, value = spec.metadata, getattr(config, spec.name)
        name, unit = flag(spec.name), "" if meta["unit"] == "1" else meta["unit"]
        integer = isinstance(spec.default, int) and not isinstance(spec.default, bool)
        for item in value if isinstance(value, tuple | list) else [value]:
            whole = (
                isinstance(item, Real)
                and not isinstance(item, bool)
                and math.isfinite(item)
                and item == int(item)
            )
            low = -math.inf if meta["low"] is None else meta["low"]
            high = math.inf if meta["high"] is None else meta["high"]
            if integer and not (whole and low <= item <= high):
                finite = math.isfinite(low + high)
                bounds = f"in [{int(low)}, {int(high)}]" if finite else f"({allowed_text(spec)})"
                raise InputError(f"{name} must be an integer {bounds}, got {item!r}")
            require_in_range(name, item, low, high, unit)


@dataclass(frozen=True)
class ScenarioConfig:
    """The settings of one real-time scenario run (:func:`oilwatch.scenarios.make_run`)."""

    noise_um: float = setting(1.0, "um", "measurement noise std of each probe", 1e-3, 50.0)
    duration_s: float = setting(
        20.0, "s", "record length, a multiple of the 1 ms sampling period; the transition is centred at half "
        "of it", 1.0, 3600.0,
    )  # fmt: skip
    seed: int = setting(1, "1", "seed of the measurement noise (an FMI Integer)", 0, MAX_SEED)
    q1_pct: float = setting(100.0, "%", "constant scenario: bearing 1 flowrate, % of its nominal", 1.0, 200.0)
    q2_pct: float = setting(100.0, "%", "constant scenario: bearing 2 flowrate, % of its nominal", 1.0, 200.0)

    def __post_init__(self) -> None:
        check_ranges(self)


@dataclass(frozen=True)
class StudyConfig:
    """The settings of the constant-flowrate identification study (:func:`oilwatch.study.make_cases` and
    the runner's retries). Rules beyond a range are checked by :func:`~oilwatch.study.make_cases`."""

    noise_um: tuple[float, ...] = setting(
        (1.0, 2.0), "um", "measurement noise std per displacement channel, one study per level",
        allowed="> 0 um, distinct", nargs="+", metavar="UM",
    )  # fmt: skip
    grid_step_pct: float = setting(
        1.0, "%", "grid step, % of nominal (1: 26 x 26 cases)", allowed="must divide 25 %", metavar="PCT"
    )
    seeds: int = setting(1, "1", "noise realizations per case", allowed=">= 1", metavar="N")
    duration_s: float = setting(10.0, "s", "record length", allowed="> 0 s")
    discard_s: float = setting(5.0, "s", "initial part of the record left out of the average",
                               allowed="0 <= discard < duration")  # fmt: skip
    retries: int = setting(2, "1", "extra attempts of a failing case", allowed=">= 0")


SCENARIO_DEFAULTS = ScenarioConfig()
STUDY_DEFAULTS = StudyConfig()
