"""The machine file's ``[probes]`` section: how the proximity probes are mounted and what is known of them.

Read from :attr:`oilwatch.models.machine.Machine.raw` (the section is optional; every key has a default)::

    [probes]
    layout = "xy"                    # the probes' mounting: "xy" (X at 0 deg, Y at 90 deg from horizontal)
                                     # or "api670" (X at 45, Y at 135: either side of top dead centre)
    # x1.angle_deg = 30.0            # or each probe's own angle (the recorded-data reader's per-probe key)
    offset_prior_std_um = 25.0       # std of each probe's zero offset before any baseline
    offset_random_walk_um_sqrt_s = 0.2   # drift of the offsets within a run [um / sqrt(s)]
    offset_drift_um_per_day = 0.1    # bound on the zero drift since a commissioning baseline [um / day]
    scale_factor_tolerance_pct = 5.0 # each probe's scale factor within +- this of its nominal (API 670)
    # x1.runout_1x_um = 2.0          # a probe's slow-roll (runout) vectors when known from the field's own
    # x1.runout_1x_phase_deg = 30.0  # slow-roll measurement: 1x and 2x amplitude, phase from the keyphasor
    # x1.runout_1x_std_um = 0.05     # and each component's std (keys runout_{1x,2x}_{um,phase_deg,std_um})

One fact, one key: the probes' angles (``layout``, or per probe ``x1.angle_deg`` ...) are read here for the
estimator and the plant and by the recorded-data reader (:mod:`oilwatch.records.probes`) from the same keys.
The estimator's probe model needs each bearing's Y probe 90 deg counter-clockwise of its X probe and the
same angle on both bearings: :attr:`Probes.angle_deg` is the X probes' angle (``EKFConfig.probe_angle_deg``).
The old estimator-only key ``angle_deg`` at the top of the section is refused with a one-line error naming
the key that replaces it.

The offsets' prior: the bearing centre is known only from the cold-rest position and a clearance with a
tolerance, so zero offsets of 10-25 um are ordinary. A baseline's offsets are widened by
``offset_drift_um_per_day`` times the days since it (``oilwatch.estimator.offset_baseline.OffsetBaseline``):
the within-run random walk is no model of months (0.2 um/sqrt(s) is 59 um after a day). The default drift
bound, 0.1 um/day: API 670 allows a probe, cable and driver set a deviation from its straight line of +-25 um
(1 mil) over 0-45 degC, and a seasonal swing of about 20 degC over about 90 days moves a zero by up to
25 um x 20/45 / 90 days = 0.12 um/day; a baseline a month old is then trusted to 3 um (``oilwatch
robustness``'s offsets-step case).

The scale factors: API 670 allows a probe, cable and driver set +-5 % on its scale factor (nominally
7.87 V/mm), and an installation whose sets were not calibrated together reads every displacement that much
off. ``scale_factor_tolerance_pct`` is that tolerance; read as a uniform error within it (the GUM's type-B
reading of a tolerance), each probe's scale factor has the std tolerance / sqrt(3)
(:attr:`Probes.scale_factor_std`, 2.9 % by default), which the estimator carries into its published std
(``EKFConfig.probe_scale_factor_std``). 0: probes calibrated as a set.

Runout: :attr:`Probes.runout` holds the per-probe ``runout_*`` keys as the lists a baseline file stores
(``oilwatch.estimator.runout.SlowRollVectors.from_document`` reads it:
:func:`oilwatch.estimator.runout.runout_of_probes`); None when no probe has one. A probe's missing keys are 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .machine import Machine
from .validation import InputError, require_in_range

LAYOUTS = {"xy": (0.0, 90.0), "api670": (45.0, 135.0)}
"""Mounting angles (X probe, Y probe) [deg] of the named layouts, counter-clockwise from the model's +x."""

DEFAULTS = {
    "offset_prior_std_um": 25.0,
    "offset_random_walk_um_sqrt_s": 0.2,
    "offset_drift_um_per_day": 0.1,
    "scale_factor_tolerance_pct": 5.0,
}

RUNOUT_KEYS = {
    "runout_1x_um": (0.0, 100.0),
    "runout_1x_phase_deg": (-360.0, 360.0),
    "runout_1x_std_um": (0.0, 100.0),
    "runout_2x_um": (0.0, 100.0),
    "runout_2x_phase_deg": (-360.0, 360.0),
    "runout_2x_std_um": (0.0, 100.0),
}
"""The per-probe runout keys and their ranges (field units: um, degrees from the keyphasor)."""


