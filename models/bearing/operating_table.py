"""One bearing table for any speed, viscosity, load and supply flowrate: the dimensionless p-theta solution.

For a given bearing geometry (R, L, c, groove) the steady mass-conserving film scales exactly: pressure with
mu Omega (R/c)^2, force with mu Omega R L (R/c)^2, flow with the film's Couette flow q_c = Omega R c L / 2.
The equilibrium eccentricity ratio and attitude, and the coefficients in the form K c / W and C c Omega / W,
are therefore functions of two numbers only (Lund 1987; Childs 1993, ch. 3):

* the Sommerfeld number S = mu N L D (R/c)^2 / W (N = Omega / 2 pi in rev/s, D = 2 R),
* the supply flowrate, here as a fraction f = q / q_t(S) of the flooded threshold at that Sommerfeld
  number (q_t / q_c is itself a function of S alone). Measuring the flowrate against q_t puts the regime
  change (starved below, flooded above, where K jumps) on one grid line, f = 1, for every S.

oilwatch's solver reproduces this scaling to round-off (tests/test_operating_table.py solves one point at two
speeds). :func:`compute_operating_table` solves the equilibrium and the eight coefficients with the
project's conventions (:func:`models.bearing.table.compute_table`: held-partition stiffness, default
full-film squeeze, mean of the one-sided limits on f = 1) on a grid uniform in ln S and in f.
:class:`OperatingTable` interpolates it by tensor-product Catmull-Rom (:mod:`models.catmull_rom`: C1,
exact at the nodes, linear in the data), and gives dimensional values and their derivatives with respect
to the flowrate and the viscosity at any (speed, viscosity, load, flowrate) inside the grid; outside,
:class:`~models.validation.InputError` (no extrapolation).
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from .. import catmull_rom
from ..validation import InputError, require_finite, require_positive
from .coefficient_kinds import QUASI_STATIC, file_suffix
from .geometry import JournalBearing
from .grid import PRODUCTION_MESH, Mesh
from .supply import ML_MIN_PER_M3_S
from .table import BearingCoefficients, compute_table, flooded_threshold

FORMAT = "oilwatch dimensionless bearing table"
FORMAT_VERSION = 1
_PAIRS = ("xx", "xy", "yx", "yy")
N_QUANTITIES = 11
"""Per node: e_x / c, e_y / c, K c / W (4, row-major), C c Omega / W (4), p_g c^2 / (mu Omega R^2)."""
GEOMETRY_KEYS = (
    "radius_m",
    "length_m",
    "clearance_m",
    "groove_angle_rad",
    "groove_circumferential_m",
    "groove_axial_m",
)


def sommerfeld_number(
    bearing: JournalBearing, viscosity_pa_s: float, speed_hz: float, load_n: float
) -> float:
    """S = mu N L D (R/c)^2 / W [-] (N in rev/s)."""
    r, c = bearing.radius_m, bearing.clearance_m
    return viscosity_pa_s * speed_hz * bearing.length_m * 2.0 * r * (r / c) ** 2 / load_n


def couette_flow_m3_s(bearing: JournalBearing, speed_hz: float) -> float:
    """The film's Couette flow q_c = Omega R c L / 2 [m^3/s], the flow unit of the dimensionless table."""
    return math.pi * speed_hz * bearing.radius_m * bearing.clearance_m * bearing.length_m


@dataclass(frozen=True)
class OperatingPoint:
    """Interpolated state of one bearing at one operating point (SI units).

    Attributes: sommerfeld S [-]; fraction_of_threshold f = q / q_t [-]; flooded_threshold_m3_s q_t;
    eccentricity_m (2,) journal centre; eccentricity_ratio; attitude_deg; supply_pressure_pa groove
    pressure (0 when starved); regime "starved" (f < 1) or "flooded"; coefficients (K, C);
    d_dq and d_dln_viscosity: the same fields' derivatives with respect to the supply flowrate
    [per m^3/s] and to ln(mu) at fixed flowrate, speed and load.
    """

    sommerfeld: float
    fraction_of_threshold: float
    flooded_threshold_m3_s: float
    eccentricity_m: np.ndarray
    eccentricity_ratio: float
    attitude_deg: float
    supply_pressure_pa: float
    regime: str
    coefficients: BearingCoefficients
    d_dq: BearingCoefficients
    d_dln_viscosity: BearingCoefficients


