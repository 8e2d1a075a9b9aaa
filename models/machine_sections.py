"""The parts of a machine file: material, discs, unbalance, bearings, oil and lubrication, and their readers.

Each reader validates one section of a parsed machine file (:mod:`oilwatch.models.machine`) with the field
readers of :mod:`oilwatch.models.machine_fields` and converts it to SI.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .bearing.geometry import DOWNWARD_LOAD_RAD, AxialGroove, JournalBearing, load_vector_n
from .machine_fields import as_node, as_number, frozen_array, read_key, read_real, read_table
from .oil import DEFAULT_THERMAL_EXPANSION_PER_K, Oil
from .validation import InputError

LOAD_SPLITS = ("equal", "reactions")


@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material of shaft and discs.

    Attributes: youngs_modulus_pa E [Pa], poisson_ratio nu [-], density_kg_m3 rho [kg/m^3].
    """

    youngs_modulus_pa: float
    poisson_ratio: float
    density_kg_m3: float

    @property
    def shear_modulus_pa(self) -> float:
        """G = E / (2 (1 + nu)) [Pa]."""
        return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))


@dataclass(frozen=True)
class Disc:
    """A rigid annular disc shrunk on the shaft at ``node`` (paper numbering from 1).

    The bore equals the shaft diameter at the node (the larger of the adjacent elements'), which is
    what reproduces the paper's rotor weight. Lengths in metres.
    """

    node: int
    width_m: float
    outer_diameter_m: float
    bore_diameter_m: float


@dataclass(frozen=True)
class StaticForce:
    """A steady force on the rotor at ``node`` (paper numbering from 1): a gear mesh at a pinion, a belt on a
    pulley, a process force on an impeller. ``force_n`` [N] along the bearing angle ``angle_rad`` [rad] (the
    grooves' convention: from the top, +y, in the direction of rotation; pi is down)."""

    node: int
    force_n: float
    angle_rad: float

    def vector_n(self) -> np.ndarray:
        """(F_x, F_y) [N] (:func:`~oilwatch.models.bearing.geometry.load_vector_n`)."""
        return load_vector_n(self.force_n, self.angle_rad)


@dataclass(frozen=True)
class Unbalance:
    """Residual unbalance by ISO 1940 balance grade: e = grade / Omega_nominal.

    Attributes: node (paper numbering), iso_grade_m_s [m/s] (G2.5 = 2.5e-3 m/s), phase_rad
    phi of Eqs. 5-6 [rad].
    """

    node: int
    iso_grade_m_s: float
    phase_rad: float


@dataclass(frozen=True, eq=False)
class Lubrication:
    """Nominal oil supply of the bearings.

    Attributes
    ----------
    nominal_supply_pressure_pa : nominal groove pressure [Pa] (NaN when the file gives only flowrates).
    nominal_flowrates_m3_s : (n_bearings,) read-only, each bearing's nominal supply flowrate [m^3/s] in the
        order of ``bearing_nodes``: a bearing's flowrate given as a percentage is a percentage of its own.
        A bearing's ``[[bearings.override]]`` value, else ``[lubrication]``'s, else the steady flowrate at the
        nominal groove pressure with that bearing's geometry and static load
        (:func:`oilwatch.models.machine.nominal_flowrate_from_pressure`).
    table_min_fraction_of_threshold, table_max_fraction_of_threshold : span of the coefficient tables as
        fractions of the flooded threshold flowrate q_t [-].
    nominal_flowrates_computed : (n_bearings,) whether each bearing's nominal flowrate was computed from the
        supply pressure (the file gives none for it).
    """

    nominal_supply_pressure_pa: float
    nominal_flowrates_m3_s: np.ndarray
    table_min_fraction_of_threshold: float
    table_max_fraction_of_threshold: float
    nominal_flowrates_computed: tuple[bool, ...]


def shaft_diameter_at_node(diameters_m: np.ndarray, node: int) -> float:
    """The shaft diameter at ``node`` [m]: the larger of the elements meeting there."""
    adjacent = [k - 1 for k in (node - 1, node) if 1 <= k <= diameters_m.size]
    return float(max(diameters_m[k] for k in adjacent))


