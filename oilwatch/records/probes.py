"""The probe set-up of a recorded machine: which record column is which probe, and how to read it.

Read from the machine file's ``[probes]`` table (keys below; every key optional), overridable on the command
line with ``KEY=VALUE`` items (``x1.column=Ch0``, ``layout=api670``). The four proximity probes are named
``x1, y1, x2, y2``: two per bearing, bearing 1 first (the estimator's order).

Conventions (API 670; Bently Nevada's "Fundamentals of Rotating Machinery Diagnostics", ch. 5):

* A probe measures the shaft's displacement along its axis, positive towards the probe. Its mounting angle
  ``angle_deg`` is the direction from the bearing centre towards the probe, counterclockwise from the model's
  +x axis (horizontal) in the model's x-y frame (y up, gravity along -y). ``layout = "api670"`` puts the X
  probe at 45 deg (45 deg to the +x side of top dead centre) and the Y probe at 135 deg (the other side);
  seen from the other end of the machine, an angle a becomes 180 - a.
* ``unit = "um"``: the column is the displacement along the probe axis in um, ``zero_um`` being its reading
  with the shaft at the bearing centre (default 0: the record format of ``oilwatch baseline``).
* ``unit = "V"``: the column is the gap voltage [V], negative (the gap grows as the voltage falls), with the
  scale factor ``sensitivity_v_per_mm`` (API 670: 200 mV/mil = 7.87 V/mm) and ``rest_gap_v``, the reading at
  cold rest. At rest the journal lies on the bottom of the clearance, at (0, -c) from the bearing centre,
  so u = -c sin(angle) + (V - rest_gap_v) / sensitivity; the bearing centre is then known only to the
  clearance's tolerance, an offset of 10-25 um that the estimator's nuisance states are for.
* ``speed_column`` [Hz] and ``keyphasor_column`` (a once-per-revolution pulse [V]; its ``keyphasor_edge``
  crossing ``keyphasor_threshold_v`` (default: halfway between the first chunk's extremes) marks the rotor
  angle ``keyphasor_angle_deg`` of Eqs. 5-6, which fixes the 1x phase reference and the record's time origin);
  ``oil_temperature_column`` [degC]; ``time_column`` [s] (TDMS: default the waveform's ``wf_increment``).
* ``noise_um``: the std of the probes' white noise, the estimator's measurement noise.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numba
import numpy as np

from oilwatch.models.machine_keys import keys_of
from oilwatch.models.probes import LAYOUTS  # one key for the reader, the estimator and the plant
from oilwatch.models.validation import InputError

PROBE_NAMES = ("x1", "y1", "x2", "y2")
UNITS = ("um", "V")
EDGES = ("falling", "rising")
API670_SENSITIVITY_V_PER_MM = 7.87
"""API 670 scale factor, 200 mV/mil."""
FOREIGN_KEYS_PREFIX = ("offset_", "prior_", "scale_factor_")
"""[probes] keys of the estimator's nuisance priors and probe tolerances: accepted here, not read here."""
RUNOUT_PREFIX = "runout_"
"""Per-probe keys of the estimator's slow-roll vectors (:mod:`oilwatch.models.probes`): accepted here, not
used by the reader."""
PROBE_KEYS = tuple(key for key in keys_of("probes.<probe>") if not key.startswith(RUNOUT_PREFIX))
TOP_KEYS = tuple(key for key in keys_of("probes") if not key.startswith(FOREIGN_KEYS_PREFIX))
"""The reader's keys, as the machine-file reference declares them (:mod:`oilwatch.models.machine_keys`)."""


@dataclass(frozen=True)
class Probe:
    """One proximity probe (see the module docstring for the conventions)."""

    name: str
    column: str
    angle_deg: float
    unit: str = "um"
    sensitivity_v_per_mm: float = API670_SENSITIVITY_V_PER_MM
    rest_gap_v: float | None = None
    zero_um: float = 0.0

    @property
    def bearing(self) -> int:
        return int(self.name[1])

    @property
    def direction(self) -> tuple[float, float]:
        """Unit vector from the bearing centre towards the probe (model frame)."""
        if self.angle_deg % 90.0 == 0.0:  # exact axes: no 6e-17 cross-talk
            quarter = round(self.angle_deg / 90.0) % 4
            return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[quarter]
        angle = math.radians(self.angle_deg)
        return (math.cos(angle), math.sin(angle))


