"""Bearing coefficient tables over supply flowrate: computation, JSON file, fast interpolation.

The estimator needs, at every 1 ms step and for each bearing, the equilibrium position and the
eight coefficients at the current flowrate estimate q, and their derivatives with respect to q (its
Jacobian). The table holds them at a few flowrates (paper: 7 points from 50 % to 150 % of q_t) and
interpolates each quantity by PCHIP, the monotone piecewise-cubic Hermite interpolant of Fritsch &
Carlson (1980): C1, exact at the nodes, no overshoot between nodes, and it follows the kink that the
regime change (starved below q_t, flooded above) puts in every curve at q_t, where a C2 spline would
ring. (K even jumps there, by up to about 10 % on Kxy and Kyy; the q_t node holds the mean of the
two one-sided limits, and the interpolant passes through it.) The cubic coefficients of every
interval are precomputed, so an evaluation is one bisection and one Horner step on a 10-vector (a
few microseconds). No extrapolation: outside the tabulated range :class:`InputError`.
"""

from __future__ import annotations

import bisect
import dataclasses
import datetime as dt
import json
import math
import platform
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import numpy as np

from ..validation import InputError, naming_file, read_text_file, require_fields, require_positive
from .coefficient_kinds import COEFFICIENT_KINDS, QUASI_STATIC, SYNCHRONOUS, require_kind
from .dynamic import synchronous_coefficients
from .equilibrium import (
    DISPLACEMENT_STEP_RATIO,
    coefficients_at,
    on_flooded_threshold,
    one_sided_coefficients,
    static_equilibrium,
)
from .geometry import JournalBearing
from .grid import PRODUCTION_MESH, Mesh
from .supply import ML_MIN_PER_M3_S, SupplyFlow, SupplyPressure

FORMAT = "oilwatch bearing coefficient table"
FORMAT_VERSION = 1
_PAIRS = ("xx", "xy", "yx", "yy")


@dataclass(frozen=True)
class BearingCoefficients:
    """Equilibrium position (2,) [m], stiffness K (2, 2) [N/m] and damping C (2, 2) [N s/m].

    As a derivative (``evaluate_with_derivative``) the same fields hold d/dq of each, per m^3/s.
    """

    eccentricity_m: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray


def flooded_threshold(bearing: JournalBearing, load_n: float, speed_hz: float, mesh: Mesh | None = None):
    """Flooded threshold q_t [m^3/s] (groove full at zero gauge pressure) and its equilibrium."""
    eq = static_equilibrium(bearing, load_n, speed_hz, SupplyPressure(0.0), mesh)
    return eq.supply_flow_m3_s, eq


