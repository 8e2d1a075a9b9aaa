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
speeds). :func:`oilwatch.models.bearing.operating_table_solve.compute_operating_table` solves the equilibrium
and the eight coefficients with the project's conventions
(:func:`oilwatch.models.bearing.table.compute_table`: held-partition stiffness, default full-film squeeze,
mean of the one-sided limits on f = 1) on a grid uniform in ln S and in f.
:class:`OperatingTable` interpolates it by tensor-product Catmull-Rom (:mod:`oilwatch.models.catmull_rom`: C1,
exact at the nodes, linear in the data), and gives dimensional values and their derivatives with respect
to the flowrate and the viscosity at any (speed, viscosity, load, flowrate) inside the grid; outside,
:class:`~models.validation.InputError` (no extrapolation).

The scaling is :mod:`oilwatch.models.bearing.sommerfeld`, the solve
:mod:`oilwatch.models.bearing.operating_table_solve`, and the compiled interpolation with the table's slice
at one operating point :mod:`oilwatch.models.bearing.operating_table_interpolation`.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import catmull_rom
from ..validation import InputError, require_finite, require_positive
from .coefficient_kinds import QUASI_STATIC, file_suffix
from .equilibrium import attitude_angle_deg
from .geometry import DOWNWARD_LOAD_RAD, JournalBearing
from .operating_table_interpolation import TableSlice, interpolate_column, interpolate_point
from .sommerfeld import N_QUANTITIES, ON_THRESHOLD
from .supply import ML_MIN_PER_M3_S
from .table import BearingCoefficients