@dataclass(frozen=True)
class ProbeSetup:
    """The record's channel mapping and probe conventions (module docstring)."""

    probes: tuple[Probe, ...]
    noise_um: float = 1.0
    time_column: str = "time_s"
    speed_column: str = "speed_hz"
    oil_temperature_column: str = "oil_temperature_c"
    keyphasor_column: str = ""
    keyphasor_edge: str = "falling"
    keyphasor_threshold_v: float | None = None
    keyphasor_angle_deg: float = 0.0
    extra: Mapping[str, object] = field(default_factory=dict)

    def probe(self, name: str) -> Probe:
        return self.probes[PROBE_NAMES.index(name)]

    @property
    def probe_columns(self) -> tuple[str, ...]:
        return tuple(p.column for p in self.probes)

    def to_dict(self) -> dict:
        """JSON-able description (for the summary's provenance)."""
        out = {key: getattr(self, key) for key in TOP_KEYS if key != "layout"}
        out["probes"] = {
            p.name: {key: getattr(p, key) for key in PROBE_KEYS if getattr(p, key) is not None}
            for p in self.probes
        }
        return out


def _number(value: object, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"probes.{key} must be a finite number, got {value!r}")
    return float(value)


def _text(value: object, key: str) -> str:
    if not isinstance(value, str):
        raise InputError(f"probes.{key} must be text, got {value!r}")
    return value


def merged_section(table: Mapping[str, object], overrides: Iterable[str]) -> dict:
    """The [probes] table with the ``KEY=VALUE`` overrides applied (dotted keys reach the probe tables): what
    the reader and the estimator's probe model (``oilwatch.models.probes.read_probes``) both read."""
    merged = {key: (dict(value) if isinstance(value, Mapping) else value) for key, value in table.items()}
    for item in overrides:
        key, equals, text = item.partition("=")
        key = key.strip()
        if not equals or not key:
            raise InputError(f"--probe {item!r}: expected KEY=VALUE, e.g. x1.column=Ch0 or layout=api670")
        try:
            value: object = float(text)
        except ValueError:
            value = text
        head, dot, tail = key.partition(".")
        if dot:
            target = merged.setdefault(head, {})
            if not isinstance(target, dict):
                raise InputError(f"--probe {item!r}: probes.{head} is not a table")
            target[tail] = value
        else:
            merged[key] = value
    return merged


