"""A plant whose structure is not the estimator's model: what a real machine has that no parameter gives.

The estimator's model (the machine file) has rigid supports, equal bearing loads, the nominal clearance and
length, the unbalance on one disc, a straight shaft and one kind of linearized film. A real machine differs in
each of these in structure, not only in a parameter the filter estimates. :class:`PlantStructure` says how the
plant differs; :func:`structural_system` builds the plant's full-order rotor-bearing system with it:

* ``film_coefficients``: the kind of film coefficients of the plant's 1x response (quasi-static or
  synchronous, :mod:`oilwatch.models.bearing.coefficient_kinds`), whatever the machine file says;
* ``clearance_factor``: the bearings' radial clearance over the machine file's. Exact through the film's
  scaling (:mod:`oilwatch.models.bearing.operating_table`): for the same R, L and groove, a clearance
  c' = g c is the machine's bearing at the Sommerfeld number of viscosity mu / g^2, with flowrates, the
  equilibrium eccentricity and 1 / (K, C) all g times the table's (:class:`ClearanceTable`);
* ``length_factor``: the bearings' axial length over the machine file's (the groove keeps its size). L/D is
  not a scaling of the table, so the plant's tables are solved afresh for that bearing
  (:func:`oilwatch.models.bearing.table.compute_table`, cached in the user cache folder);
* ``load_split``: "reactions" loads each bearing with its statically determinate reaction instead of the
  machine file's split;
* ``unbalance_discs``: the unbalance spread over several discs, each a share of the machine's moment at a
  phase relative to the machine's phase;
* ``pedestals``: a mass, spring and damper under each bearing in x and y
  (:mod:`oilwatch.models.rotor.pedestals`);
* ``side_load_fraction``, ``side_load_angle_deg``: a steady force at each bearing that the machine file
  does not give (coupling misalignment, a belt, a process or gear force): a fraction of the bearing's
  share of the weight along a bearing angle (the grooves' convention: from the top, with the rotation;
  270 deg is +x, horizontal). Each bearing then carries the vector sum of its machine-file load and this
  force, in magnitude and direction (:func:`structural_machine`); the rotor carries the external force that
  makes it so (``Rotor.static_force``). The machine's tables are for its own load direction, so the plant's
  tables are solved afresh for the turned load (:func:`solved_table`, cached);
* ``threshold_one_sided``: the film coefficients at each bearing's flooded threshold q_t take their one-sided
  limits, starved below and flooded above, with the jump a direct solve has there; the estimator's
  dimensionless table interpolates one cubic across it, which smooths the jump over the neighbouring cells
  (2-7 % of the largest K within 1 % of q_t, docs/bearings.md). Needs ``length_factor`` 1 and no side load
  (the solved tables interpolate across q_t);
* ``bow_m``: a bent shaft. The bow is the shape the shaft takes on rigid point supports at the bearing
  nodes under a uniform lateral load, scaled to ``bow_m`` at its largest between the bearings and turning
  with the shaft at ``bow_phase_rad`` from the keyphasor. Its load on the rotor is K_shaft b (the shaft's
  elastic force acts on r - b), a 1x load fixed in the rotor. The bow is zero at the bearing nodes, so the
  probes see no runout from it. The plant carries it in the unit 1x load, so it is exact at the system's
  speed (a speed change would scale it like the unbalance, as the square of the speed).

Every field at its default gives the machine file's plant.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field, fields

import numpy as np

from ..bearing.coefficient_kinds import COEFFICIENT_KINDS, QUASI_STATIC
from ..bearing.geometry import JournalBearing, load_polar, load_vector_n
from ..bearing.table import CoefficientTable, compute_table, flooded_threshold
from ..cache import user_cache_dir
from ..machine import Machine
from ..rotor.assembly import Rotor
from ..rotor.pedestals import Pedestals
from ..validation import InputError, require_in_range
from .operating_point import ConditionedTable, operating_tables_of
from .rotor_bearing import RotorBearingSystem

LENGTH_TABLE_POINTS = 7
"""Flowrates of a plant table solved for another bearing length (50-150 % of its q_t, as the machine's)."""


def _meta(unit: str, low: float, high: float, description: str) -> dict:
    return {"unit": unit, "range": (low, high), "description": description}


@dataclass(frozen=True)
class PlantStructure:
    """How the plant's structure differs from the machine file (module docstring; defaults: not at all).

    Numeric fields carry their unit, range and description in their metadata (the plant FMU's parameters).
    """

    film_coefficients: str | None = None
    clearance_factor: float = field(
        default=1.0, metadata=_meta("1", 0.7, 1.3, "bearing radial clearance over the machine file's")
    )
    length_factor: float = field(
        default=1.0, metadata=_meta("1", 0.8, 1.2, "bearing axial length over the machine file's")
    )
    load_split: str | None = None
    unbalance_discs: tuple[tuple[int, float, float], ...] = ()
    pedestal_mass_kg: float = field(
        default=0.0, metadata=_meta("kg", 0.0, 1e5, "modal mass of each bearing pedestal (0: rigid supports)")
    )
    pedestal_stiffness_n_m: float = field(
        default=0.0, metadata=_meta("N/m", 0.0, 1e11, "stiffness of each pedestal to ground, x and y")
    )
    pedestal_damping_n_s_m: float = field(
        default=0.0, metadata=_meta("N s/m", 0.0, 1e7, "damping of each pedestal to ground, x and y")
    )
    bow_m: float = field(
        default=0.0, metadata=_meta("m", 0.0, 200e-6, "shaft bow, largest between the bearings")
    )
    bow_phase_rad: float = field(
        default=0.0, metadata=_meta("rad", -2 * math.pi, 2 * math.pi, "phase of the bow from the keyphasor")
    )
    side_load_fraction: float = field(
        default=0.0,
        metadata=_meta("1", 0.0, 1.0, "steady side force at each bearing over its share of the weight"),
    )
    side_load_angle_deg: float = field(
        default=270.0,
        metadata=_meta(
            "deg", 0.0, 360.0, "bearing angle of the side force (from the top, with the rotation; 270: +x)"
        ),
    )
    threshold_one_sided: bool = False

    def __post_init__(self) -> None:
        for f in fields(self):
            if "range" in f.metadata:
                low, high = f.metadata["range"]
                require_in_range(f.name, getattr(self, f.name), low, high, f.metadata["unit"])
        if self.film_coefficients is not None and self.film_coefficients not in COEFFICIENT_KINDS:
            raise InputError(
                f"film_coefficients must be one of {', '.join(COEFFICIENT_KINDS)}, "
                f"got {self.film_coefficients!r}"
            )
        if self.load_split not in (None, "equal", "reactions"):
            raise InputError(f"load_split must be 'equal' or 'reactions', got {self.load_split!r}")
        if not isinstance(self.threshold_one_sided, bool):
            raise InputError(f"threshold_one_sided must be True or False, got {self.threshold_one_sided!r}")
        if self.threshold_one_sided and self.length_factor != 1.0:
            raise InputError(
                "threshold_one_sided needs length_factor 1: the tables solved for another bearing length "
                "interpolate across the flooded threshold"
            )
        if self.threshold_one_sided and self.side_load_fraction > 0.0:
            raise InputError(
                "threshold_one_sided needs side_load_fraction 0: the tables solved for the turned load "
                "interpolate across the flooded threshold"
            )
        if (self.pedestal_mass_kg > 0.0) != (self.pedestal_stiffness_n_m > 0.0):
            raise InputError("pedestal_mass_kg and pedestal_stiffness_n_m: give both (> 0) or neither")
        for node, share, phase in self.unbalance_discs:
            require_in_range("unbalance share", share, 0.0, 10.0)
            require_in_range("unbalance phase", phase, -2 * math.pi, 2 * math.pi, "rad")
            if isinstance(node, bool) or not isinstance(node, int):
                raise InputError(f"unbalance disc node must be an integer, got {node!r}")

    @property
    def solved_tables(self) -> bool:
        """Whether the plant's tables are solved for its bearings (another length, or a load turned by a
        side force) rather than the machine's tables scaled to its clearance (:class:`ClearanceTable`)."""
        return self.length_factor != 1.0 or self.side_load_fraction > 0.0

    @property
    def pedestals(self) -> Pedestals | None:
        """The pedestals, or None for rigid supports."""
        if self.pedestal_mass_kg == 0.0:
            return None
        return Pedestals(self.pedestal_mass_kg, self.pedestal_stiffness_n_m, self.pedestal_damping_n_s_m)


class ClearanceTable(ConditionedTable):
    """The dimensionless table of the machine's bearing seen as the same bearing with clearance g c.

    With R, L and the groove unchanged the film depends on c only through S (proportional to mu / c^2) and
    the flow unit q_c = Omega R c L / 2; forces keep their scale W. So at the clearance g c: S is the table's
    at mu / g^2, q_t is g times, the eccentricity is g times and K = W Kbar / (g c), C likewise 1 / g.
    """

    def __init__(
        self,
        table,
        load_n: float,
        speed_hz: float,
        viscosity_pa_s: float,
        clearance_factor: float,
        one_sided: bool = False,
    ) -> None:
        self.clearance_factor = require_in_range("clearance factor", clearance_factor, 0.5, 2.0)
        super().__init__(table, load_n, speed_hz, viscosity_pa_s, one_sided)
        self.metadata["bearing"]["clearance_m"] = table.geometry["clearance_m"] * clearance_factor

    def table_viscosity_pa_s(self, viscosity_pa_s: float) -> float:
        """The Sommerfeld number at clearance g c is the table's at viscosity mu / g^2 (class docstring)."""
        return viscosity_pa_s / self.clearance_factor**2

    @property
    def flowrate_range_m3_s(self) -> tuple[float, float]:
        """Flowrates [m^3/s] the table covers."""
        low, high = self._slice.flowrate_range_m3_s
        return low * self.clearance_factor, high * self.clearance_factor

    @property
    def flowrates_m3_s(self) -> np.ndarray:
        """The flowrate nodes [m^3/s]."""
        return super().flowrates_m3_s * self.clearance_factor

    def evaluate_many(self, q_m3_s: np.ndarray) -> np.ndarray:
        """Rows (m, 10) ``[e_x, e_y, K, C]`` (SI) at the flowrates (m,) [m^3/s]."""
        g = self.clearance_factor
        rows = self._slice.rows(np.asarray(q_m3_s, dtype=float) / g)
        rows[:, :2] *= g
        rows[:, 2:] /= g
        return rows


def structural_bearing(bearing: JournalBearing, structure: PlantStructure) -> JournalBearing:
    """``bearing`` with the structure's clearance and length factors."""
    return dataclasses.replace(
        bearing,
        clearance_m=bearing.clearance_m * structure.clearance_factor,
        length_m=bearing.length_m * structure.length_factor,
    )


def structural_machine(machine: Machine, structure: PlantStructure) -> Machine:
    """The machine file as the plant is: its load split, and each bearing's static load (magnitude in
    ``static_loads_given_n``, direction in its ``load_angle_rad``) the vector sum of the machine's load and
    the structure's side force (module docstring). A machine with ``static_forces`` whose plant has another
    load split or a side force gives the plant its bearings' loads, the forces' reactions included, as given
    loads (the rotor then carries them at the bearings: the journals' statics are the same). The bearings
    keep the machine file's clearance and length (:func:`structural_bearing` applies those)."""
    plant = machine
    if structure.load_split is not None and structure.load_split != machine.load_split:
        plant = dataclasses.replace(machine, load_split=structure.load_split)
    if structure.side_load_fraction == 0.0 and (plant is machine or not machine.static_forces):
        return plant
    rotor = Rotor.from_machine(plant)
    weight = dataclasses.replace(plant, static_loads_given_n=(), static_forces=())
    shares = Rotor.from_machine(weight).bearing_static_loads_n
    side = load_vector_n(structure.side_load_fraction * shares, math.radians(structure.side_load_angle_deg))
    loads, angles = load_polar(
        load_vector_n(rotor.bearing_static_loads_n, rotor.bearing_load_angles_rad) + side
    )
    bearings = tuple(
        dataclasses.replace(b, load_angle_rad=float(a)) for b, a in zip(plant.bearings, angles, strict=True)
    )
    return dataclasses.replace(
        plant, bearings=bearings, static_loads_given_n=tuple(float(w) for w in loads), static_forces=()
    )


def structural_rotor(machine: Machine, structure: PlantStructure) -> Rotor:
    """The plant's rotor: the machine's with the structure's load split and side force
    (:func:`structural_machine`)."""
    return Rotor.from_machine(structural_machine(machine, structure))


def unit_1x_load(rotor: Rotor, structure: PlantStructure, omega_rad_s: float, moment: complex) -> np.ndarray:
    """(n_dof,) complex: the plant's 1x load per unit complex unbalance moment ``moment`` [kg m] (the
    machine's), with the unbalance spread over the structure's discs and its bow (module docstring)."""
    unit = np.zeros(rotor.n_dof, dtype=complex)
    discs = structure.unbalance_discs or ((rotor.unbalance_node, 1.0, 0.0),)
    for node, share, phase in discs:
        unit[rotor.dof(node, "x")] += share * omega_rad_s**2 * np.exp(1j * phase)
        unit[rotor.dof(node, "y")] += -1j * share * omega_rad_s**2 * np.exp(1j * phase)
    if structure.bow_m > 0.0:
        unit += rotor.stiffness_matrix @ bow_shape(rotor, structure.bow_m, structure.bow_phase_rad) / moment
    return unit


def bow_shape(rotor: Rotor, bow_m: float, phase_rad: float) -> np.ndarray:
    """(n_dof,) complex: the bow b (module docstring) as a rotating vector, x = Re(b e^{i theta}),
    y = Re(-i b e^{i theta}) (the unbalance's convention); its largest translation between the bearings is
    bow_m."""
    n = rotor.n_dof
    fixed = [rotor.dof(node, axis) for node in rotor.bearing_nodes for axis in ("x", "y")]
    free = np.setdiff1d(np.arange(n), fixed)
    shapes = []
    for axis in ("x", "y"):
        load = np.zeros(n)
        load[[rotor.dof(k, axis) for k in range(1, rotor.n_nodes + 1)]] = 1.0
        shape = np.zeros(n)
        shape[free] = np.linalg.solve(rotor.stiffness_matrix[np.ix_(free, free)], load[free])
        shapes.append(shape)
    first, last = min(rotor.bearing_nodes), max(rotor.bearing_nodes)
    span = [rotor.dof(k, "x") for k in range(first, last + 1)]
    scale = bow_m / np.max(np.abs(shapes[0][span]))
    return scale * np.exp(1j * phase_rad) * (shapes[0] - 1j * shapes[1])


def structural_system(
    machine: Machine,
    structure: PlantStructure,
    unbalance_moment_kg_m: float | None = None,
    unbalance_phase_rad: float | None = None,
) -> RotorBearingSystem:
    """The plant's full-order rotor-bearing system with the structure (module docstring), at the machine's
    nominal speed and oil temperature; unbalance moment and phase as :class:`RotorBearingSystem`'s."""
    plant = structural_machine(machine, structure)
    rotor = Rotor.from_machine(plant)
    speed = machine.nominal_speed_hz
    kind = structure.film_coefficients or machine.dynamic_coefficients
    kinds = (QUASI_STATIC,) if kind == QUASI_STATIC else (QUASI_STATIC, kind)
    loads = rotor.bearing_static_loads_n
    # the machine's tables hold only loads along its bearings' own directions
    turned = any(
        p.load_angle_rad != b.load_angle_rad for p, b in zip(plant.bearings, machine.bearings, strict=True)
    )
    if turned and structure.threshold_one_sided:
        raise InputError(
            "threshold_one_sided needs the machine's load directions: its plant's loads are turned (a side "
            "force, or static forces under another load split), and the tables solved for them interpolate "
            "across the flooded threshold"
        )
    if not (structure.solved_tables or turned):
        viscosity = machine.bearings[0].viscosity_pa_s  # one oil: every bearing's nominal viscosity
        groups = [
            [
                ClearanceTable(
                    table, w, speed, viscosity, structure.clearance_factor, structure.threshold_one_sided
                )
                for table, w in zip(operating_tables_of(machine, k), loads, strict=True)
            ]
            for k in kinds
        ]
    else:
        groups = [[solved_table(plant, structure, w, k, i) for i, w in enumerate(loads)] for k in kinds]
    moment = rotor.unbalance_moment_kg_m if unbalance_moment_kg_m is None else unbalance_moment_kg_m
    phase = rotor.unbalance_phase_rad if unbalance_phase_rad is None else unbalance_phase_rad
    omega = 2.0 * math.pi * speed
    return RotorBearingSystem(
        rotor,
        groups[0],
        speed,
        None,
        moment,
        phase,
        machine.lubrication.nominal_flowrates_m3_s,
        groups[1] if len(groups) > 1 else None,
        unit_unbalance_force=unit_1x_load(rotor, structure, omega, moment * np.exp(1j * phase)),
        pedestals=structure.pedestals,
    )


def solved_table(
    machine: Machine, structure: PlantStructure, load_n: float, kind: str, bearing_index: int = 0
) -> CoefficientTable:
    """The flowrate table of the machine's bearing ``bearing_index`` (from 0) with the structure's clearance
    and length at ``load_n`` along the bearing's ``load_angle_rad`` (``machine``: the plant's,
    :func:`structural_machine`), solved at the nominal speed on the production mesh (cached in
    ``<cache>/tables/structure/``, by geometry with the load direction, load, speed and kind)."""
    bearing = structural_bearing(machine.bearings[bearing_index], structure)
    speed = machine.nominal_speed_hz
    key = json.dumps([dataclasses.asdict(bearing), round(load_n, 6), speed, kind, LENGTH_TABLE_POINTS])
    path = user_cache_dir() / "tables" / "structure" / f"{hashlib.sha256(key.encode()).hexdigest()[:16]}.json"
    if path.exists():
        return CoefficientTable.load(path)
    q_t, _ = flooded_threshold(bearing, load_n, speed)
    lubrication = machine.lubrication
    flows = q_t * np.linspace(
        lubrication.table_min_fraction_of_threshold,
        lubrication.table_max_fraction_of_threshold,
        LENGTH_TABLE_POINTS,
    )
    table = compute_table(
        bearing,
        load_n,
        speed,
        flows,
        flooded_threshold_m3_s=q_t,
        coefficients=kind,
        provenance={"structure": key},
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.tmp")
    table.save(temporary)
    temporary.replace(path)
    return table