@dataclass(frozen=True)
class Probes:
    """SI values of the ``[probes]`` section: angle_deg (the X probes' angle) [deg], offset_prior_std_m [m],
    offset_random_walk_m_sqrt_s [m / sqrt(s)], offset_drift_m_per_day [m / day]; scale_factor_std: each
    probe's scale-factor std relative to its nominal [-] (module docstring); runout: the per-probe runout
    keys as {key: [x1, y1, x2, y2]} in the field's units, or None (module docstring)."""

    angle_deg: float
    offset_prior_std_m: float
    offset_random_walk_m_sqrt_s: float
    offset_drift_m_per_day: float = 0.0
    scale_factor_std: float = 0.0
    runout: dict | None = None


def _runout(section: dict) -> dict | None:
    """The per-probe runout keys (module docstring), None when no probe gives one."""
    columns = {key: [0.0] * 4 for key in RUNOUT_KEYS}
    given = False
    for k, name in enumerate(("x1", "y1", "x2", "y2")):
        table = section.get(name, {})
        if not isinstance(table, dict):
            continue
        for key, (low, high) in RUNOUT_KEYS.items():
            if key not in table:
                continue
            value = table[key]
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InputError(f"probes.{name}.{key} must be a number, got {value!r}")
            unit = "deg" if key.endswith("deg") else "um"
            columns[key][k] = require_in_range(f"probes.{name}.{key}", float(value), low, high, unit)
            given = True
    return columns if given else None


def _probe_angles(section: dict) -> dict[str, float]:
    """Each probe's mounting angle [deg] from ``layout`` and the per-probe ``angle_deg`` keys."""
    if "angle_deg" in section:
        raise InputError(
            "probes.angle_deg is no longer read: give the mounting as probes.layout ('xy': 0 deg, "
            "'api670': 45 deg) or per probe (x1.angle_deg, ...), the keys the recorded-data reader shares"
        )
    layout = section.get("layout", "xy")
    if layout not in LAYOUTS:
        raise InputError(f"probes.layout must be one of {', '.join(LAYOUTS)}, got {layout!r}")
    angles = {}
    for name in ("x1", "y1", "x2", "y2"):
        table = section.get(name, {})
        value = table.get("angle_deg", LAYOUTS[layout][name[0] == "y"]) if isinstance(table, dict) else None
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise InputError(f"probes.{name}.angle_deg must be a number, got {value!r}")
        angles[name] = float(value)
    return angles


def probe_pair_angle_deg(section: dict) -> float:
    """The X probes' angle [deg] the estimator and the plant use (module docstring; one-line InputError when
    the probes are not two perpendicular pairs at the same angle)."""
    angles = _probe_angles(section)
    x_angle = angles["x1"]
    for bearing in ("1", "2"):
        x, y = angles["x" + bearing], angles["y" + bearing]
        if abs(math.remainder(x - x_angle, 360.0)) > 1e-9 or abs(math.remainder(y - x - 90.0, 360.0)) > 1e-9:
            raise InputError(
                f"probes: the estimator needs each Y probe 90 deg counter-clockwise of its X probe and the "
                f"same angle on both bearings; got x1 {angles['x1']:g}, y1 {angles['y1']:g}, x2 "
                f"{angles['x2']:g}, y2 {angles['y2']:g} deg"
            )
    return math.remainder(x_angle, 360.0)


def read_probes(machine: Machine) -> Probes:
    """The machine's probe section with its defaults (one-line InputError naming a bad key)."""
    section = machine.raw.get("probes", {})
    if not isinstance(section, dict):
        raise InputError("[probes] must be a table")
    # the section is shared with the recorded-data reader (columns, units): only these keys are read here
    values = {key: section.get(key, default) for key, default in DEFAULTS.items()}
    for key, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InputError(f"probes.{key} must be a number, got {value!r}")
    return Probes(
        angle_deg=probe_pair_angle_deg(section),
        offset_prior_std_m=require_in_range(
            "probes.offset_prior_std_um", float(values["offset_prior_std_um"]), 0.0, 1000.0, "um"
        )
        * 1e-6,
        offset_random_walk_m_sqrt_s=require_in_range(
            "probes.offset_random_walk_um_sqrt_s", float(values["offset_random_walk_um_sqrt_s"]), 0.0, 100.0
        )
        * 1e-6,
        offset_drift_m_per_day=require_in_range(
            "probes.offset_drift_um_per_day", float(values["offset_drift_um_per_day"]), 0.0, 1000.0, "um/day"
        )
        * 1e-6,
        scale_factor_std=require_in_range(
            "probes.scale_factor_tolerance_pct", float(values["scale_factor_tolerance_pct"]), 0.0, 50.0, "%"
        )
        / (100.0 * math.sqrt(3.0)),
        runout=_runout(section),
    )