def probe_setup(table: Mapping[str, object] | None = None, overrides: Iterable[str] = ()) -> ProbeSetup:
    """The :class:`ProbeSetup` of a machine file's ``[probes]`` table and command-line overrides."""
    if table is not None and not isinstance(table, Mapping):
        raise InputError("[probes] must be a table")
    data = merged_section(table or {}, overrides)
    for key, value in data.items():
        known = key in TOP_KEYS or key in PROBE_NAMES or key.startswith(FOREIGN_KEYS_PREFIX)
        if not known:
            raise InputError(
                f"probes.{key}: unknown key; allowed: {', '.join(TOP_KEYS + PROBE_NAMES)} (and the "
                "estimator's offset_*, prior_* and scale_factor_* keys)"
            )
        if key in PROBE_NAMES and not isinstance(value, Mapping):
            raise InputError(f"probes.{key} must be a table of {', '.join(PROBE_KEYS)}")
    layout = _text(data.get("layout", "xy"), "layout")
    if layout not in LAYOUTS:
        raise InputError(f"probes.layout must be one of {', '.join(LAYOUTS)}, got {layout!r}")
    probes = tuple(_probe(name, data.get(name, {}), LAYOUTS[layout][name[0] == "y"]) for name in PROBE_NAMES)
    for bearing in (1, 2):
        a, b = (p for p in probes if p.bearing == bearing)
        if abs(math.sin(math.radians(a.angle_deg - b.angle_deg))) < 0.17:
            raise InputError(
                f"probes.{a.name}.angle_deg = {a.angle_deg:g} and probes.{b.name}.angle_deg = "
                f"{b.angle_deg:g}: the two probes of a bearing must be at least 10 deg from parallel"
            )
    edge = _text(data.get("keyphasor_edge", "falling"), "keyphasor_edge")
    if edge not in EDGES:
        raise InputError(f"probes.keyphasor_edge must be one of {', '.join(EDGES)}, got {edge!r}")
    noise = _number(data.get("noise_um", 1.0), "noise_um")
    if noise <= 0.0:
        raise InputError(f"probes.noise_um must be > 0 um, got {noise:g}")
    threshold = data.get("keyphasor_threshold_v")
    extra = {key: value for key, value in data.items() if key.startswith(FOREIGN_KEYS_PREFIX)}
    return ProbeSetup(
        probes=probes,
        noise_um=noise,
        time_column=_text(data.get("time_column", "time_s"), "time_column"),
        speed_column=_text(data.get("speed_column", "speed_hz"), "speed_column"),
        oil_temperature_column=_text(
            data.get("oil_temperature_column", "oil_temperature_c"), "oil_temperature_column"
        ),
        keyphasor_column=_text(data.get("keyphasor_column", ""), "keyphasor_column"),
        keyphasor_edge=edge,
        keyphasor_threshold_v=None if threshold is None else _number(threshold, "keyphasor_threshold_v"),
        keyphasor_angle_deg=_number(data.get("keyphasor_angle_deg", 0.0), "keyphasor_angle_deg"),
        extra=extra,
    )


def _probe(name: str, table: Mapping[str, object], default_angle: float) -> Probe:
    for key in table:
        if key not in PROBE_KEYS and not key.startswith(RUNOUT_PREFIX):
            raise InputError(f"probes.{name}.{key}: unknown key; allowed: {', '.join(PROBE_KEYS)}")
    unit = _text(table.get("unit", "um"), f"{name}.unit")
    if unit not in UNITS:
        raise InputError(f"probes.{name}.unit must be one of {', '.join(UNITS)}, got {unit!r}")
    sensitivity = _number(
        table.get("sensitivity_v_per_mm", API670_SENSITIVITY_V_PER_MM), f"{name}.sensitivity_v_per_mm"
    )
    if not 0.1 <= sensitivity <= 100.0:
        raise InputError(
            f"probes.{name}.sensitivity_v_per_mm must lie in [0.1, 100] V/mm, got {sensitivity:g}"
        )
    rest = table.get("rest_gap_v")
    if unit == "V":
        if rest is None:
            raise InputError(
                f"probes.{name}.rest_gap_v is required with unit = 'V': the gap voltage at cold rest "
                "(shaft on the bottom of the clearance), e.g. -10.0"
            )
        rest = _number(rest, f"{name}.rest_gap_v")
        if not -24.0 <= rest < 0.0:
            raise InputError(
                f"probes.{name}.rest_gap_v must lie in [-24, 0) V (gap voltage is negative), got {rest:g}"
            )
    default_column = f"{name}_v" if unit == "V" else f"{name}_um"
    return Probe(
        name=name,
        column=_text(table.get("column", default_column), f"{name}.column"),
        angle_deg=_number(table.get("angle_deg", default_angle), f"{name}.angle_deg"),
        unit=unit,
        sensitivity_v_per_mm=sensitivity,
        rest_gap_v=rest,
        zero_um=_number(table.get("zero_um", 0.0), f"{name}.zero_um"),
    )


def with_overrides(setup: ProbeSetup, **changes) -> ProbeSetup:
    """A copy of ``setup`` with top-level fields replaced."""
    return replace(setup, **changes)


