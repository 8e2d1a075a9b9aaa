"""The flooded journal centreline from slow roll to speed, and the radial clearance it measures.

A coast-down (or run-up) record holds, at every speed, the journal's mean position in its bearing: the
shaft-centreline plot of condition monitoring. At slow roll the journal sits low in the clearance; as the
speed rises the film lifts it along a locus that, for a flooded bearing, depends only on the Sommerfeld number
S = mu N L D (R/c)^2 / W. For a pressure-fed bearing the groove pressure enters through p_s c^2 / (mu Omega
R^2), and that times S is p_s L D / (2 pi W), a constant of the bearing and its load: the locus e/c(S) of a
given bearing, load and supply pressure holds for any clearance and viscosity (:class:`FloodedLocus`).

So the clearance is measurable without knowing the probes' zero offsets. At a clearance g c and a film
viscosity v mu (mu from the oil law at the record's oil temperature) the position at speed N is

    y(N) = o + g c E(S_0(N) v / g^2),

with E the locus (e_x/c, e_y/c) and S_0 the machine file's Sommerfeld number: v only moves the points along
the locus, g also scales its size, so the two separate wherever the record spans enough of the locus. The
offsets o enter linearly and are eliminated at each (g, v) (variable projection: Golub & Pereyra, Inverse
Problems 19, R1, 2003), and :func:`fit_clearance` returns g and v with the covariance of the projected
Gauss-Newton problem, scaled by the fit's own residual when that exceeds the probes' averaged noise (a locus
that does not fit, such as a bearing of another length, widens the std instead of hiding).

References: Childs, *Turbomachinery Rotordynamics* (Wiley 1993), ch. 3 (the flooded locus and its Sommerfeld
scaling); Bently and Hatch, *Fundamentals of Rotating Machinery Diagnostics* (2002), ch. 9 (the
shaft-centreline plot, and its use to check the bearing clearance).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..cache import user_cache_dir
from ..validation import InputError, require_in_range, require_positive
from .equilibrium import static_equilibrium
from .geometry import JournalBearing
from .grid import PRODUCTION_MESH, Mesh
from .operating_table import GEOMETRY_KEYS, groove_layout
from .sommerfeld import sommerfeld_number
from .supply import SupplyPressure

LOCUS_SOMMERFELD_RANGE = (0.01, 10.0)
"""Sommerfeld numbers the locus spans: a slow roll at a few % of a turbine's speed (eccentricity about 0.9)
to beyond a clearance 25 % tighter at a film twice as viscous at the running speed. It ends higher where the
film no longer carries the load short of contact (eccentricity 0.98: a short bearing at a low S)."""
MIN_NODES = 8
"""Nodes a locus needs (from its highest S down): a bearing whose film fails sooner is refused."""
LOCUS_SOMMERFELD_RATIO = 1.25
"""Ratio of neighbouring locus nodes (uniform in ln S); the cubic between them is within 1e-4 c of a
direct solve (tests/test_centreline.py)."""
CLEARANCE_FACTOR_RANGE = (0.7, 1.4)
"""Clearance factors g the fit searches: a worn or a mis-machined bearing, far beyond a tolerance."""
VISCOSITY_FACTOR_RANGE = (0.4, 2.5)
"""Film viscosity factors v the fit searches (the oil law's viscosity times v)."""
MAX_FILM_VISCOSITY_FACTOR = 1.5
"""The film viscosity factor above which a centreline is not the machine file's bearing under its load.

The film runs hotter than the oil supplied, so its viscosity is at most the oil law's at the supply
temperature (v <= 1), within the oil grade's tolerance (ISO 3448: +-10 %) and what a bearing of another
length reads as (v = 1.15 at +5 %). A fit that needs a film half as viscous again as the supply oil is
making up for a locus that is not this bearing's: a static load the file does not give turns the locus (a
horizontal force of 30 % of the weight share: v = 2.25 and a clearance 10 % wide on the turbine, v = 1.74
and 7 % tight on the compressor), which no clearance and film reproduce. Probe scale factors 5 % off read
v = 1.07, every model-structure case of the robustness runs 0.86-1.22."""
MIN_SPEED_SPAN = 3.0
"""Highest over lowest speed a centreline must span: below it the locus's arc is too short to tell its
size from the viscosity's shift along it."""


class FloodedLocus:
    """The flooded journal position e/c (x, y) of one bearing at one load and supply pressure against S.

    ``sommerfeld_nodes`` (n,) increasing, ``positions`` (n, 2) e/c in the model's axes (x horizontal, y up;
    the load along -y), ``metadata`` how they were solved. :meth:`position` interpolates a cubic spline in
    ln S; outside the nodes it raises InputError.
    """

    def __init__(self, sommerfeld_nodes, positions, metadata: dict) -> None:
        self.sommerfeld_nodes = np.asarray(sommerfeld_nodes, dtype=float)
        self.positions = np.asarray(positions, dtype=float)
        if self.positions.shape != (self.sommerfeld_nodes.size, 2) or self.sommerfeld_nodes.size < 4:
            raise InputError("a flooded locus needs at least 4 Sommerfeld nodes with one (x, y) each")
        if np.any(np.diff(self.sommerfeld_nodes) <= 0.0):
            raise InputError("a flooded locus needs increasing Sommerfeld nodes")
        self.metadata = metadata
        # scipy.interpolate imported here, not at the top: the estimator FMU imports this module for its
        # clearance range and would start 0.2 s later
        from scipy.interpolate import CubicSpline

        self._spline = CubicSpline(np.log(self.sommerfeld_nodes), self.positions, axis=0)

    @property
    def sommerfeld_range(self) -> tuple[float, float]:
        """(lowest, highest) Sommerfeld number the locus covers."""
        return float(self.sommerfeld_nodes[0]), float(self.sommerfeld_nodes[-1])

    def position(self, sommerfeld, clamped: bool = False) -> np.ndarray:
        """e/c (m, 2) at the Sommerfeld numbers (m,); ``clamped``: beyond the nodes, the end node's (for a
        search that may step outside; its result is checked strictly)."""
        s = np.atleast_1d(np.asarray(sommerfeld, dtype=float))
        low, high = self.sommerfeld_range
        if clamped:
            s = np.clip(s, low, high)
        if not (np.all(np.isfinite(s)) and s.min() >= low * (1 - 1e-12) and s.max() <= high * (1 + 1e-12)):
            bad = s[~((s >= low * (1 - 1e-12)) & (s <= high * (1 + 1e-12)))]
            raise InputError(
                f"Sommerfeld number {bad[0]:.4g} is outside the flooded locus's [{low:.4g}, {high:.4g}]"
            )
        return self._spline(np.log(s))

    @classmethod
    def compute(
        cls,
        bearing: JournalBearing,
        load_n: float,
        supply_pressure_pa: float,
        mesh: Mesh | None = None,
        progress: Callable[[int, int], None] | None = None,
    ) -> FloodedLocus:
        """Solve the locus on :data:`LOCUS_SOMMERFELD_RANGE`: one static equilibrium per node, at the speed
        that gives its S with the bearing's own clearance and viscosity (module docstring: that holds for any
        other), the groove held at ``supply_pressure_pa``; each node starts from its neighbour's position."""
        require_positive("bearing load", load_n, "N")
        if not (math.isfinite(supply_pressure_pa) and supply_pressure_pa >= 0.0):
            raise InputError(f"a flooded locus's supply pressure must be >= 0 Pa, got {supply_pressure_pa!r}")
        mesh = PRODUCTION_MESH if mesh is None else mesh
        low, high = LOCUS_SOMMERFELD_RANGE
        count = math.ceil(math.log(high / low) / math.log(LOCUS_SOMMERFELD_RATIO)) + 1
        nodes = np.geomspace(low, high, count)
        per_hz = sommerfeld_number(bearing, bearing.viscosity_pa_s, 1.0, load_n)
        positions = np.empty((count, 2))
        guess = None
        first = 0
        for i in range(count - 1, -1, -1):  # light load first: Newton starts best near the centre
            try:
                equilibrium = static_equilibrium(
                    bearing,
                    load_n,
                    nodes[i] / per_hz,
                    SupplyPressure(supply_pressure_pa),
                    mesh,
                    initial_guess_m=guess,
                )
            except InputError:  # the film no longer carries the load short of contact: the locus ends
                first = i + 1
                break
            guess = equilibrium.eccentricity_m
            positions[i] = guess / bearing.clearance_m
            if progress is not None:
                progress(count - i, count)
        if count - first < MIN_NODES:
            raise InputError(
                f"the flooded locus of this bearing ends above S = {nodes[first]:.3g}: fewer than "
                f"{MIN_NODES} nodes carry the load"
            )
        nodes, positions = nodes[first:], positions[first:]
        metadata = {
            "bearing": dataclasses.asdict(bearing),
            "load_n": load_n,
            "supply_pressure_pa": supply_pressure_pa,
            "mesh": {"n_circ": mesh.n_circ, "n_axial": mesh.n_axial},
        }
        return cls(nodes, positions, metadata)

    def to_dict(self) -> dict:
        """The JSON document."""
        return {
            "format": "oilwatch flooded locus",
            "format_version": 1,
            **self.metadata,
            "sommerfeld_nodes": self.sommerfeld_nodes.tolist(),
            "positions": self.positions.tolist(),
        }

    @classmethod
    def from_dict(cls, document: dict) -> FloodedLocus:
        """Read :meth:`to_dict`'s document."""
        meta = {k: v for k, v in document.items() if k not in ("sommerfeld_nodes", "positions")}
        return cls(document["sommerfeld_nodes"], document["positions"], meta)

    def matches(self, bearing: JournalBearing, load_n: float, supply_pressure_pa: float) -> bool:
        """Whether the locus was solved for this bearing geometry (any viscosity), load and pressure."""
        solved, wanted = (
            {k: float(g[k]) for k in GEOMETRY_KEYS} | groove_layout(g)
            for g in (self.metadata.get("bearing", {}), dataclasses.asdict(bearing))
        )
        same_geometry = solved.keys() == wanted.keys() and all(
            np.allclose(solved[k], wanted[k], rtol=1e-9, atol=1e-15) for k in wanted
        )
        return (
            same_geometry
            and math.isclose(self.metadata.get("load_n", -1.0), load_n, rel_tol=1e-6)
            and math.isclose(self.metadata.get("supply_pressure_pa", -1.0), supply_pressure_pa, rel_tol=1e-9)
        )


LOCI_FORMAT = "oilwatch flooded loci"


def save_loci(path: str | Path, loci: list[FloodedLocus], provenance: dict) -> None:
    """Write loci (one per distinct bearing load) as one JSON file, whole or not at all."""
    document = {"format": LOCI_FORMAT, "format_version": 1, "provenance": provenance}
    document["loci"] = [locus.to_dict() for locus in loci]
    _write_whole(Path(path), json.dumps(document, indent=1) + "\n")


def _write_whole(path: Path, text: str) -> None:
    """Write ``text`` beside ``path`` and rename it there: a reader finds the whole file or none."""
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_text(text)
    temporary.replace(path)


def load_loci(path: str | Path) -> list[FloodedLocus]:
    """The loci of a file written by :func:`save_loci` (one-line InputError on a bad file)."""
    try:
        document = json.loads(Path(path).read_text())
        if document.get("format") != LOCI_FORMAT:
            raise InputError(f"{path} is not an {LOCI_FORMAT} file")
        return [FloodedLocus.from_dict(item) for item in document["loci"]]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise InputError(f"flooded locus file {path}: {error}") from None


def flooded_locus(
    bearing: JournalBearing,
    load_n: float,
    supply_pressure_pa: float,
    mesh: Mesh | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> FloodedLocus:
    """:meth:`FloodedLocus.compute`, kept in ``<cache>/tables/locus/`` (about a minute on the production
    mesh, once per bearing, load and supply pressure)."""
    mesh = PRODUCTION_MESH if mesh is None else mesh
    key = json.dumps(
        [
            dataclasses.asdict(bearing),
            round(load_n, 6),
            round(supply_pressure_pa, 3),
            [mesh.n_circ, mesh.n_axial],
            LOCUS_SOMMERFELD_RANGE,
            LOCUS_SOMMERFELD_RATIO,
        ]
    )
    path = user_cache_dir() / "tables" / "locus" / f"{hashlib.sha256(key.encode()).hexdigest()[:16]}.json"
    if path.exists():
        return FloodedLocus.from_dict(json.loads(path.read_text()))
    locus = FloodedLocus.compute(bearing, load_n, supply_pressure_pa, mesh, progress)
    _write_whole(path, json.dumps(locus.to_dict()) + "\n")
    return locus


@dataclasses.dataclass(frozen=True)
class ClearanceFit:
    """One bearing's clearance and film from its centreline.

    Attributes: clearance_factor g and its std (the clearance over the machine file's); viscosity_factor v
    and its std (the film's viscosity over the oil law's); correlation of g and v; offsets_m (2,) the
    probes' zero offsets (x, y) [m]; residual_rms_m the fit's rms residual [m]; points the centreline's
    points; speed_span the highest over the lowest speed.

    :attr:`explains_centreline` says whether the fit is the machine file's bearing at all
    (:data:`MAX_FILM_VISCOSITY_FACTOR`); :attr:`applied_clearance_factor` is what the estimator's model takes.
    """

    clearance_factor: float
    clearance_factor_std: float
    viscosity_factor: float
    viscosity_factor_std: float
    correlation: float
    offsets_m: np.ndarray
    residual_rms_m: float
    points: int
    speed_span: float

    @property
    def explains_centreline(self) -> bool:
        """Whether the machine file's bearing, at some clearance and a film no more viscous than
        :data:`MAX_FILM_VISCOSITY_FACTOR` times the oil law's, explains the centreline."""
        return self.viscosity_factor <= MAX_FILM_VISCOSITY_FACTOR

    @property
    def applied_clearance_factor(self) -> float:
        """The clearance factor the estimator's model takes: the measured one, or 1 (the machine file's
        clearance) when the fit does not explain the centreline, whose clearance it would only make up."""
        return self.clearance_factor if self.explains_centreline else 1.0


def fit_clearance(
    locus: FloodedLocus,
    bearing: JournalBearing,
    load_n: float,
    speed_hz,
    viscosity_pa_s,
    positions_m,
    noise_std_m: float,
) -> ClearanceFit:
    """Fit the clearance and viscosity factors of one bearing to its centreline (module docstring).

    ``speed_hz`` (K,), ``viscosity_pa_s`` (K,) the oil law's viscosity at each point's oil temperature,
    ``positions_m`` (K, 2) the mean journal position (x, y) at each point, ``noise_std_m`` the std of one
    such mean (the probes' noise over the samples averaged). ``bearing`` and ``load_n`` are the machine
    file's, ``locus`` solved for them.
    """
    speed = np.asarray(speed_hz, dtype=float)
    mu = np.broadcast_to(np.asarray(viscosity_pa_s, dtype=float), speed.shape)
    y = np.asarray(positions_m, dtype=float)
    if speed.ndim != 1 or y.shape != (speed.size, 2):
        raise InputError("a centreline needs one speed and one (x, y) position per point")
    if speed.size < 6:
        raise InputError(f"a centreline needs at least 6 speeds, got {speed.size}")
    if not (np.all(np.isfinite(speed)) and speed.min() > 0.0 and np.all(np.isfinite(y))):
        raise InputError("a centreline's speeds must be positive and its positions finite")
    span = float(speed.max() / speed.min())
    if span < MIN_SPEED_SPAN:
        raise InputError(
            f"a centreline must span a speed ratio of at least {MIN_SPEED_SPAN:g} (slow roll to speed), "
            f"got {speed.min():.4g}-{speed.max():.4g} Hz"
        )
    require_positive("centreline noise std", noise_std_m, "m")
    c = bearing.clearance_m
    s0 = sommerfeld_number(bearing, mu, speed, load_n)

    def residual(theta: np.ndarray) -> np.ndarray:
        g, v = np.exp(theta)
        shape = g * c * locus.position(s0 * v / g**2, clamped=True)
        r = y - shape
        return (r - r.mean(axis=0)).ravel() / noise_std_m  # whitened: the solver's tolerances are relative

    low = np.log([CLEARANCE_FACTOR_RANGE[0], VISCOSITY_FACTOR_RANGE[0]])
    high = np.log([CLEARANCE_FACTOR_RANGE[1], VISCOSITY_FACTOR_RANGE[1]])
    from scipy.optimize import least_squares  # start-up: see FloodedLocus.__init__

    solution = least_squares(residual, np.zeros(2), bounds=(low, high), x_scale=0.1, xtol=1e-12, ftol=1e-14)
    theta = solution.x
    r = residual(theta)
    dof = max(r.size - 4, 1)  # 2 factors and 2 offsets
    chi2_per_dof = float(r @ r / dof)
    jac = solution.jac
    covariance = max(chi2_per_dof, 1.0) * np.linalg.pinv(jac.T @ jac)
    g, v = np.exp(theta)
    std = np.sqrt(np.diag(covariance))
    for name, value, (lo, hi) in (
        ("clearance factor", g, CLEARANCE_FACTOR_RANGE),
        ("viscosity factor", v, VISCOSITY_FACTOR_RANGE),
    ):
        if not lo * 1.001 < value < hi / 1.001:
            raise InputError(
                f"the centreline's {name} came out at the search's limit ({value:.3f}, range "
                f"{lo:g}-{hi:g}): the record is not a flooded coast-down of this bearing"
            )
    s_low, s_high = locus.sommerfeld_range
    reached = s0 * v / g**2
    if reached.min() < s_low * (1 - 1e-9) or reached.max() > s_high * (1 + 1e-9):
        raise InputError(
            f"the centreline's speeds {speed.min():.4g}-{speed.max():.4g} Hz reach Sommerfeld numbers "
            f"{reached.min():.3g}-{reached.max():.3g} at the fitted clearance and film, beyond the flooded "
            f"locus's {s_low:.3g}-{s_high:.3g} (a slow roll below the film's load capacity?)"
        )
    shape = g * c * locus.position(s0 * v / g**2)
    return ClearanceFit(
        clearance_factor=float(g),
        clearance_factor_std=float(g * std[0]),
        viscosity_factor=float(v),
        viscosity_factor_std=float(v * std[1]),
        correlation=float(covariance[0, 1] / (std[0] * std[1])) if std.all() else 0.0,
        offsets_m=(y - shape).mean(axis=0),
        residual_rms_m=noise_std_m * math.sqrt(chi2_per_dof),
        points=int(speed.size),
        speed_span=span,
    )


def centreline_points(
    speed_hz, values, bin_ratio: float = 1.05, min_samples: int = 1, weights=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Average a record's rows into centreline points: ``speed_hz`` (K,), ``values`` (K, m) (the probe
    signals and whatever else is averaged with them), ``weights`` (K,) the samples each row stands for (a
    revolution's mean: :func:`revolution_means`; None: one each).

    Rows are grouped in speed bins of ``bin_ratio`` (uniform in ln N); each bin of at least ``min_samples``
    samples gives its weighted mean speed, mean values (m,) and sample count. A centreline file with one row
    per speed passes unchanged.
    """
    speed = np.asarray(speed_hz, dtype=float)
    values = np.asarray(values, dtype=float)
    weight = np.ones(speed.size) if weights is None else np.asarray(weights, dtype=float)
    require_in_range("centreline speed bin ratio", bin_ratio, 1.001, 2.0)
    if speed.ndim != 1 or values.ndim != 2 or values.shape[0] != speed.size or weight.shape != speed.shape:
        raise InputError("a centreline record needs one speed per sample")
    if not (np.all(np.isfinite(speed)) and np.all(speed > 0.0)):
        raise InputError("a centreline record needs a positive, finite speed_hz on every sample")
    index = np.floor(np.log(speed) / math.log(bin_ratio)).astype(np.int64)
    bins, inverse = np.unique(index, return_inverse=True)
    sums = np.zeros((bins.size, values.shape[1] + 2))
    np.add.at(sums, inverse, weight[:, None] * np.column_stack([np.ones(speed.size), speed, values]))
    counts = sums[:, 0]
    keep = counts >= min_samples
    mean = sums[keep, 1:] / counts[keep, None]
    return mean[:, 0], mean[:, 1:], counts[keep]


def revolution_means(revolutions, speed_hz, values) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mean speed, values (m,) and sample count of each whole revolution of a record: ``revolutions``
    (K,) the rotor's turns since the record began (the keyphasor's count, or the speed's integral). The
    first and last, partial, revolutions are dropped. A mean over a whole revolution has no 1x or 2x
    runout in it, which a mean over a speed bin at slow roll (about one revolution) would keep."""
    turns = np.floor(np.asarray(revolutions, dtype=float)).astype(np.int64)
    speed = np.asarray(speed_hz, dtype=float)
    values = np.asarray(values, dtype=float)
    groups, inverse, counts = np.unique(turns, return_inverse=True, return_counts=True)
    sums = np.zeros((groups.size, values.shape[1] + 1))
    np.add.at(sums, inverse, np.column_stack([speed, values]))
    means = sums / counts[:, None]
    whole = slice(1, -1)
    return means[whole, 0], means[whole, 1:], counts[whole]