FORMAT = "oilwatch dimensionless bearing table"
FORMAT_VERSION = 2
"""2: the one-sided limits on f = 1 (``threshold_sides``); version 1 files lack them: they interpolate only
across the threshold (``one_sided=False``) and are upgraded by ``oilwatch bearing-map --reuse``."""
GEOMETRY_KEYS = (
    "radius_m",
    "length_m",
    "clearance_m",
    "groove_angle_rad",
    "groove_circumferential_m",
    "groove_axial_m",
)


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

    ``sommerfeld_nodes`` (n_s,) uniform in ln S, ``fraction_nodes`` (n_f,) uniform (``fraction_step``
    apart), ``values``
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
        threshold_sides=None,
    ):
        self.sommerfeld_nodes = np.asarray(sommerfeld_nodes, dtype=float)
        self.fraction_nodes = np.asarray(fraction_nodes, dtype=float)
        self.values = np.asarray(values, dtype=float)
        self.threshold_flow_ratio = np.asarray(threshold_flow_ratio, dtype=float)
        self.geometry = {k: float(geometry[k]) for k in GEOMETRY_KEYS} | groove_layout(geometry)
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
        on_threshold = np.flatnonzero(np.isclose(self.fraction_nodes, 1.0, rtol=0, atol=1e-12))
        if on_threshold.size != 1 or not 0 < on_threshold[0] < n_f - 1:
            raise InputError(
                "a dimensionless bearing table needs a flowrate node on the flooded threshold (f = 1)"
            )
        self._on_threshold = int(on_threshold[0])
        padded = np.zeros((n_s + 2, n_f + 2, N_QUANTITIES))
        padded[1:-1, 1:-1] = self.values
        catmull_rom.extrapolate_ghosts(padded)
        self._across = ((padded, float(self.fraction_nodes[0]), n_f),)
        self.threshold_sides = None
        self._sides: tuple[tuple[np.ndarray, float, int], ...] = ()
        if threshold_sides is not None:
            self.threshold_sides = np.asarray(threshold_sides, dtype=float)
            if self.threshold_sides.shape != (n_s, 2, N_QUANTITIES):
                raise InputError(
                    f"threshold_sides must have shape ({n_s}, 2, {N_QUANTITIES}), "
                    f"got {self.threshold_sides.shape}"
                )
            self._sides = self._one_sided_grids()
        threshold = np.zeros(n_s + 2)
        threshold[1:-1] = np.log(self.threshold_flow_ratio)
        catmull_rom.extrapolate_ghosts(threshold, axes=1)
        self._log_threshold = threshold
        self._s0, self._hs = self._log_s[0], self._log_s[1] - self._log_s[0]
        self.fraction_step = float(self.fraction_nodes[1] - self.fraction_nodes[0])

    def _one_sided_grids(self) -> tuple[tuple[np.ndarray, float, int], ...]:
        """(padded values, first f, node count) of the starved nodes f <= 1 and of the flooded nodes f >= 1,
        each ending on its own one-sided limit on f = 1: the cubic never spans the jump of K, C there."""
        k = self._on_threshold
        grids = []
        for side, nodes in ((0, slice(0, k + 1)), (1, slice(k, None))):
            values = self.values[:, nodes].copy()
            values[:, -1 if side == 0 else 0] = self.threshold_sides[:, side]
            padded = np.zeros((values.shape[0] + 2, values.shape[1] + 2, N_QUANTITIES))
            padded[1:-1, 1:-1] = values
            catmull_rom.extrapolate_ghosts(padded)
            grids.append((padded, float(self.fraction_nodes[nodes][0]), values.shape[1]))
        return tuple(grids)

    def grids(self, one_sided: bool, where: str = "") -> tuple[tuple[np.ndarray, float, int], ...]:
        """(padded values, first f, node count) of the f grids: ``one_sided`` the starved and the flooded ones
        (see :meth:`_one_sided_grids`; InputError for a version-1 table), else one grid across the threshold
        (the mean of the one-sided limits on f = 1, the jump smoothed over the neighbouring cells)."""
        if not one_sided:
            return self._across
        if not self._sides:
            raise InputError(
                f"the dimensionless bearing table{where} has no one-sided limits on the flooded threshold "
                "(made by an older oilwatch): recompute it with `oilwatch bearing-map --reuse <that file>`"
            )
        return self._sides

    # -- ranges and checks -------------------------------------------------------------------------------
    @property
    def sommerfeld_range(self) -> tuple[float, float]:
        """(lowest, highest) tabulated Sommerfeld number."""
        return float(self.sommerfeld_nodes[0]), float(self.sommerfeld_nodes[-1])

    @property
    def fraction_range(self) -> tuple[float, float]:
        """(lowest, highest) tabulated flowrate as a fraction of the flooded threshold."""
        return float(self.fraction_nodes[0]), float(self.fraction_nodes[-1])

    def with_clearance(self, clearance_m: float) -> OperatingTable:
        """The same table for the bearing of radial clearance ``clearance_m``: with R, L and the grooves
        unchanged the dimensionless film depends on c only through S and the flow unit q_c (exact: the
        Sommerfeld scaling of :mod:`oilwatch.models.bearing.sommerfeld`), so only the geometry's c changes;
        the node values are shared."""
        require_positive("bearing clearance", clearance_m, "m")
        other = copy.copy(self)
        other.geometry = {**self.geometry, "clearance_m": float(clearance_m)}
        return other

    def check_geometry(self, bearing: JournalBearing) -> None:
        """Raise :class:`InputError` unless ``bearing`` has the table's geometry (viscosity may differ)."""
        mismatch = geometry_mismatch(self.geometry, bearing)
        if mismatch is not None:
            raise InputError(f"the dimensionless bearing table was computed for {mismatch}")

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

    def interpolate(
        self, sommerfeld: float, fraction: float, one_sided: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Dimensionless values (11,) at (S, f) and their derivatives with respect to ln S and f.

        ``one_sided``: the starved and the flooded nodes are interpolated separately, each up to its own
        limit on f = 1, so the jump of K and C there is kept (within :data:`ON_THRESHOLD` of it, the mean of
        the limits, as a direct solve on the threshold); else one C1 interpolant across it."""
        s = self._sommerfeld_coordinate(sommerfeld, "the operating point")
        f = require_finite("flowrate fraction of the flooded threshold", fraction)
        low, high = self.fraction_range
        if not low - 1e-12 <= f <= high + 1e-12:
            raise InputError(
                f"supply flowrate at {f * 100:.4g} % of the flooded threshold is outside the table's "
                f"[{low * 100:.4g}, {high * 100:.4g}] % (no extrapolation)"
            )
        out = np.empty((3, N_QUANTITIES))
        results = []
        grids = self.grids(one_sided)
        for side, (padded, f0, n) in enumerate(grids):
            if (
                len(grids) == 1
                or (side == 0 and f <= 1.0 + ON_THRESHOLD)
                or (side == 1 and f >= 1.0 - ON_THRESHOLD)
            ):
                interpolate_point(
                    padded,
                    s,
                    f,
                    self._s0,
                    self._hs,
                    self.sommerfeld_nodes.size,
                    f0,
                    self.fraction_step,
                    n,
                    out,
                )
                results.append(out.copy())
        # on the threshold: the mean of the one-sided limits, as a direct solve gives there
        mean = sum(results) / len(results)
        return mean[0], mean[1], mean[2]

    def evaluate(
        self, speed_hz: float, viscosity_pa_s: float, load_n: float, q_m3_s: float, one_sided: bool = False
    ) -> OperatingPoint:
        """Dimensional equilibrium and coefficients at one operating point, with d/dq and d/d ln(mu)
        (``one_sided``: see :meth:`interpolate`)."""
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
            value, d_ds, d_df = self.interpolate(sommerfeld, fraction, one_sided)
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
            attitude_deg=attitude_angle_deg(e, self.geometry.get("load_angle_rad", DOWNWARD_LOAD_RAD)),
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

    def columns_at(
        self, sommerfeld: float, one_sided: bool, where: str
    ) -> tuple[float, list[tuple[np.ndarray, float, int]]]:
        """ln(q_t / q_c) at ``sommerfeld`` and, for each f grid of :meth:`grids`, the table interpolated in S
        there: (column (n + 2, 11) with its ghost nodes, first f, node count n), which
        :func:`~oilwatch.models.bearing.operating_table_interpolation.interpolate_rows` evaluates in f.
        ``where`` names the operating point in the error of a Sommerfeld number outside the table."""
        s = self._sommerfeld_coordinate(sommerfeld, where)
        threshold, columns = math.nan, []
        for padded, f0, n in self.grids(one_sided, f" at {where}"):
            column = np.empty((n + 2, N_QUANTITIES))
            threshold = interpolate_column(
                padded, self._log_threshold, s, self._s0, self._hs, self.sommerfeld_nodes.size, column
            )
            columns.append((column, f0, n))
        return threshold, columns

    def at(
        self, speed_hz: float, viscosity_pa_s: float, load_n: float, one_sided: bool = False
    ) -> TableSlice:
        """The table at one speed [Hz], viscosity [Pa s] and load [N]: a function of the flowrate only."""
        return TableSlice(self, speed_hz, viscosity_pa_s, load_n, one_sided)

    # -- file ---------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """The JSON document: nodes, dimensionless rows, geometry and provenance."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION if self.threshold_sides is not None else 1,
            "geometry": self.geometry,
            **self.metadata,
            "sommerfeld_nodes": self.sommerfeld_nodes.tolist(),
            "fraction_of_threshold_nodes": self.fraction_nodes.tolist(),
            "threshold_flow_ratio": self.threshold_flow_ratio.tolist(),
            "values": self.values.tolist(),
            **({} if self.threshold_sides is None else {"threshold_sides": self.threshold_sides.tolist()}),
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
            "threshold_sides",
        )
        meta = {k: v for k, v in data.items() if k not in keys}
        return cls(
            data["sommerfeld_nodes"],
            data["fraction_of_threshold_nodes"],
            data["values"],
            data["threshold_flow_ratio"],
            data["geometry"],
            meta,
            data.get("threshold_sides"),
        )