@numba.njit(cache=True)
def _combine(along, inverse, out):  # pragma: no cover - compiled; covered through positions_m
    """out[k, i] = sum of inverse[i, j] along[k, j] over the nonzero inverse[i, j] only (a missing reading
    reaches only the coordinates it enters), summed in j order from 0.0. Compiled: a live record comes one
    line at a time, where a numpy call per term cost more than the line's estimate."""
    n, m = along.shape
    for k in range(n):
        for i in range(m):
            total = 0.0
            for j in range(m):
                if inverse[i, j] != 0.0:
                    total += inverse[i, j] * along[k, j]
            out[k, i] = total
    return out


class PositionConverter:
    """Probe readings (one column per probe, in its unit) -> the shaft's (x1, y1, x2, y2) [m] in the model
    frame from each bearing centre, for a machine of the bearings' radial clearances ``clearances_m``
    (bearing 1 first)."""

    def __init__(self, setup: ProbeSetup, clearances_m: Sequence[float]) -> None:
        self.setup = setup
        scale = np.zeros(4)
        offset = np.zeros(4)
        for i, probe in enumerate(setup.probes):
            if probe.unit == "um":
                scale[i], offset[i] = 1e-6, -probe.zero_um * 1e-6
            else:
                per_volt = 1e-3 / probe.sensitivity_v_per_mm  # m per V
                rest_m = -clearances_m[probe.bearing - 1] * probe.direction[1]
                scale[i], offset[i] = per_volt, rest_m - probe.rest_gap_v * per_volt
        self._scale, self._offset = scale, offset
        # per bearing: [n_a; n_b] (x, y) = (u_a, u_b)  ->  (x, y) = inv [u_a, u_b]
        self._inverse = np.zeros((4, 4))
        for b in range(2):
            normals = np.array([setup.probes[2 * b].direction, setup.probes[2 * b + 1].direction])
            self._inverse[2 * b : 2 * b + 2, 2 * b : 2 * b + 2] = np.linalg.inv(normals)

    @property
    def pair_angle_deg(self) -> float | None:
        """The estimator's ``probe_angle_deg`` (``EKFConfig``) when it can take these probes' readings along
        their axes, as the estimator FMU does: each bearing's Y probe 90 deg counter-clockwise of its X
        probe, both bearings' X probes at the same angle; None otherwise (the readings are then turned into
        (x, y) positions first)."""
        x1, y1, x2, y2 = (probe.angle_deg for probe in self.setup.probes)
        same = math.isclose(((x2 - x1 + 180.0) % 360.0) - 180.0, 0.0, abs_tol=1e-9)
        square = all(
            math.isclose(((y - x - 90.0 + 180.0) % 360.0) - 180.0, 0.0, abs_tol=1e-9)
            for x, y in ((x1, y1), (x2, y2))
        )
        return x1 if same and square else None

    def along_axis_m(self, readings: np.ndarray) -> np.ndarray:
        """(k, 4) readings in the probes' units -> (k, 4) displacements along each probe's axis [m]."""
        return readings * self._scale + self._offset

    def positions_from_axes_m(self, along_m: np.ndarray) -> np.ndarray:
        """(k, 4) displacements along the probes' axes [m] -> (x1, y1, x2, y2) [m] (NaN as in
        :meth:`positions_m`)."""
        along = np.ascontiguousarray(along_m, dtype=np.float64)
        return _combine(along, self._inverse, np.empty_like(along))

    def positions_m(self, readings: np.ndarray) -> np.ndarray:
        """(k, 4) readings -> (k, 4) (x1, y1, x2, y2) [m]. A missing (NaN) reading makes missing only the
        coordinates it enters: both of its bearing for inclined probes, one for probes along x and y."""
        return self.positions_from_axes_m(self.along_axis_m(readings))

    def readings(self, positions_m: np.ndarray) -> np.ndarray:
        """The inverse map: (k, 4) (x1, y1, x2, y2) [m] -> readings in the probes' units (for writing
        records)."""
        normals = np.linalg.inv(self._inverse)
        return (positions_m @ normals.T - self._offset) / self._scale