def pchip_coefficients(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The piecewise-cubic coefficients of the PCHIP interpolant of ``y`` (n, m) over the nodes ``x`` (n,).

    Fritsch & Butland's node derivatives (the weighted harmonic mean of the neighbouring slopes, zero where
    they differ in sign or one is zero) and Moler's shape-preserving three-point formula at the ends: the
    interpolant of ``scipy.interpolate.PchipInterpolator``, whose coefficients these are to the last bit
    (``tests/test_bearing_table.py``). Computed here, not by scipy.interpolate, whose import (0.2 s, with
    scipy.optimize) is most of what an FMU would spend on it at its start.

    Parameters
    ----------
    x : (n,) array, increasing, n >= 2.
    y : (n, m) array.

    Returns
    -------
    (4, n - 1, m) array: interval k's cubic in (x - x[k]), highest power first (``PPoly.c``'s layout).

    References
    ----------
    F. N. Fritsch and J. Butland, "A method for constructing local monotone piecewise cubic interpolants",
    SIAM J. Sci. Stat. Comput. 5 (1984) 300-304. C. Moler, *Numerical Computing with MATLAB*, SIAM 2004,
    sec. 3.6 (``pchiptx``).
    """
    h = np.diff(x)[:, None]
    slope = np.diff(y, axis=0) / h
    derivative = np.zeros_like(y)
    if len(x) == 2:
        derivative[:] = slope
    else:
        w1 = 2.0 * h[1:] + h[:-1]
        w2 = h[1:] + 2.0 * h[:-1]
        flat = (np.sign(slope[1:]) != np.sign(slope[:-1])) | (slope[1:] == 0.0) | (slope[:-1] == 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            mean = (w1 / slope[:-1] + w2 / slope[1:]) / (w1 + w2)
        derivative[1:-1] = np.where(flat, 0.0, 1.0 / np.where(flat, 1.0, mean))
        derivative[0] = _pchip_end(h[0], h[1], slope[0], slope[1])
        derivative[-1] = _pchip_end(h[-1], h[-2], slope[-1], slope[-2])
    t = (derivative[:-1] + derivative[1:] - 2.0 * slope) / h
    return np.stack([t / h, (slope - derivative[:-1]) / h - t, derivative[:-1], y[:-1]])


def _pchip_end(h0, h1, m0, m1) -> np.ndarray:
    """An end node's derivative: the one-sided three-point estimate, held to the end slope's sign and within
    three times it where the slopes change sign (Moler's ``pchiptx``)."""
    d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
    d = np.where(np.sign(d) != np.sign(m0), 0.0, d)
    return np.where((np.sign(m0) != np.sign(m1)) & (np.abs(d) > 3.0 * np.abs(m0)), 3.0 * m0, d)


class CoefficientTable:
    """Tabulated equilibrium and coefficients over supply flowrate, with PCHIP interpolation.

    Arrays (n = number of flowrates, increasing): flowrates_m3_s (n,), eccentricity_m (n, 2),
    eccentricity_ratio (n,), attitude_deg (n,), supply_pressure_pa (n,), side_leakage_m3_s (n,),
    regimes (n,) str, stiffness (n, 2, 2) [N/m], damping (n, 2, 2) [N s/m]; speed_hz, load_n, and
    ``metadata`` (mesh, tolerances, bearing, provenance).
    """

    def __init__(self, rows: list[dict], speed_hz: float, load_n: float, metadata: dict):
        if len(rows) < 2:
            raise InputError(f"a coefficient table needs at least 2 flowrates, got {len(rows)}")
        rows = sorted(rows, key=lambda r: r["supply_flowrate_m3_s"])
        self.speed_hz = float(speed_hz)
        self.load_n = float(load_n)
        self.metadata = metadata
        self.rows = rows
        self.flowrates_m3_s = np.array([r["supply_flowrate_m3_s"] for r in rows])
        if np.any(np.diff(self.flowrates_m3_s) <= 0.0):
            raise InputError("coefficient table flowrates must be distinct")
        self.eccentricity_m = np.array([[r["eccentricity_x_m"], r["eccentricity_y_m"]] for r in rows])
        self.eccentricity_ratio = np.array([r["eccentricity_ratio"] for r in rows])
        self.attitude_deg = np.array([r["attitude_deg"] for r in rows])
        self.supply_pressure_pa = np.array([r["supply_pressure_pa"] for r in rows])
        self.side_leakage_m3_s = np.array([r["side_leakage_m3_s"] for r in rows])
        self.regimes = [r["regime"] for r in rows]
        self.stiffness = np.array([_matrix(r["stiffness_n_per_m"]) for r in rows])
        self.damping = np.array([_matrix(r["damping_n_s_per_m"]) for r in rows])
        values = np.concatenate(
            [
                self.eccentricity_m,
                self.stiffness.reshape(-1, 4),
                self.damping.reshape(-1, 4),
            ],
            axis=1,
        )
        cubic = pchip_coefficients(self.flowrates_m3_s, values)  # (4, n-1, 10), high first
        self._coef = np.ascontiguousarray(np.transpose(cubic[::-1], (1, 0, 2)))  # (n-1, 4, 10)
        self._nodes = [float(q) for q in self.flowrates_m3_s]
        self._node_array = np.array(self._nodes)
        self._q_min, self._q_max = self._nodes[0], self._nodes[-1]

    @property
    def flowrate_range_m3_s(self) -> tuple[float, float]:
        """(lowest, highest) tabulated supply flowrate [m^3/s]."""
        return self._q_min, self._q_max

    def _interval(self, q_m3_s: float) -> tuple[int, float]:
        q = float(q_m3_s)
        if not self._q_min <= q <= self._q_max:
            raise InputError(
                f"supply flowrate q = {q * ML_MIN_PER_M3_S:.6g} ml/min ({q:.6g} m^3/s) is outside "
                f"the table range [{self._q_min * ML_MIN_PER_M3_S:.6g}, "
                f"{self._q_max * ML_MIN_PER_M3_S:.6g}] ml/min (no extrapolation)"
            )
        i = min(bisect.bisect_right(self._nodes, q) - 1, len(self._nodes) - 2)
        return i, q - self._nodes[i]

    def evaluate(self, q_m3_s: float) -> BearingCoefficients:
        """Interpolated equilibrium and coefficients at supply flowrate ``q_m3_s`` [m^3/s]."""
        i, t = self._interval(q_m3_s)
        c = self._coef[i]
        v = c[0] + t * (c[1] + t * (c[2] + t * c[3]))
        return BearingCoefficients(v[0:2], v[2:6].reshape(2, 2), v[6:10].reshape(2, 2))

    def evaluate_many(self, q_m3_s: np.ndarray) -> np.ndarray:
        """Interpolated rows at the flowrates ``q_m3_s`` (m,) [m^3/s]: (m, 10) as ``[e_x, e_y, K (row-major),
        C (row-major)]`` in SI units, the values of :meth:`evaluate` in one array."""
        q = np.asarray(q_m3_s, dtype=float)
        if not (self._q_min <= q.min() and q.max() <= self._q_max):
            self._interval(q.min() if q.min() < self._q_min else q.max())  # raises, naming the flowrate
        i = np.minimum(np.searchsorted(self._node_array, q, side="right") - 1, len(self._nodes) - 2)
        t = (q - self._node_array[i])[:, None]
        c = self._coef[i]
        return c[:, 0] + t * (c[:, 1] + t * (c[:, 2] + t * c[:, 3]))

    def evaluate_with_derivative(self, q_m3_s: float) -> tuple[BearingCoefficients, BearingCoefficients]:
        """(values, d/dq of the values [per m^3/s]) at ``q_m3_s`` [m^3/s]."""
        i, t = self._interval(q_m3_s)
        c = self._coef[i]
        v = c[0] + t * (c[1] + t * (c[2] + t * c[3]))
        d = c[1] + t * (2.0 * c[2] + 3.0 * t * c[3])
        return (
            BearingCoefficients(v[0:2], v[2:6].reshape(2, 2), v[6:10].reshape(2, 2)),
            BearingCoefficients(d[0:2], d[2:6].reshape(2, 2), d[6:10].reshape(2, 2)),
        )

    def to_dict(self) -> dict:
        """The JSON document (units in every key)."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "speed_hz": self.speed_hz,
            "load_n": self.load_n,
            **self.metadata,
            "rows": self.rows,
        }

    def save(self, path: str | Path) -> None:
        """Write the table as JSON to ``path``."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=1) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> CoefficientTable:
        """Read a table written by :meth:`save`; InputError naming the file and the missing or bad key
        when it is not one (its structure is checked before any of it is used)."""
        if not Path(path).is_file():
            raise InputError(f"coefficient table file not found: {path}")
        text = read_text_file("coefficient table", path, "a JSON file written by oilwatch bearing-table")
        try:
            data = json.loads(text)
        except json.JSONDecodeError as error:
            raise InputError(f"coefficient table {path} is not valid JSON: {error}") from None
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            found = data.get("format") if isinstance(data, dict) else type(data).__name__
            raise InputError(f"{path} is not an {FORMAT} (format={found!r})")
        with naming_file("coefficient table", path):
            require_fields(data, "the table", _TABLE_FIELDS)
            for i, row in enumerate(data["rows"]):
                require_fields(row, f"rows[{i}]", _ROW_FIELDS)
                for key in ("stiffness_n_per_m", "damping_n_s_per_m"):
                    require_fields(row[key], f"rows[{i}].{key}", dict.fromkeys(_PAIRS, float))
                    bad = [pair for pair in _PAIRS if not math.isfinite(float(row[key][pair]))]
                    if bad:  # interpolated, a NaN would fail deep inside scipy
                        raise InputError(
                            f"rows[{i}].{key}.{bad[0]} must be a finite number, got {row[key][bad[0]]!r}"
                        )
            meta = {k: v for k, v in data.items() if k not in ("format", "format_version", "rows")}
            meta.pop("speed_hz", None)
            meta.pop("load_n", None)
            return cls(data["rows"], data["speed_hz"], data["load_n"], meta)


_TABLE_FIELDS = {"speed_hz": float, "load_n": float, "rows": list}
_ROW_FIELDS = {
    "supply_flowrate_m3_s": float,
    "regime": str,
    "eccentricity_x_m": float,
    "eccentricity_y_m": float,
    "eccentricity_ratio": float,
    "attitude_deg": float,
    "supply_pressure_pa": float,
    "side_leakage_m3_s": float,
    "stiffness_n_per_m": dict,
    "damping_n_s_per_m": dict,
}
"""What :meth:`CoefficientTable.load` needs of each row of a table file (the keys of :func:`table_row`)."""


def _matrix(entries: dict) -> np.ndarray:
    return np.array([[entries["xx"], entries["xy"]], [entries["yx"], entries["yy"]]])


def _entries(matrix: np.ndarray) -> dict:
    return {k: float(v) for k, v in zip(_PAIRS, matrix.ravel(), strict=True)}


def table_row(eq, stiffness: np.ndarray, damping: np.ndarray) -> dict:
    """One table row (JSON-ready, units in the keys) from an equilibrium and its coefficients."""
    return {
        "supply_flowrate_m3_s": eq.supply_flow_m3_s,
        "supply_flowrate_ml_min": eq.supply_flow_m3_s * ML_MIN_PER_M3_S,
        "regime": eq.regime,
        "eccentricity_x_m": float(eq.eccentricity_m[0]),
        "eccentricity_y_m": float(eq.eccentricity_m[1]),
        "eccentricity_ratio": eq.eccentricity_ratio,
        "attitude_deg": eq.attitude_deg,
        "supply_pressure_pa": eq.supply_pressure_pa,
        "side_leakage_m3_s": eq.side_leakage_m3_s,
        "stiffness_n_per_m": _entries(stiffness),
        "damping_n_s_per_m": _entries(damping),
    }


def compute_table(
    bearing: JournalBearing,
    load_n: float,
    speed_hz: float,
    flowrates_m3_s,
    mesh: Mesh | None = None,
    progress: Callable[[int, int], None] | None = None,
    *,
    flooded_threshold_m3_s: float | None = None,
    provenance: dict | None = None,
    coefficients: str = QUASI_STATIC,
) -> CoefficientTable:
    """Equilibrium and coefficients at each supply flowrate [m^3/s] (``SupplyFlow``), as a table.

    Points are solved from the highest flowrate down, each equilibrium starting from the previous
    one. ``provenance`` entries (e.g. the command line) are stored with the table. A point on the
    flooded threshold (the q_t node) holds the mean of the starved and flooded one-sided
    coefficients (K and C jump across q_t, see ``coefficients_at``) and also stores both limits
    under ``one_sided_at_flooded_threshold``.

    ``coefficients`` (:data:`~oilwatch.models.bearing.coefficient_kinds.COEFFICIENT_KINDS`):
    ``"quasi-static"`` (:func:`coefficients_at`) or ``"synchronous"``: K(Omega), C(Omega) of the transient
    film at whirl frequency = spin speed (:func:`oilwatch.models.bearing.dynamic.synchronous_coefficients`; on
    q_t the mean of the one-sided impedances).
    """
    mesh = PRODUCTION_MESH if mesh is None else mesh
    require_kind(coefficients)
    require_positive("load_n", load_n, "N")
    require_positive("speed_hz", speed_hz, "Hz")
    flows = sorted((float(q) for q in flowrates_m3_s), reverse=True)
    for q in flows:
        require_positive("supply flowrate", q, "m^3/s")
    rows = []
    guess = None
    for done, q in enumerate(flows):
        if progress is not None:
            progress(done, len(flows))
        supply = SupplyFlow(q)
        eq = static_equilibrium(bearing, load_n, speed_hz, supply, mesh, initial_guess_m=guess)
        if coefficients == SYNCHRONOUS:
            stiffness, damping = synchronous_coefficients(eq.film, eq.eccentricity_m, speed_hz, supply)
        else:
            stiffness, damping = coefficients_at(bearing, eq, speed_hz, supply, mesh)
        row = table_row(eq, stiffness, damping)
        if coefficients == SYNCHRONOUS and on_flooded_threshold(eq.film, supply, speed_hz):
            row["at_flooded_threshold"] = "mean of the starved and flooded one-sided impedances"
        elif on_flooded_threshold(eq.film, supply, speed_hz):
            sides = one_sided_coefficients(bearing, eq, speed_hz, supply, mesh)
            row["one_sided_at_flooded_threshold"] = {
                side: {"stiffness_n_per_m": _entries(k), "damping_n_s_per_m": _entries(c)}
                for side, (k, c) in sides.items()
            }
        rows.append(row)
        guess = eq.eccentricity_m
    meta = {
        "units": "SI unless the key says otherwise; flowrates also in ml/min",
        "flooded_threshold_m3_s": flooded_threshold_m3_s,
        "bearing": dataclasses.asdict(bearing),
        "mesh": {"n_circ": mesh.n_circ, "n_axial": mesh.n_axial},
        "solver": {
            "method": "p-theta finite volumes, semi-smooth Newton (active set), sparse LU",
            "coefficients": COEFFICIENT_KINDS[coefficients],
            "squeeze": "full-film (frozen film content; see models.bearing.film)"
            if coefficients == QUASI_STATIC
            else "transient: d(h theta)/dt with fluid-fraction transport (models.bearing.dynamic)",
            "equilibrium_force_tolerance": 1e-9,
            "displacement_step_ratio": DISPLACEMENT_STEP_RATIO,
            "stiffness": "central differences on the equilibrium's full/cavitated partition (held)"
            if coefficients == QUASI_STATIC
            else "K = Re Z(i Omega), C = Im Z(i Omega) / Omega on the held partition",
            "at_flooded_threshold": "mean of the starved and flooded one-sided coefficients",
        },
        "interpolation": "PCHIP (Fritsch-Carlson monotone piecewise cubic Hermite) over q",
        "provenance": {
            "oilwatch_version": _version(),
            "date_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
            "python": platform.python_version(),
            "numpy": np.__version__,
            **(provenance or {}),
        },
    }
    return CoefficientTable(rows, speed_hz, load_n, meta)


def _version() -> str:
    try:
        return metadata.version("oilwatch")
    except metadata.PackageNotFoundError:
        return "unknown"