def _entries(data: Mapping[str, Any], name: str) -> list[tuple[str, Mapping[str, Any]]]:
    """The tables of the ``[[name]]`` array (none when absent) with their section names, ``name[i]``."""
    entries = data.get(name, [])
    if not isinstance(entries, list):
        raise InputError(f"[[{name}]] must be an array of tables")
    for i, entry in enumerate(entries):
        if not isinstance(entry, Mapping):
            raise InputError(f"{name}[{i}] must be a table")
    return [(f"{name}[{i}]", entry) for i, entry in enumerate(entries)]


def read_discs(data: Mapping[str, Any], diameters: np.ndarray, n_nodes: int) -> tuple[Disc, ...]:
    """The ``[[discs]]`` array (none when absent); each bore is the shaft diameter at its node."""
    discs = []
    for section, entry in _entries(data, "discs"):
        node = as_node(read_key(entry, section, "node"), f"{section}.node", n_nodes)
        width = read_real(entry, section, "width_mm", "mm") / 1e3
        outer = read_real(entry, section, "outer_diameter_mm", "mm") / 1e3
        bore = shaft_diameter_at_node(diameters, node)
        if outer <= bore:
            raise InputError(
                f"{section}.outer_diameter_mm must exceed the shaft diameter at node {node} "
                f"({bore * 1e3:g} mm), got {outer * 1e3:g}"
            )
        discs.append(Disc(node, width, outer, bore))
    return tuple(discs)


def read_static_forces(data: Mapping[str, Any], n_nodes: int) -> tuple[StaticForce, ...]:
    """The ``[[static_forces]]`` array (none when absent)."""
    forces = []
    for section, entry in _entries(data, "static_forces"):
        node = as_node(read_key(entry, section, "node"), f"{section}.node", n_nodes)
        force = read_real(entry, section, "force_n", "N")
        angle = math.radians(read_real(entry, section, "angle_deg", "deg", low=None))
        forces.append(StaticForce(node, force, angle))
    return tuple(forces)


def read_bearings(
    data: Mapping[str, Any], diameters: np.ndarray, n_nodes: int
) -> tuple[tuple[int, ...], tuple[JournalBearing, ...], str]:
    """The ``[bearings]`` table: (bearing nodes, each bearing's geometry and viscosity in the nodes' order,
    load split).

    The table's geometry is every bearing's unless a ``[[bearings.override]]`` entry for its node gives
    other values of some :data:`OVERRIDE_KEYS` (:func:`read_overrides`).
    """
    table = read_table(data, "bearings")
    nodes = read_key(table, "bearings", "nodes")
    if not isinstance(nodes, list) or not nodes:
        raise InputError("bearings.nodes must be a non-empty list of node numbers")
    bearing_nodes = tuple(as_node(n, f"bearings.nodes[{i}]", n_nodes) for i, n in enumerate(nodes))
    if len(set(bearing_nodes)) != len(bearing_nodes):
        raise InputError(f"bearings.nodes must be distinct, got {list(bearing_nodes)}")
    load_split = read_key(table, "bearings", "load_split")
    if load_split not in LOAD_SPLITS:
        raise InputError(f"bearings.load_split must be one of {LOAD_SPLITS}, got {load_split!r}")
    viscosity = _bearing_viscosity(data, table)
    shared = _read_geometry(table, {}, "", viscosity)
    overrides = read_overrides(table, bearing_nodes)
    bearings = []
    for i, node in enumerate(bearing_nodes):
        section, entry = overrides.get(node, ("", {}))
        override = {key: value for key, value in entry.items() if key in OVERRIDE_KEYS}
        bearing = _read_geometry(table, override, section, viscosity) if override else shared
        _check_journal(bearing, diameters, node, i, section if "radius_mm" in override else "bearings")
        bearings.append(bearing)
    return bearing_nodes, tuple(bearings), load_split


OVERRIDE_KEYS = (
    "radius_mm",
    "length_mm",
    "radial_clearance_um",
    "groove_angle_deg",
    "groove_circumferential_mm",
    "groove_axial_mm",
    "grooves",
    "circumferential_groove_axial_mm",
    "load_angle_deg",
)
"""The keys of ``[bearings]`` that a ``[[bearings.override]]`` entry may give for its bearing: its geometry
and the direction of its static load."""
OVERRIDE_SUPPLY_KEY = "nominal_flowrate_ml_min"
"""The key of ``[lubrication]`` that a ``[[bearings.override]]`` entry may give for its bearing: its own
nominal supply flowrate."""
OVERRIDE_LOAD_KEY = "static_load_n"
"""The key only a ``[[bearings.override]]`` entry gives: the magnitude of its bearing's static load, when it
is not the bearing's share of the weight (a gear mesh, a belt, a process force)."""