def geometry_mismatch(stored: Mapping[str, Any], bearing: JournalBearing) -> str | None:
    """How the geometry ``stored`` with a table (a :class:`JournalBearing` as a dict) differs from
    ``bearing``'s, as "<what the table has>, the bearing has <what>" (None: the same geometry; the viscosity
    is not geometry)."""
    for key in GEOMETRY_KEYS:
        have, want = float(getattr(bearing, key)), float(stored[key])
        if not math.isclose(have, want, rel_tol=1e-9, abs_tol=1e-15):
            return f"{key} = {want:g}, the bearing has {have:g}"
    want_load, have_load = load_angle_deg(stored), math.degrees(bearing.load_angle_rad)
    if not math.isclose(want_load, have_load, rel_tol=1e-9, abs_tol=1e-9):
        return f"a load along {want_load:g} deg, the bearing's points along {have_load:g} deg"
    want = groove_layout(stored)
    have = groove_layout(dataclasses.asdict(bearing))
    same = want.keys() == have.keys() and all(
        np.allclose(want[k], have[k], rtol=1e-9, atol=1e-15) for k in want
    )
    if not same:
        return f"the grooves {want or 'of a one-groove bearing'}, the bearing has {have or 'one groove'}"
    return None


def load_angle_deg(geometry: Mapping[str, Any]) -> float:
    """The bearing angle [deg] the static load points along in a bearing's geometry (a
    :class:`JournalBearing` as a dict): 180 (-y, the weight) where the geometry holds none (the bundled
    tables, all loaded downward, do not write it)."""
    return math.degrees(float(geometry.get("load_angle_rad", DOWNWARD_LOAD_RAD)))


