"""The machine description: load and validate a rotor-bearing machine file (TOML, units in the keys).

The bundled file ``models/turbine.toml`` is the generic turbine of the paper (Tables 1-3). Users
describe their own machines the same way: any number of shaft elements, discs and bearing nodes.
Every physical value carries its unit in its key (``element_length_mm``); :func:`load_machine`
converts to SI and returns a frozen :class:`Machine`.

Quantities that need the finite-element model (rotor mass, weight, bearing loads, unbalance moment)
are not stored here: see ``models.rotor.assembly.Rotor.from_machine``.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from .bearing.coefficient_kinds import DEFAULT_KIND, require_kind
from .bearing.geometry import JournalBearing
from .oil import DEFAULT_THERMAL_EXPANSION_PER_K, Oil
from .validation import InputError, naming_file, read_text_file

BUNDLED_MACHINE = Path(__file__).resolve().parent / "turbine.toml"
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
class Unbalance:
    """Residual unbalance by ISO 1940 balance grade: e = grade / Omega_nominal.

    Attributes: node (paper numbering), iso_grade_m_s [m/s] (G2.5 = 2.5e-3 m/s), phase_rad
    phi of Eqs. 5-6 [rad].
    """

    node: int
    iso_grade_m_s: float
    phase_rad: float


@dataclass(frozen=True)
class Lubrication:
    """Nominal oil supply of the bearings.

    Attributes: nominal_supply_pressure_pa [Pa] (NaN when the file gives only a flowrate),
    nominal_flowrate_m3_s [m^3/s] (every flowrate given as a percentage is a percentage of it),
    table_min/max_fraction_of_threshold: span of the coefficient tables as fractions of the flooded
    threshold flowrate q_t [-], nominal_flowrate_computed: True when the file gives only the supply
    pressure and the flowrate was computed from it (:func:`nominal_flowrate_from_pressure`).
    """

    nominal_supply_pressure_pa: float
    nominal_flowrate_m3_s: float
    table_min_fraction_of_threshold: float
    table_max_fraction_of_threshold: float
    nominal_flowrate_computed: bool = False


@dataclass(frozen=True, eq=False, repr=False)
class Machine:
    """A rotor-bearing machine in SI units, as read from its machine file.

    Attributes
    ----------
    name : free text.
    source_path : the file it was read from.
    nominal_speed_hz : nominal spin speed [Hz].
    gravity_m_s2 : gravitational acceleration along -y [m/s^2].
    material : shaft and disc material.
    element_lengths_m, element_diameters_m : (n_elements,) read-only arrays [m]; element k joins
        node k to node k+1 (paper numbering from 1).
    discs : rigid discs.
    unbalance : residual unbalance (grade, node, phase).
    bearing_nodes : nodes carrying a bearing, in the file's order.
    bearing : geometry and lubricant shared by every bearing.
    load_split : how the weight is shared among bearings: "equal" (the paper: W / n_bearings each)
        or "reactions" (the support reactions of the rotor on rigid supports).
    lubrication : nominal supply.
    structural_damping_s : stiffness-proportional rotor damping coefficient beta [s], C = beta K
        (0 when the file has no ``[rotor_damping]`` table).
    raw : the parsed file, for sections owned by other models.
    oil : the lubricating oil (``[oil]``), None when the file gives ``bearings.viscosity_pa_s`` instead.
    dynamic_coefficients : which linearized film coefficients the machine's tables hold and the plant's and
        estimator's models use (``bearings.dynamic_coefficients``, :mod:`models.bearing.coefficient_kinds`):
        "synchronous" (default) or "quasi-static".
    nominal_oil_temperature_c : oil supply temperature [degC] at which ``bearing.viscosity_pa_s`` holds
        (None without ``[oil]``).
    """

    name: str
    source_path: Path
    nominal_speed_hz: float
    gravity_m_s2: float
    material: Material
    element_lengths_m: np.ndarray
    element_diameters_m: np.ndarray
    discs: tuple[Disc, ...]
    unbalance: Unbalance
    bearing_nodes: tuple[int, ...]
    bearing: JournalBearing
    load_split: str
    lubrication: Lubrication
    structural_damping_s: float
    raw: Mapping[str, Any]
    oil: Oil | None = None
    nominal_oil_temperature_c: float | None = None
    dynamic_coefficients: str = DEFAULT_KIND

    def __repr__(self) -> str:
        return (
            f"Machine({self.name!r}, {self.n_elements} elements, discs at "
            f"{[d.node for d in self.discs]}, bearings at {list(self.bearing_nodes)}, "
            f"from {str(self.source_path)!r})"
        )

    @property
    def n_elements(self) -> int:
        """Number of shaft elements."""
        return int(self.element_lengths_m.size)

    @property
    def n_nodes(self) -> int:
        """Number of nodes (n_elements + 1)."""
        return self.n_elements + 1

    @property
    def nominal_speed_rad_s(self) -> float:
        """Nominal spin speed Omega [rad/s]."""
        return 2.0 * math.pi * self.nominal_speed_hz


def _table(data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    value = data.get(key)
    if value is None:
        raise InputError(f"missing table [{key}]")
    if not isinstance(value, Mapping):
        raise InputError(f"[{key}] must be a table")
    return value


def _number(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{field} must be a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise InputError(f"{field} must be finite, got {value!r}")
    return number


def _get(table: Mapping[str, Any], section: str, key: str) -> Any:
    if key not in table:
        raise InputError(f"missing {section}.{key}")
    return table[key]


def _real(
    table: Mapping[str, Any],
    section: str,
    key: str,
    unit: str,
    *,
    low: float | None = 0.0,
    strict: bool = True,
    high: float | None = None,
    value: Any = None,
    field: str | None = None,
) -> float:
    """Read one number and check ``low < x`` (``<=`` unless strict) and ``x < high``."""
    field = field or f"{section}.{key}"
    number = _number(_get(table, section, key) if value is None else value, field)
    u = f" {unit}" if unit else ""
    if low is not None and (number <= low if strict else number < low):
        raise InputError(f"{field} must be {'>' if strict else '>='} {low:g}{u}, got {number:g}")
    if high is not None and number >= high:
        raise InputError(f"{field} must be < {high:g}{u}, got {number:g}")
    return number


def _positive_array(table: Mapping[str, Any], section: str, key: str, unit: str) -> np.ndarray:
    values = _get(table, section, key)
    if not isinstance(values, list) or not values:
        raise InputError(f"{section}.{key} must be a non-empty list of numbers [{unit}]")
    out = [
        _real(table, section, key, unit, value=v, field=f"{section}.{key}[{i}]") for i, v in enumerate(values)
    ]
    return np.array(out)


def _node(value: Any, field: str, n_nodes: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"{field} must be an integer node number, got {value!r}")
    if not 1 <= value <= n_nodes:
        raise InputError(f"{field} = {value} is not a node of this rotor (nodes 1..{n_nodes})")
    return value


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array


def shaft_diameter_at_node(diameters_m: np.ndarray, node: int) -> float:
    """The shaft diameter at ``node`` [m]: the larger of the elements meeting there."""
    adjacent = [k - 1 for k in (node - 1, node) if 1 <= k <= diameters_m.size]
    return float(max(diameters_m[k] for k in adjacent))


def _read_discs(data: Mapping[str, Any], diameters: np.ndarray, n_nodes: int) -> tuple[Disc, ...]:
    entries = data.get("discs", [])
    if not isinstance(entries, list):
        raise InputError("[[discs]] must be an array of tables")
    discs = []
    for i, entry in enumerate(entries):
        section = f"discs[{i}]"
        if not isinstance(entry, Mapping):
            raise InputError(f"{section} must be a table")
        node = _node(_get(entry, section, "node"), f"{section}.node", n_nodes)
        width = _real(entry, section, "width_mm", "mm") / 1e3
        outer = _real(entry, section, "outer_diameter_mm", "mm") / 1e3
        bore = shaft_diameter_at_node(diameters, node)
        if outer <= bore:
            raise InputError(
                f"{section}.outer_diameter_mm must exceed the shaft diameter at node {node} "
                f"({bore * 1e3:g} mm), got {outer * 1e3:g}"
            )
        discs.append(Disc(node, width, outer, bore))
    return tuple(discs)


def _read_bearings(
    data: Mapping[str, Any], diameters: np.ndarray, n_nodes: int
) -> tuple[tuple[int, ...], JournalBearing, str]:
    table = _table(data, "bearings")
    nodes = _get(table, "bearings", "nodes")
    if not isinstance(nodes, list) or not nodes:
        raise InputError("bearings.nodes must be a non-empty list of node numbers")
    bearing_nodes = tuple(_node(n, f"bearings.nodes[{i}]", n_nodes) for i, n in enumerate(nodes))
    if len(set(bearing_nodes)) != len(bearing_nodes):
        raise InputError(f"bearings.nodes must be distinct, got {list(bearing_nodes)}")
    load_split = _get(table, "bearings", "load_split")
    if load_split not in LOAD_SPLITS:
        raise InputError(f"bearings.load_split must be one of {LOAD_SPLITS}, got {load_split!r}")
    radius = _real(table, "bearings", "radius_mm", "mm") / 1e3
    clearance = _real(table, "bearings", "radial_clearance_um", "um") / 1e6
    if clearance >= radius:
        raise InputError("bearings.radial_clearance_um must be smaller than bearings.radius_mm")
    for i, node in enumerate(bearing_nodes):
        journal = shaft_diameter_at_node(diameters, node)
        adjacent = [diameters[k - 1] for k in (node - 1, node) if 1 <= k <= diameters.size]
        if min(abs(d - 2.0 * radius) for d in adjacent) > 0.01 * 2.0 * radius:
            raise InputError(
                f"bearings.radius_mm = {radius * 1e3:g} does not match the shaft at "
                f"bearings.nodes[{i}] = {node} (diameter {journal * 1e3:g} mm)"
            )
    length = _real(table, "bearings", "length_mm", "mm") / 1e3
    groove_axial = _real(table, "bearings", "groove_axial_mm", "mm") / 1e3
    if groove_axial > length:
        raise InputError(
            f"bearings.groove_axial_mm must be <= bearings.length_mm ({length * 1e3:g}), "
            f"got {groove_axial * 1e3:g}"
        )
    groove_circ = _real(table, "bearings", "groove_circumferential_mm", "mm") / 1e3
    if groove_circ > math.pi * radius:
        raise InputError(
            f"bearings.groove_circumferential_mm must be <= pi R ({math.pi * radius * 1e3:g}), "
            f"got {groove_circ * 1e3:g}"
        )
    bearing = JournalBearing(
        radius_m=radius,
        length_m=length,
        clearance_m=clearance,
        viscosity_pa_s=_bearing_viscosity(data, table),
        groove_angle_rad=math.radians(_real(table, "bearings", "groove_angle_deg", "deg", low=None)),
        groove_circumferential_m=groove_circ,
        groove_axial_m=groove_axial,
    )
    return bearing_nodes, bearing, load_split


def _read_oil(data: Mapping[str, Any]) -> tuple[Oil | None, float | None]:
    """The ``[oil]`` section: ISO VG grade + viscosity index, or two measured points; density; nominal
    supply temperature. (None, None) when the file has no ``[oil]``."""
    if "oil" not in data:
        return None, None
    table = _table(data, "oil")
    density = _real(table, "oil", "density_15c_kg_m3", "kg/m^3")
    expansion = DEFAULT_THERMAL_EXPANSION_PER_K
    if "thermal_expansion_per_k" in table:
        expansion = _real(table, "oil", "thermal_expansion_per_k", "1/K", strict=False)
    by_grade = "iso_vg_grade" in table or "viscosity_index" in table
    by_points = "kinematic_viscosity_points_c_cst" in table
    if by_grade == by_points:
        raise InputError(
            "[oil] needs either iso_vg_grade and viscosity_index, or kinematic_viscosity_points_c_cst "
            "(two [temperature degC, viscosity cSt] pairs), not both"
        )
    if by_grade:
        grade = _real(table, "oil", "iso_vg_grade", "cSt")
        oil = Oil.from_grade(grade, _real(table, "oil", "viscosity_index", "", low=None), density, expansion)
    else:
        points = table["kinematic_viscosity_points_c_cst"]
        pairs_ok = isinstance(points, list) and len(points) == 2
        if not (pairs_ok and all(isinstance(p, list) and len(p) == 2 for p in points)):
            raise InputError(
                "oil.kinematic_viscosity_points_c_cst must be two [temperature degC, viscosity cSt] pairs, "
                f"got {points!r}"
            )
        field = "oil.kinematic_viscosity_points_c_cst"
        pairs = tuple(tuple(_number(v, f"{field}[{i}]") for v in p) for i, p in enumerate(points))
        oil = Oil.from_points(pairs, density, expansion)
    temperature = _real(table, "oil", "nominal_supply_temperature_c", "degC", low=None)
    oil.dynamic_viscosity_pa_s(temperature)  # range check: names the temperature
    return oil, temperature


def _bearing_viscosity(data: Mapping[str, Any], bearings: Mapping[str, Any]) -> float:
    """The bearings' nominal viscosity [Pa s]: the oil's at its nominal temperature, or given directly."""
    oil, temperature = _read_oil(data)
    if oil is None:
        return _real(bearings, "bearings", "viscosity_pa_s", "Pa s")
    if "viscosity_pa_s" in bearings:
        raise InputError(
            "give the bearings' viscosity once: bearings.viscosity_pa_s or the [oil] section "
            "(its viscosity at oil.nominal_supply_temperature_c), not both"
        )
    return oil.dynamic_viscosity_pa_s(temperature)


def _read_lubrication(data: Mapping[str, Any]) -> Lubrication:
    table = _table(data, "lubrication")
    low = _real(table, "lubrication", "table_min_fraction_of_threshold", "")
    high = _real(table, "lubrication", "table_max_fraction_of_threshold", "")
    if high <= low:
        raise InputError(
            "lubrication.table_max_fraction_of_threshold must exceed "
            f"table_min_fraction_of_threshold ({low:g}), got {high:g}"
        )
    if "nominal_flowrate_ml_min" not in table and "nominal_supply_pressure_bar" not in table:
        raise InputError(
            "[lubrication] needs nominal_flowrate_ml_min or nominal_supply_pressure_bar (the flowrate is "
            "then computed at that groove pressure)"
        )
    pressure = math.nan
    if "nominal_supply_pressure_bar" in table:
        pressure = _real(table, "lubrication", "nominal_supply_pressure_bar", "bar", strict=False) * 1e5
    flowrate = math.nan
    if "nominal_flowrate_ml_min" in table:
        flowrate = _real(table, "lubrication", "nominal_flowrate_ml_min", "ml/min") / 1e6 / 60.0
    return Lubrication(
        nominal_supply_pressure_pa=pressure,
        nominal_flowrate_m3_s=flowrate,
        table_min_fraction_of_threshold=low,
        table_max_fraction_of_threshold=high,
        nominal_flowrate_computed=math.isnan(flowrate),
    )


_COMPUTED_FLOWRATES: dict[tuple[str, str], float] = {}
"""Nominal flowrates computed from the supply pressure in this process, by (file, file text)."""


def nominal_flowrate_from_pressure(machine: Machine) -> float:
    """The steady supply flowrate [m^3/s] at the machine's nominal groove pressure, nominal speed and the
    first bearing's static load (the paper defines its nominal flowrate so, from a 0.5 bar groove pressure).

    One steady p-theta solve on the production mesh (about a second); every bearing of a machine file
    shares the geometry, and with ``load_split = "equal"`` the load too.
    """
    from .bearing.equilibrium import static_equilibrium
    from .bearing.grid import PRODUCTION_MESH
    from .bearing.supply import SupplyPressure
    from .rotor.assembly import Rotor

    load = float(Rotor.from_machine(machine).bearing_static_loads_n[0])
    supply = SupplyPressure(machine.lubrication.nominal_supply_pressure_pa)
    equilibrium = static_equilibrium(machine.bearing, load, machine.nominal_speed_hz, supply, PRODUCTION_MESH)
    return float(equilibrium.supply_flow_m3_s)


def _with_nominal_flowrate(machine: Machine, key: tuple[str, str]) -> Machine:
    if not machine.lubrication.nominal_flowrate_computed:
        return machine
    if key not in _COMPUTED_FLOWRATES:
        _COMPUTED_FLOWRATES[key] = nominal_flowrate_from_pressure(machine)
    lubrication = replace(machine.lubrication, nominal_flowrate_m3_s=_COMPUTED_FLOWRATES[key])
    return replace(machine, lubrication=lubrication)


def machine_from_dict(data: Mapping[str, Any], source_path: Path | str = "<dict>") -> Machine:
    """Validate a parsed machine file and return the :class:`Machine` in SI units.

    Raises :class:`InputError` naming the offending field for any missing, non-numeric, negative
    or inconsistent value. A ``[lubrication]`` table without ``nominal_flowrate_ml_min`` gets the flowrate
    computed at ``nominal_supply_pressure_bar`` (:func:`nominal_flowrate_from_pressure`).
    """
    head = _table(data, "machine")
    name = head.get("name", Path(str(source_path)).stem)
    if not isinstance(name, str):
        raise InputError(f"machine.name must be text, got {name!r}")
    mat = _table(data, "material")
    material = Material(
        youngs_modulus_pa=_real(mat, "material", "youngs_modulus_pa", "Pa"),
        poisson_ratio=_real(mat, "material", "poisson_ratio", "", low=-1.0, high=0.5),
        density_kg_m3=_real(mat, "material", "density_kg_m3", "kg/m^3"),
    )
    shaft = _table(data, "shaft")
    lengths = _positive_array(shaft, "shaft", "element_length_mm", "mm") / 1e3
    diameters = _positive_array(shaft, "shaft", "element_diameter_mm", "mm") / 1e3
    if lengths.size != diameters.size:
        raise InputError(
            f"shaft.element_length_mm has {lengths.size} entries but shaft.element_diameter_mm "
            f"has {diameters.size}: give one length and one diameter per element"
        )
    n_nodes = lengths.size + 1
    unb = _table(data, "unbalance")
    unbalance = Unbalance(
        node=_node(_get(unb, "unbalance", "node"), "unbalance.node", n_nodes),
        iso_grade_m_s=_real(unb, "unbalance", "iso_grade_mm_s", "mm/s", strict=False) / 1e3,
        phase_rad=math.radians(_real(unb, "unbalance", "phase_deg", "deg", low=None)),
    )
    bearing_nodes, bearing, load_split = _read_bearings(data, diameters, n_nodes)
    oil, oil_temperature = _read_oil(data)
    damping = data.get("rotor_damping", {})
    if not isinstance(damping, Mapping):
        raise InputError("[rotor_damping] must be a table")
    beta = 0.0
    if "stiffness_proportional_s" in damping:
        beta = _real(damping, "rotor_damping", "stiffness_proportional_s", "s", strict=False)
    machine = Machine(
        name=name,
        source_path=Path(str(source_path)),
        nominal_speed_hz=_real(head, "machine", "nominal_speed_hz", "Hz"),
        gravity_m_s2=_real(head, "machine", "gravity_m_s2", "m/s^2", strict=False),
        material=material,
        element_lengths_m=_frozen(lengths),
        element_diameters_m=_frozen(diameters),
        discs=_read_discs(data, diameters, n_nodes),
        unbalance=unbalance,
        bearing_nodes=bearing_nodes,
        bearing=bearing,
        load_split=load_split,
        lubrication=_read_lubrication(data),
        structural_damping_s=beta,
        raw=data,
        oil=oil,
        nominal_oil_temperature_c=oil_temperature,
        dynamic_coefficients=require_kind(
            _table(data, "bearings").get("dynamic_coefficients", DEFAULT_KIND),
            "bearings.dynamic_coefficients",
        ),
    )
    return _with_nominal_flowrate(machine, (str(source_path), repr(sorted(data.items()))))


def load_machine(path: str | Path | None = None) -> Machine:
    """Read and validate a machine file; ``None`` reads the bundled generic turbine.

    Raises :class:`InputError` when the file is missing, is not valid TOML, or holds a missing,
    non-numeric, negative or inconsistent value (the message names the field).
    """
    source = BUNDLED_MACHINE if path is None else Path(path)
    text = read_text_file("machine file", source, "a TOML machine file such as models/turbine.toml")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"machine file {str(source)!r} is not valid TOML: {error}") from None
    with naming_file("machine file", source):
        return machine_from_dict(data, source)