def read_overrides(
    table: Mapping[str, Any], bearing_nodes: tuple[int, ...]
) -> dict[int, tuple[str, Mapping]]:
    """The ``[[bearings.override]]`` entries by bearing node: (the entry's section name, the entry without
    its ``node``). Each names one node of ``bearings.nodes``, at most once, and gives only
    :data:`OVERRIDE_KEYS` and :data:`OVERRIDE_SUPPLY_KEY`."""
    if "override" not in table:
        return {}
    entries = table["override"]
    if not isinstance(entries, list) or not entries:
        raise InputError("[[bearings.override]] must be a non-empty array of tables")
    overrides: dict[int, tuple[str, Mapping]] = {}
    for i, entry in enumerate(entries):
        section = f"bearings.override[{i}]"
        if not isinstance(entry, Mapping):
            raise InputError(f"{section} must be a table")
        node = read_key(entry, section, "node")
        if isinstance(node, bool) or not isinstance(node, int) or node not in bearing_nodes:
            raise InputError(
                f"{section}.node must be one of bearings.nodes {list(bearing_nodes)}, got {node!r}"
            )
        if node in overrides:
            raise InputError(
                f"{section}.node = {node}: that bearing has an override already ({overrides[node][0]})"
            )
        unknown = sorted(set(entry) - {"node", *OVERRIDE_KEYS, OVERRIDE_SUPPLY_KEY, OVERRIDE_LOAD_KEY})
        if unknown:
            raise InputError(
                f"{section}.{unknown[0]} cannot differ between bearings: an override gives only node, "
                f"{', '.join(OVERRIDE_KEYS)}, {OVERRIDE_SUPPLY_KEY} and {OVERRIDE_LOAD_KEY}"
            )
        overrides[node] = section, {key: value for key, value in entry.items() if key != "node"}
    return overrides


def read_static_loads(data: Mapping[str, Any], bearing_nodes: tuple[int, ...]) -> tuple[float | None, ...]:
    """Each bearing's static load magnitude [N] from its ``[[bearings.override]] static_load_n``, in the order
    of ``bearing_nodes``; None where the file gives none (the bearing carries its share of the weight)."""
    overrides = read_overrides(read_table(data, "bearings"), bearing_nodes)
    loads = []
    for node in bearing_nodes:
        section, entry = overrides.get(node, ("", {}))
        given = OVERRIDE_LOAD_KEY in entry
        loads.append(read_real(entry, section, OVERRIDE_LOAD_KEY, "N") if given else None)
    return tuple(loads)


def _read_geometry(
    table: Mapping[str, Any], override: Mapping[str, Any], section: str, viscosity: float
) -> JournalBearing:
    """The geometry of ``[bearings]`` (section "bearings") with the keys of ``override`` (section ``section``)
    in place of the table's; an override that gives grooves replaces the table's grooves whole."""

    def source(key: str) -> tuple[Mapping[str, Any], str]:
        return (override, section) if key in override else (table, "bearings")

    def real(key: str, unit: str, **bounds) -> float:
        where, name = source(key)
        return read_real(where, name, key, unit, **bounds)

    radius = real("radius_mm", "mm") / 1e3
    clearance = real("radial_clearance_um", "um") / 1e6
    if clearance >= radius:
        raise InputError(
            f"{source('radial_clearance_um')[1]}.radial_clearance_um must be smaller than "
            f"{source('radius_mm')[1]}.radius_mm ({radius * 1e3:g} mm), got {clearance * 1e6:g} um"
        )
    length = real("length_mm", "mm") / 1e3
    length_name = f"{source('length_mm')[1]}.length_mm"
    gives_grooves = any(key in override for key in (*GROOVE_KEYS, "grooves"))
    grooves = read_grooves(*((override, section) if gives_grooves else (table, "bearings")), radius, length,
                           length_name)  # fmt: skip
    band = 0.0
    if "circumferential_groove_axial_mm" in override or "circumferential_groove_axial_mm" in table:
        band_mm = real("circumferential_groove_axial_mm", "mm", high=length * 1e3)
        band = band_mm / 1e3
    load_angle = DOWNWARD_LOAD_RAD
    if "load_angle_deg" in override or "load_angle_deg" in table:
        load_angle = math.radians(real("load_angle_deg", "deg", low=None))
    return JournalBearing(
        radius_m=radius,
        length_m=length,
        clearance_m=clearance,
        viscosity_pa_s=viscosity,
        groove_angle_rad=grooves[0].angle_rad,
        groove_circumferential_m=grooves[0].circumferential_m,
        groove_axial_m=grooves[0].axial_m,
        more_grooves=grooves[1:],
        circumferential_groove_m=band,
        load_angle_rad=load_angle,
    )