def groove_layout(geometry: dict) -> dict:
    """The grooves beyond the first and the load's direction of a bearing's geometry (a
    :class:`JournalBearing` as a dict), as stored in a table's geometry: empty for the one-groove bearing
    loaded along -y, so that its tables keep their form."""
    more = [
        [float(g[k]) for k in ("angle_rad", "circumferential_m", "axial_m")]
        if isinstance(g, dict)
        else [float(v) for v in g]
        for g in geometry.get("more_grooves", ())
    ]
    band = float(geometry.get("circumferential_groove_m", 0.0))
    layout = {}
    if more:
        layout["more_grooves"] = more
    if band > 0.0:
        layout["circumferential_groove_m"] = band
    load_angle = float(geometry.get("load_angle_rad", DOWNWARD_LOAD_RAD))
    if load_angle != DOWNWARD_LOAD_RAD:
        layout["load_angle_rad"] = load_angle
    return layout


def _coefficients(v: np.ndarray) -> BearingCoefficients:
    return BearingCoefficients(v[0:2].copy(), v[2:6].reshape(2, 2).copy(), v[6:10].reshape(2, 2).copy())


def operating_table_name(
    machine_file: str | Path, coefficients: str = QUASI_STATIC, bearing: int | None = None
) -> str:
    """``<stem>_bearing_dimensionless[_synchronous].json``: the file name follows the coefficient kind; a
    machine whose bearings differ has one table per geometry, ``<stem>_bearing<N>_dimensionless...``, named
    after ``bearing`` N, the first bearing (from 1) of that geometry
    (:func:`oilwatch.models.system.factory.geometry_number`)."""
    number = "" if bearing is None else str(bearing)
    return f"{Path(machine_file).stem}_bearing{number}_dimensionless{file_suffix(coefficients)}.json"


def operating_table_path(
    machine_file: str | Path, coefficients: str = QUASI_STATIC, bearing: int | None = None
) -> Path:
    """Where a machine's dimensionless table of that coefficient kind (and of bearing N's geometry,
    :func:`operating_table_name`) lives: ``tables/`` beside the file."""
    return Path(machine_file).parent / "tables" / operating_table_name(machine_file, coefficients, bearing)