class OperatingTable:
    """Dimensionless equilibrium and coefficients over (ln S, f), interpolated C1.

    ``sommerfeld_nodes`` (n_s,) uniform in ln S, ``fraction_nodes`` (n_f,) uniform, ``values``
    (n_s, n_f, 11) as :data:`N_QUANTITIES`, ``threshold_flow_ratio`` (n_s,) q_t / q_c, ``geometry``
    the bearing it belongs to (:data:`GEOMETRY_KEYS`), ``metadata`` provenance and solver.
    """

    def __init__(
        self,
        sommerfeld_nodes,
        fraction_nodes,
        values,
        threshold_flow_ratio,
        geometry: dict,
        metadata: dict | None = None,
    ):
        self.sommerfeld_nodes = np.asarray(sommerfeld_nodes, dtype=float)
        self.fraction_nodes = np.asarray(fraction_nodes, dtype=float)
        self.values = np.asarray(values, dtype=float)
        self.threshold_flow_ratio = np.asarray(threshold_flow_ratio, dtype=float)
        self.geometry = {k: float(geometry[k]) for k in GEOMETRY_KEYS}
        self.metadata = metadata or {}
        n_s, n_f = self.sommerfeld_nodes.size, self.fraction_nodes.size
        if n_s < 3 or n_f < 3 or self.values.shape != (n_s, n_f, N_QUANTITIES):
            raise InputError(
                f"a dimensionless bearing table needs >= 3 x 3 nodes and values of shape (n_s, n_f, "
                f"{N_QUANTITIES}), got {n_s} x {n_f} and {self.values.shape}"
            )
        self._log_s = np.log(self.sommerfeld_nodes)
        for name, nodes in (
            ("Sommerfeld numbers (in ln S)", self._log_s),
            ("flowrate fractions", self.fraction_nodes),
        ):
            steps = np.diff(nodes)
            if np.any(steps <= 0) or not np.allclose(steps, steps[0], rtol=1e-6):
                raise InputError(
                    f"dimensionless bearing table: {name} must be increasing and uniformly spaced"
                )
        padded = np.zeros((n_s + 2, n_f + 2, N_QUANTITIES))
        padded[1:-1, 1:-1] = self.values
        catmull_rom.extrapolate_ghosts(padded)
        self._padded = padded
        threshold = np.zeros(n_s + 2)
        threshold[1:-1] = np.log(self.threshold_flow_ratio)
        catmull_rom.extrapolate_ghosts(threshold, axes=1)
        self._log_threshold = threshold
        self._s0, self._hs = self._log_s[0], self._log_s[1] - self._log_s[0]
        self._f0, self._hf = self.fraction_nodes[0], self.fraction_nodes[1] - self.fraction_nodes[0]

    # -- ranges and checks -------------------------------------------------------------------------------
    @property
    def sommerfeld_range(self) -> tuple[float, float]:
        """(lowest, highest) tabulated Sommerfeld number."""
        return float(self.sommerfeld_nodes[0]), float(self.sommerfeld_nodes[-1])

    @property
    def fraction_range(self) -> tuple[float, float]:
        """(lowest, highest) tabulated flowrate as a fraction of the flooded threshold."""
        return float(self.fraction_nodes[0]), float(self.fraction_nodes[-1])

    def check_geometry(self, bearing: JournalBearing) -> None:
        """Raise :class:`InputError` unless ``bearing`` has the table's geometry (viscosity may differ)."""
        for key in GEOMETRY_KEYS:
            have, want = float(getattr(bearing, key)), self.geometry[key]
            if not math.isclose(have, want, rel_tol=1e-9, abs_tol=1e-15):
                raise InputError(
                    f"the dimensionless bearing table was computed for {key} = {want:g}, "
                    f"the bearing has {have:g}"
                )

    def _sommerfeld_coordinate(self, sommerfeld: float, where: str) -> float:
        low, high = self.sommerfeld_range
        if not low * (1 - 1e-12) <= sommerfeld <= high * (1 + 1e-12):
            raise InputError(
                f"{where} has Sommerfeld number {sommerfeld:.4g}, outside the table's "
                f"[{low:.4g}, {high:.4g}] "
                "(no extrapolation: recompute the table over a wider range with `oilwatch bearing-map`)"
            )
        return math.log(sommerfeld)

    # -- interpolation ------------------------------------------------------------------------------------
    def flooded_threshold_ratio(self, sommerfeld: float) -> tuple[float, float]:
        """(q_t / q_c, d ln(q_t / q_c) / d ln S) at ``sommerfeld``."""
        s = self._sommerfeld_coordinate(sommerfeld, "the operating point")
        i, t = catmull_rom.cell(s, self._s0, self._hs, self.sommerfeld_nodes.size)
        w, dw = catmull_rom.weights(t)
        stencil = self._log_threshold[i : i + 4]
        return math.exp(float(w @ stencil)), float(dw @ stencil) / self._hs

    def interpolate(self, sommerfeld: float, fraction: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Dimensionless values (11,) at (S, f) and their derivatives with respect to ln S and f."""
        s = self._sommerfeld_coordinate(sommerfeld, "the operating point")
        f = require_finite("flowrate fraction of the flooded threshold", fraction)
        low, high = self.fraction_range
        if not low - 1e-12 <= f <= high + 1e-12:
            raise InputError(
                f"supply flowrate at {f * 100:.4g} % of the flooded threshold is outside the table's "
                f"[{low * 100:.4g}, {high * 100:.4g}] % (no extrapolation)"
            )
        out = np.empty((3, N_QUANTITIES))
        _interpolate_point(
            self._padded,
            s,
            f,
            self._s0,
            self._hs,
            self.sommerfeld_nodes.size,
            self._f0,
            self._hf,
            self.fraction_nodes.size,
            out,
        )
        return out[0], out[1], out[2]

    def evaluate(
        self, speed_hz: float, viscosity_pa_s: float, load_n: float, q_m3_s: float
    ) -> OperatingPoint:
        """Dimensional equilibrium and coefficients at one operating point, with d/dq and d/d ln(mu)."""
        speed = require_positive("speed_hz", speed_hz, "Hz")
        mu = require_positive("viscosity_pa_s", viscosity_pa_s, "Pa s")
        load = require_positive("load_n", load_n, "N")
        q = require_positive("supply flowrate", q_m3_s, "m^3/s")
        r, c, length = self.geometry["radius_m"], self.geometry["clearance_m"], self.geometry["length_m"]
        omega = 2.0 * math.pi * speed
        sommerfeld = mu * speed * length * 2.0 * r * (r / c) ** 2 / load
        where = f"the operating point ({speed:g} Hz, {mu:.4g} Pa s, {load:.5g} N)"
        self._sommerfeld_coordinate(sommerfeld, where)
        ratio, dln_ratio = self.flooded_threshold_ratio(sommerfeld)
        q_t = ratio * math.pi * speed * r * c * length
        fraction = q / q_t
        try:
            value, d_ds, d_df = self.interpolate(sommerfeld, fraction)
        except InputError as error:
            raise InputError(
                f"{error} at {where}: q = {q * ML_MIN_PER_M3_S:.5g} ml/min, "
                f"q_t = {q_t * ML_MIN_PER_M3_S:.5g} ml/min"
            ) from None
        scale = np.concatenate(
            [np.full(2, c), np.full(4, load / c), np.full(4, load / (c * omega)), [mu * omega * (r / c) ** 2]]
        )
        d_dq = d_df * scale / q_t
        d_dlnmu = (d_ds - d_df * fraction * dln_ratio) * scale
        d_dlnmu[10] += value[10] * scale[10]
        dimensional = value * scale
        e = dimensional[0:2]
        return OperatingPoint(
            sommerfeld=sommerfeld,
            fraction_of_threshold=fraction,
            flooded_threshold_m3_s=q_t,
            eccentricity_m=e,
            eccentricity_ratio=float(math.hypot(*value[0:2])),
            attitude_deg=_attitude_deg(e),
            supply_pressure_pa=max(float(dimensional[10]), 0.0),
            regime="starved" if fraction < 1.0 else "flooded",
            coefficients=_coefficients(dimensional),
            d_dq=_coefficients(d_dq),
            d_dln_viscosity=_coefficients(d_dlnmu),
        )

    def flowrate_range_m3_s(
        self, speed_hz: float, viscosity_pa_s: float, load_n: float
    ) -> tuple[float, float]:
        """(lowest, highest) supply flowrate [m^3/s] the table covers at this speed, viscosity and load."""
        return self.at(speed_hz, viscosity_pa_s, load_n).flowrate_range_m3_s

    def evaluate_many(self, speed_hz: float, viscosity_pa_s: float, load_n: float, q_m3_s) -> np.ndarray:
        """Rows (m, 10) ``[e_x, e_y, K (row-major), C (row-major)]`` (SI) at the flowrates (m,) [m^3/s], at
        one speed, viscosity and load: the layout of ``CoefficientTable.evaluate_many``."""
        return self.at(speed_hz, viscosity_pa_s, load_n).rows(q_m3_s)

    def at(self, speed_hz: float, viscosity_pa_s: float, load_n: float) -> TableSlice:
        """The table at one speed [Hz], viscosity [Pa s] and load [N]: a function of the flowrate only."""
        return TableSlice(self, speed_hz, viscosity_pa_s, load_n)

    # -- file ---------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """The JSON document: nodes, dimensionless rows, geometry and provenance."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "geometry": self.geometry,
            **self.metadata,
            "sommerfeld_nodes": self.sommerfeld_nodes.tolist(),
            "fraction_of_threshold_nodes": self.fraction_nodes.tolist(),
            "threshold_flow_ratio": self.threshold_flow_ratio.tolist(),
            "values": self.values.tolist(),
        }

    def save(self, path: str | Path) -> None:
        """Write the table as JSON."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=1) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> OperatingTable:
        """Read a table written by :meth:`save`."""
        try:
            data = json.loads(Path(path).read_text())
        except FileNotFoundError:
            raise InputError(
                f"dimensionless bearing table not found: {path} (make it with `oilwatch bearing-map`)"
            ) from None
        except json.JSONDecodeError as error:
            raise InputError(f"dimensionless bearing table {path} is not valid JSON: {error}") from None
        if data.get("format") != FORMAT:
            raise InputError(f"{path} is not an {FORMAT} (format={data.get('format')!r})")
        keys = (
            "format",
            "format_version",
            "geometry",
            "sommerfeld_nodes",
            "fraction_of_threshold_nodes",
            "threshold_flow_ratio",
            "values",
        )
        meta = {k: v for k, v in data.items() if k not in keys}
        return cls(
            data["sommerfeld_nodes"],
            data["fraction_of_threshold_nodes"],
            data["values"],
            data["threshold_flow_ratio"],
            data["geometry"],
            meta,
        )


@numba.njit(cache=True)
def _interpolate_point(padded, s, f, s0, hs, ns, f0, hf, nf, out):  # pragma: no cover - compiled
    """Values, d/d ln S and d/d f (rows of ``out`` (3, 11)) at (ln S = s, f) on the padded grid."""
    i, ts = catmull_rom.cell(s, s0, hs, ns)
    j, tf = catmull_rom.cell(f, f0, hf, nf)
    ws, dws = catmull_rom.weights(ts)
    wf, dwf = catmull_rom.weights(tf)
    out[:, :] = 0.0
    for a in range(4):
        for b in range(4):
            node = padded[i + a, j + b]
            for k in range(node.shape[0]):
                out[0, k] += ws[a] * wf[b] * node[k]
                out[1, k] += dws[a] * wf[b] * node[k] / hs
                out[2, k] += ws[a] * dwf[b] * node[k] / hf


class TableSlice:
    """The dimensionless table at one (speed, viscosity, load): interpolated in S once, in f per call.

    Attributes: sommerfeld, flooded_threshold_m3_s q_t, flowrate_range_m3_s; :meth:`rows` as
    ``OperatingTable.evaluate_many``.
    """

    def __init__(self, table: OperatingTable, speed_hz: float, viscosity_pa_s: float, load_n: float):
        g = table.geometry
        r, c, length = g["radius_m"], g["clearance_m"], g["length_m"]
        self.sommerfeld = viscosity_pa_s * speed_hz * length * 2.0 * r * (r / c) ** 2 / load_n
        where = f"the operating point ({speed_hz:g} Hz, {viscosity_pa_s:.4g} Pa s, {load_n:.5g} N)"
        s = table._sommerfeld_coordinate(self.sommerfeld, where)
        column = np.empty((table.fraction_nodes.size + 2, N_QUANTITIES))
        threshold = _interpolate_column(
            table._padded, table._log_threshold, s, table._s0, table._hs, table.sommerfeld_nodes.size, column
        )
        self.flooded_threshold_m3_s = math.exp(threshold) * math.pi * speed_hz * r * c * length
        low, high = table.fraction_range
        self.flowrate_range_m3_s = (low * self.flooded_threshold_m3_s, high * self.flooded_threshold_m3_s)
        self._table, self._where, self._column = table, where, column
        self._scale = np.concatenate(
            [np.full(2, c), np.full(4, load_n / c), np.full(4, load_n / (c * 2.0 * math.pi * speed_hz))]
        )

    def rows(self, q_m3_s) -> np.ndarray:
        """Rows (m, 10) ``[e_x, e_y, K, C]`` (SI) at the flowrates (m,) [m^3/s]."""
        q = np.atleast_1d(np.asarray(q_m3_s, dtype=float))
        fraction = q / self.flooded_threshold_m3_s
        table = self._table
        low, high = table.fraction_range
        if not (fraction.min() >= low - 1e-12 and fraction.max() <= high + 1e-12):
            bad = fraction.min() if fraction.min() < low - 1e-12 else fraction.max()
            raise InputError(
                f"supply flowrate {bad * self.flooded_threshold_m3_s * ML_MIN_PER_M3_S:.5g} ml/min "
                f"({bad * 100:.4g} % of the flooded threshold) is outside the table's [{low * 100:.4g}, "
                f"{high * 100:.4g}] % at {self._where} (no extrapolation)"
            )
        value = np.empty((q.size, 10))
        _interpolate_rows(self._column, fraction, table._f0, table._hf, table.fraction_nodes.size, value)
        value *= self._scale
        return value


@numba.njit(cache=True)
def _interpolate_column(padded, log_threshold, s, s0, hs, ns, column):  # pragma: no cover - compiled
    """Interpolate the padded grid in ln S at s into ``column`` (n_f + 2, 11); return ln(q_t / q_c) there."""
    i, ts = catmull_rom.cell(s, s0, hs, ns)
    ws, _ = catmull_rom.weights(ts)
    column[:, :] = 0.0
    threshold = 0.0
    for a in range(4):
        threshold += ws[a] * log_threshold[i + a]
        for j in range(column.shape[0]):
            for k in range(column.shape[1]):
                column[j, k] += ws[a] * padded[i + a, j, k]
    return threshold


@numba.njit(cache=True)
def _interpolate_rows(column, fractions, f0, hf, nf, out):  # pragma: no cover - compiled
    """The first 10 values of a column (n_f + 2, 11) at each f of ``fractions`` into ``out`` (m, 10)."""
    for m in range(fractions.shape[0]):
        j, tf = catmull_rom.cell(fractions[m], f0, hf, nf)
        wf, _ = catmull_rom.weights(tf)
        for k in range(out.shape[1]):
            acc = 0.0
            for b in range(4):
                acc += wf[b] * column[j + b, k]
            out[m, k] = acc


def _coefficients(v: np.ndarray) -> BearingCoefficients:
    return BearingCoefficients(v[0:2].copy(), v[2:6].reshape(2, 2).copy(), v[6:10].reshape(2, 2).copy())


def _attitude_deg(e: np.ndarray) -> float:
    angle = math.degrees(math.atan2(e[1], e[0])) + 90.0
    return (angle + 180.0) % 360.0 - 180.0


def dimensionless_row(bearing: JournalBearing, row: dict, speed_hz: float, load_n: float) -> np.ndarray:
    """The 11 dimensionless quantities of one row of a :class:`~models.bearing.table.CoefficientTable`."""
    c = bearing.clearance_m
    omega = 2.0 * math.pi * speed_hz
    k = [row["stiffness_n_per_m"][p] * c / load_n for p in _PAIRS]
    d = [row["damping_n_s_per_m"][p] * c * omega / load_n for p in _PAIRS]
    p_ref = bearing.viscosity_pa_s * omega * (bearing.radius_m / c) ** 2
    return np.array(
        [row["eccentricity_x_m"] / c, row["eccentricity_y_m"] / c, *k, *d, row["supply_pressure_pa"] / p_ref]
    )


def sommerfeld_grid(centre: float, low: float, high: float, ratio: float) -> np.ndarray:
    """Nodes centre * ratio^k (uniform in ln S), from the last <= ``low`` to the first >= ``high``."""
    if not 0 < low <= high:
        raise InputError(f"Sommerfeld range must satisfy 0 < low <= high, got [{low:g}, {high:g}]")
    if ratio <= 1.0:
        raise InputError(f"Sommerfeld node ratio must be > 1, got {ratio:g}")
    k_low = math.floor(math.log(low / centre) / math.log(ratio) + 1e-9)
    k_high = math.ceil(math.log(high / centre) / math.log(ratio) - 1e-9)
    return centre * ratio ** np.arange(k_low, k_high + 1, dtype=float)


def compute_operating_table(
    bearing: JournalBearing,
    load_n: float,
    speed_hz: float,
    sommerfeld_nodes,
    fraction_nodes,
    mesh: Mesh | None = None,
    progress: Callable[[int], None] | None = None,
    provenance: dict | None = None,
    coefficients: str = QUASI_STATIC,
    checkpoint: str | Path | None = None,
) -> OperatingTable:
    """Solve the dimensionless table at ``speed_hz`` and ``load_n``, setting each S by the viscosity.

    At each Sommerfeld node the viscosity is mu = S W / (N L D (R/c)^2); the flooded threshold and
    then :func:`~models.bearing.table.compute_table` at the flowrates f q_t give the node's row.
    ``coefficients`` is the kind of K, C (:data:`~models.bearing.table.COEFFICIENT_KINDS`): at whirl
    frequency = spin speed the whirl ratio is 1, so the synchronous K c / W and C c Omega / W are functions
    of (S, f) too. ``progress(n)`` is called after each solved point (n = 1) and each threshold (n = 0).
    ``checkpoint``: a JSON file that holds every finished Sommerfeld node; a stopped run started again
    with the same file, nodes, mesh and kind resumes after the last finished node.
    """
    mesh = PRODUCTION_MESH if mesh is None else mesh
    load = require_positive("load_n", load_n, "N")
    speed = require_positive("speed_hz", speed_hz, "Hz")
    s_nodes = np.asarray(sommerfeld_nodes, dtype=float)
    f_nodes = np.asarray(fraction_nodes, dtype=float)
    q_c = couette_flow_m3_s(bearing, speed)
    unit_viscosity = sommerfeld_number(bearing, 1.0, speed, load)
    values = np.empty((s_nodes.size, f_nodes.size, N_QUANTITIES))
    threshold = np.empty(s_nodes.size)
    started = time.perf_counter()
    resume = _Checkpoint(checkpoint, s_nodes, f_nodes, mesh, coefficients, speed, load)
    for i, s in enumerate(s_nodes):
        if resume.has(i):
            threshold[i], values[i] = resume.node(i)
            if progress is not None:
                progress(0)
                progress(f_nodes.size)
            continue
        at_s = dataclasses.replace(bearing, viscosity_pa_s=float(s / unit_viscosity))
        q_t, _ = flooded_threshold(at_s, load, speed, mesh)
        threshold[i] = q_t / q_c
        if progress is not None:
            progress(0)
        flows = q_t * f_nodes
        flows[np.isclose(f_nodes, 1.0, rtol=0, atol=1e-12)] = q_t  # exactly on the threshold
        table = compute_table(
            at_s, load, speed, flows, mesh, flooded_threshold_m3_s=q_t, coefficients=coefficients
        )
        for j, row in enumerate(table.rows):
            values[i, j] = dimensionless_row(at_s, row, speed, load)
            if progress is not None:
                progress(1)
        resume.store(i, threshold[i], values[i], table.metadata)
    meta = {k: v for k, v in resume.metadata.items() if k in ("mesh", "solver")}
    meta["solver"] = {
        **meta["solver"],
        "per_node": "models.bearing.table.compute_table at mu = S W / (N L D (R/c)^2)",
    }
    meta.update(
        {
            "quantities": "values[i][j] at (S_i, f_j): e_x/c, e_y/c, K c/W (xx, xy, yx, yy), "
            "C c Omega/W (xx, xy, yx, yy), groove pressure c^2/(mu Omega R^2)",
            "solved_at": {"speed_hz": speed, "load_n": load},
            "interpolation": "tensor-product Catmull-Rom in (ln S, f), ghost nodes linearly extrapolated; "
            "q_t/q_c in ln-ln over S",
            "provenance": {
                **resume.metadata["provenance"],
                "compute_s": round(time.perf_counter() - started, 1),
                **(provenance or {}),
            },
        }
    )
    return OperatingTable(s_nodes, f_nodes, values, threshold, dataclasses.asdict(bearing), meta)


class _Checkpoint:
    """The finished Sommerfeld nodes of :func:`compute_operating_table`, kept in a JSON file (or nowhere)."""

    def __init__(self, path, s_nodes, f_nodes, mesh: Mesh, coefficients: str, speed_hz: float, load_n: float):
        self.path = None if path is None else Path(path)
        self.key = {
            "sommerfeld_nodes": s_nodes.tolist(),
            "fraction_of_threshold_nodes": f_nodes.tolist(),
            "mesh": [mesh.n_circ, mesh.n_axial],
            "coefficients": coefficients,
            "speed_hz": speed_hz,
            "load_n": load_n,
        }
        self.nodes: dict[str, dict] = {}
        self.metadata: dict = {}
        if self.path is not None and self.path.is_file():
            try:
                data = json.loads(self.path.read_text())
            except json.JSONDecodeError as error:
                raise InputError(f"checkpoint {self.path} is not valid JSON: {error}") from None
            if data.get("key") != self.key:
                raise InputError(
                    f"checkpoint {self.path} belongs to another table (nodes, mesh, kind, speed or load "
                    "differ): remove it or choose another --out"
                )
            self.nodes, self.metadata = data["nodes"], data["metadata"]

    def has(self, i: int) -> bool:
        return str(i) in self.nodes

    def node(self, i: int) -> tuple[float, np.ndarray]:
        entry = self.nodes[str(i)]
        return entry["threshold_flow_ratio"], np.asarray(entry["values"])

    def store(self, i: int, threshold: float, values: np.ndarray, metadata: dict) -> None:
        self.nodes[str(i)] = {"threshold_flow_ratio": float(threshold), "values": values.tolist()}
        self.metadata = metadata
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            text = json.dumps({"key": self.key, "nodes": self.nodes, "metadata": metadata})
            temporary = self.path.with_name(self.path.name + ".tmp")
            temporary.write_text(text)
            temporary.replace(self.path)


def operating_table_name(machine_file: str | Path, coefficients: str = QUASI_STATIC) -> str:
    """``<stem>_bearing_dimensionless[_synchronous].json``: the file name follows the coefficient kind."""
    return f"{Path(machine_file).stem}_bearing_dimensionless{file_suffix(coefficients)}.json"


def operating_table_path(machine_file: str | Path, coefficients: str = QUASI_STATIC) -> Path:
    """Where a machine's dimensionless table of that coefficient kind lives: ``tables/`` beside the file."""
    return Path(machine_file).parent / "tables" / operating_table_name(machine_file, coefficients)