def _check_journal(
    bearing: JournalBearing, diameters: np.ndarray, node: int, index: int, section: str
) -> None:
    """InputError unless the bearing's radius is the shaft's at its node (within 1 %)."""
    radius = bearing.radius_m
    adjacent = [diameters[k - 1] for k in (node - 1, node) if 1 <= k <= diameters.size]
    if min(abs(d - 2.0 * radius) for d in adjacent) > 0.01 * 2.0 * radius:
        journal = shaft_diameter_at_node(diameters, node)
        raise InputError(
            f"{section}.radius_mm = {radius * 1e3:g} does not match the shaft at "
            f"bearings.nodes[{index}] = {node} (diameter {journal * 1e3:g} mm)"
        )


GROOVE_KEYS = ("groove_angle_deg", "groove_circumferential_mm", "groove_axial_mm")
"""The one-groove form of ``[bearings]``; ``[[bearings.grooves]]`` (angle_deg, circumferential_mm, axial_mm)
lists any number of axial grooves instead."""


def read_grooves(
    table: Mapping[str, Any], section: str, radius: float, length: float, length_name: str
) -> tuple[AxialGroove, ...]:
    """The axial grooves of ``table`` (``[bearings]`` or an override, named ``section``): the one-groove keys
    or the ``[[<section>.grooves]]`` array; ``length_name`` names the key the bearing length came from."""
    one = [key for key in GROOVE_KEYS if key in table]
    if "grooves" in table and one:
        raise InputError(
            f"give the grooves once: [[{section}.grooves]] or {section}.{', '.join(one)}, not both"
        )
    if "grooves" not in table:
        entries, keys = [table], GROOVE_KEYS
        sections = [section]
    else:
        entries, keys = table["grooves"], ("angle_deg", "circumferential_mm", "axial_mm")
        if not isinstance(entries, list) or not entries:
            raise InputError(f"[[{section}.grooves]] must be a non-empty array of tables")
        sections = [f"{section}.grooves[{i}]" for i in range(len(entries))]
    grooves = []
    for where, entry in zip(sections, entries, strict=True):
        if not isinstance(entry, Mapping):
            raise InputError(f"{where} must be a table")
        angle, circumferential, axial = keys
        groove_axial = read_real(entry, where, axial, "mm") / 1e3
        if groove_axial > length:
            raise InputError(
                f"{where}.{axial} must be <= {length_name} ({length * 1e3:g}), got {groove_axial * 1e3:g}"
            )
        groove_circ = read_real(entry, where, circumferential, "mm") / 1e3
        if groove_circ > math.pi * radius:
            raise InputError(
                f"{where}.{circumferential} must be <= pi R ({math.pi * radius * 1e3:g}), "
                f"got {groove_circ * 1e3:g}"
            )
        grooves.append(
            AxialGroove(
                math.radians(read_real(entry, where, angle, "deg", low=None)), groove_circ, groove_axial
            )
        )
    return tuple(grooves)


def read_oil(data: Mapping[str, Any]) -> tuple[Oil | None, float | None]:
    """The ``[oil]`` section: ISO VG grade + viscosity index, or two measured points; density; nominal
    supply temperature. (None, None) when the file has no ``[oil]``."""
    if "oil" not in data:
        return None, None
    table = read_table(data, "oil")
    density = read_real(table, "oil", "density_15c_kg_m3", "kg/m^3")
    expansion = DEFAULT_THERMAL_EXPANSION_PER_K
    if "thermal_expansion_per_k" in table:
        expansion = read_real(table, "oil", "thermal_expansion_per_k", "1/K", strict=False)
    by_grade = "iso_vg_grade" in table or "viscosity_index" in table
    by_points = "kinematic_viscosity_points_c_cst" in table
    if by_grade == by_points:
        raise InputError(
            "[oil] needs either iso_vg_grade and viscosity_index, or kinematic_viscosity_points_c_cst "
            "(two [temperature degC, viscosity cSt] pairs), not both"
        )
    if by_grade:
        grade = read_real(table, "oil", "iso_vg_grade", "cSt")
        oil = Oil.from_grade(
            grade, read_real(table, "oil", "viscosity_index", "", low=None), density, expansion
        )
    else:
        points = table["kinematic_viscosity_points_c_cst"]
        pairs_ok = isinstance(points, list) and len(points) == 2
        if not (pairs_ok and all(isinstance(p, list) and len(p) == 2 for p in points)):
            raise InputError(
                "oil.kinematic_viscosity_points_c_cst must be two [temperature degC, viscosity cSt] pairs, "
                f"got {points!r}"
            )
        field = "oil.kinematic_viscosity_points_c_cst"
        pairs = tuple(tuple(as_number(v, f"{field}[{i}]") for v in p) for i, p in enumerate(points))
        oil = Oil.from_points(pairs, density, expansion)
    temperature = read_real(table, "oil", "nominal_supply_temperature_c", "degC", low=None)
    oil.dynamic_viscosity_pa_s(temperature)  # range check: names the temperature
    return oil, temperature


def _bearing_viscosity(data: Mapping[str, Any], bearings: Mapping[str, Any]) -> float:
    """The bearings' nominal viscosity [Pa s]: the oil's at its nominal temperature, or given directly."""
    oil, temperature = read_oil(data)
    if oil is None:
        return read_real(bearings, "bearings", "viscosity_pa_s", "Pa s")
    if "viscosity_pa_s" in bearings:
        raise InputError(
            "give the bearings' viscosity once: bearings.viscosity_pa_s or the [oil] section "
            "(its viscosity at oil.nominal_supply_temperature_c), not both"
        )
    return oil.dynamic_viscosity_pa_s(temperature)


def read_lubrication(data: Mapping[str, Any], bearing_nodes: tuple[int, ...]) -> Lubrication:
    """The ``[lubrication]`` table: nominal pressure and/or flowrate and the tables' span, with each bearing's
    own nominal flowrate from its ``[[bearings.override]]`` (``bearing_nodes`` from :func:`read_bearings`).

    A bearing whose flowrate neither its override nor ``[lubrication]`` gives gets NaN, for the machine to
    solve at the nominal groove pressure (:attr:`Lubrication.nominal_flowrates_computed`).
    """
    table = read_table(data, "lubrication")
    low = read_real(table, "lubrication", "table_min_fraction_of_threshold", "")
    high = read_real(table, "lubrication", "table_max_fraction_of_threshold", "")
    if high <= low:
        raise InputError(
            "lubrication.table_max_fraction_of_threshold must exceed "
            f"table_min_fraction_of_threshold ({low:g}), got {high:g}"
        )
    pressure = math.nan
    if "nominal_supply_pressure_bar" in table:
        pressure = read_real(table, "lubrication", "nominal_supply_pressure_bar", "bar", strict=False) * 1e5
    shared = math.nan
    if OVERRIDE_SUPPLY_KEY in table:
        shared = read_real(table, "lubrication", OVERRIDE_SUPPLY_KEY, "ml/min") / 1e6 / 60.0
    overrides = read_overrides(read_table(data, "bearings"), bearing_nodes)
    flowrates = []
    for node in bearing_nodes:
        section, entry = overrides.get(node, ("", {}))
        own = OVERRIDE_SUPPLY_KEY in entry
        flowrates.append(
            read_real(entry, section, OVERRIDE_SUPPLY_KEY, "ml/min") / 1e6 / 60.0 if own else shared
        )
    computed = tuple(math.isnan(q) for q in flowrates)
    if any(computed) and math.isnan(pressure):
        raise InputError(
            "[lubrication] needs nominal_flowrate_ml_min or nominal_supply_pressure_bar (the flowrate is "
            "then computed at that groove pressure)"
        )
    return Lubrication(
        nominal_supply_pressure_pa=pressure,
        nominal_flowrates_m3_s=frozen_array(flowrates),
        table_min_fraction_of_threshold=low,
        table_max_fraction_of_threshold=high,
        nominal_flowrates_computed=computed,
    )
