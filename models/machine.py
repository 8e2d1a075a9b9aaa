"""The machine description: load and validate a rotor-bearing machine file (TOML, units in the keys).

The bundled file ``models/turbine.toml`` is the generic turbine of the paper (Tables 1-3), and
``models/compressor.toml`` a six-stage compressor on two-axial-groove bearings. Users
describe their own machines the same way: any number of shaft elements, discs and bearing nodes.
Every physical value carries its unit in its key (``element_length_mm``); :func:`load_machine`
converts to SI and returns a frozen :class:`Machine`.

Quantities that need the finite-element model (rotor mass, weight, bearing loads, unbalance moment)
are not stored here: see ``oilwatch.models.rotor.assembly.Rotor.from_machine``.

The sections' data and readers (:mod:`oilwatch.models.machine_sections`: material, discs, unbalance, bearings,
oil, lubrication) and the field readers they share (:mod:`oilwatch.models.machine_fields`) live in their own
modules.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10, where an FMU may run: it reads its machine files' parsed twins
    tomllib = None

from .bearing.coefficient_kinds import DEFAULT_KIND, require_kind
from .bearing.geometry import DOWNWARD_LOAD_RAD, JournalBearing
from .bearing.supply import ML_MIN_PER_M3_S
from .machine_fields import as_node, frozen_array, read_key, read_positive_array, read_real, read_table
from .machine_sections import (
    Disc,
    Lubrication,
    Material,
    StaticForce,
    Unbalance,
    read_bearings,
    read_discs,
    read_lubrication,
    read_oil,
    read_static_forces,
    read_static_loads,
)
from .oil import Oil
from .validation import InputError, naming_file, read_text_file

BUNDLED_MACHINE = Path(__file__).resolve().parent / "turbine.toml"
BUNDLED_MACHINES = {
    "turbine": BUNDLED_MACHINE,
    "compressor": BUNDLED_MACHINE.with_name("compressor.toml"),
}
"""The machine files that come with oilwatch, by the name a command's ``--machine`` takes: the paper's generic
turbine (the default) and a six-stage compressor on two-axial-groove bearings."""
DEFAULT_REDUCTION_CUTOFF_HZ = 500.0
"""Fixed-interface modes kept by the reduced model unless the machine file says otherwise: below 500 Hz, the
Nyquist frequency of 1 kHz sampling. A rotor whose interior modes just above it still shape the 1x response
at its running speed needs more (:func:`oilwatch.models.system.reduction_check.reduction_flow_bias`)."""


def bundled_name(path: str | Path | None) -> str | None:
    """The name of the bundled machine whose file ``path`` is (None: a file of the user's, or None): what a
    result file records, so that it names the same machine in any installation."""
    if path is None:
        return None
    resolved = Path(path).resolve()
    return next((name for name, file in BUNDLED_MACHINES.items() if file.resolve() == resolved), None)


def is_default_machine(machine: Machine) -> bool:
    """Whether ``machine`` was read from the default machine file (:data:`BUNDLED_MACHINE`, the turbine)."""
    return machine.source_path.resolve() == BUNDLED_MACHINE.resolve()


def machine_file_path(value: str | Path) -> Path:
    """The machine file ``value`` names: a bundled machine's file for its name (:data:`BUNDLED_MACHINES`)
    unless a file of that name exists here, else ``value`` as a path."""
    path = Path(value)
    bundled = BUNDLED_MACHINES.get(str(value))
    return bundled if bundled is not None and not path.is_file() else path


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
    bearings : each bearing's geometry and lubricant, in the order of ``bearing_nodes``: the ``[bearings]``
        geometry with its ``[[bearings.override]]`` for that node (:func:`read_bearings`). :attr:`bearing`
        is the one geometry of a machine whose bearings are all alike.
    load_split : how the weight is shared among bearings: "equal" (the paper: W / n_bearings each)
        or "reactions" (the support reactions of the rotor on rigid supports).
    static_loads_given_n : each bearing's static load magnitude [N] where its ``[[bearings.override]]``
        gives one (``static_load_n``: a gear mesh, a belt, a process force), None where it carries its
        share of the weight; its direction is ``bearings[i].load_angle_rad``. Empty: every bearing carries
        its share.
    static_forces : steady forces on the rotor (``[[static_forces]]``: a gear mesh, a belt, a process force);
        with them each bearing's static load, magnitude and direction, is the statics' (its weight share plus
        its support reaction to the forces), and ``bearings[i].load_angle_rad`` holds that direction.
    lubrication : nominal supply (each bearing's nominal flowrate: ``lubrication.nominal_flowrates_m3_s``;
        :meth:`shared_nominal_flowrate_m3_s` the one of a machine whose bearings' nominals are alike).
    structural_damping_s : stiffness-proportional rotor damping coefficient beta [s], C = beta K
        (0 when the file has no ``[rotor_damping]`` table).
    raw : the parsed file, for sections owned by other models.
    oil : the lubricating oil (``[oil]``), None when the file gives ``bearings.viscosity_pa_s`` instead.
    dynamic_coefficients : which linearized film coefficients the machine's tables hold and the plant's and
        estimator's models use (``bearings.dynamic_coefficients``,
        :mod:`oilwatch.models.bearing.coefficient_kinds`): "synchronous" (default) or "quasi-static".
    nominal_oil_temperature_c : oil supply temperature [degC] at which ``bearing.viscosity_pa_s`` holds
        (None without ``[oil]``).
    reduction_cutoff_hz : the reduced (Craig-Bampton) model keeps the fixed-interface modes below this
        frequency (``reduced_model.cutoff_hz``, default :data:`DEFAULT_REDUCTION_CUTOFF_HZ`).
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
    bearings: tuple[JournalBearing, ...]
    load_split: str
    lubrication: Lubrication
    structural_damping_s: float
    raw: Mapping[str, Any]
    oil: Oil | None = None
    nominal_oil_temperature_c: float | None = None
    dynamic_coefficients: str = DEFAULT_KIND
    reduction_cutoff_hz: float = DEFAULT_REDUCTION_CUTOFF_HZ
    static_loads_given_n: tuple[float | None, ...] = ()
    static_forces: tuple[StaticForce, ...] = ()

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

    @property
    def bearings_differ(self) -> bool:
        """Whether the bearings' geometries or load directions are not all the same
        (``[[bearings.override]]``): each then has tables of its own."""
        return any(b != self.bearings[0] for b in self.bearings[1:])

    @property
    def bearing(self) -> JournalBearing:
        """The one bearing geometry of a machine whose bearings are all alike; InputError when they differ,
        for what handles one geometry only (:meth:`shared_bearing`)."""
        return self.shared_bearing("this computation")

    def shared_bearing(self, feature: str) -> JournalBearing:
        """The one bearing geometry of the machine; InputError naming ``feature`` (a command or a part of
        oilwatch) when its bearings differ, since ``feature`` takes one bearing geometry."""
        if self.bearings_differ:
            raise InputError(
                f"bearings of {self.name} differ in geometry or load direction ({self.source_path.name} "
                f"has [[bearings.override]]): {feature} takes one bearing geometry; give the bearings one "
                "to run it"
            )
        return self.bearings[0]

    def shared_nominal_flowrate_m3_s(self, feature: str) -> float:
        """The one nominal supply flowrate [m^3/s] of a machine whose bearings' nominals are all alike;
        InputError naming ``feature`` when they differ, since ``feature`` runs every bearing at one flowrate
        (each bearing's: ``lubrication.nominal_flowrates_m3_s``)."""
        nominal = self.lubrication.nominal_flowrates_m3_s
        if (nominal != nominal[0]).any():
            given = " / ".join(f"{q * ML_MIN_PER_M3_S:.1f}" for q in nominal)
            raise InputError(
                f"the bearings of {self.name} have different nominal flowrates ({given} ml/min): {feature} "
                "runs every bearing at one flowrate; give them one nominal flowrate to run it"
            )
        return float(nominal[0])

    def geometry_bearing(self, index: int) -> int:
        """The number (from 1, in ``bearing_nodes`` order) of the first bearing whose geometry is that of
        bearing ``index`` (from 0): the bearing a table of that geometry is named after."""
        return 1 + next(i for i, b in enumerate(self.bearings) if b == self.bearings[index])

    @property
    def distinct_geometries(self) -> tuple[int, ...]:
        """The indices (from 0) of the first bearing of each distinct geometry, in ``bearing_nodes`` order."""
        return tuple(sorted({self.geometry_bearing(i) - 1 for i in range(len(self.bearings))}))


_COMPUTED_FLOWRATES: dict[tuple[JournalBearing, float, float, float], float] = {}
"""Nominal flowrates computed from the supply pressure in this process, by (bearing geometry, static load [N],
speed [Hz], groove pressure [Pa]): one steady solve per distinct bearing."""


def nominal_flowrate_from_pressure(machine: Machine, index: int, load_n: float) -> float:
    """The steady supply flowrate [m^3/s] of bearing ``index`` (from 0) at the machine's nominal groove
    pressure and nominal speed, with that bearing's geometry and its static load ``load_n`` [N] (the paper
    defines its nominal flowrate so, from a 0.5 bar groove pressure).

    One steady p-theta solve on the production mesh (about a second), once per distinct geometry, load,
    speed and pressure in a process.
    """
    from .bearing.equilibrium import static_equilibrium
    from .bearing.grid import PRODUCTION_MESH
    from .bearing.supply import SupplyPressure

    bearing = machine.bearings[index]
    pressure = machine.lubrication.nominal_supply_pressure_pa
    key = (bearing, float(load_n), machine.nominal_speed_hz, pressure)
    if key not in _COMPUTED_FLOWRATES:
        supply = SupplyPressure(pressure)
        equilibrium = static_equilibrium(
            bearing, float(load_n), machine.nominal_speed_hz, supply, PRODUCTION_MESH
        )
        _COMPUTED_FLOWRATES[key] = float(equilibrium.supply_flow_m3_s)
    return _COMPUTED_FLOWRATES[key]


def _with_nominal_flowrates(machine: Machine) -> Machine:
    """``machine`` with the nominal flowrate of each bearing the file gives none for solved at the supply
    pressure (:func:`nominal_flowrate_from_pressure`)."""
    computed = machine.lubrication.nominal_flowrates_computed
    if not any(computed):
        return machine
    from .rotor.assembly import Rotor

    loads = Rotor.from_machine(machine).bearing_static_loads_n
    flowrates = [
        nominal_flowrate_from_pressure(machine, i, loads[i]) if solve else float(given)
        for i, (solve, given) in enumerate(
            zip(computed, machine.lubrication.nominal_flowrates_m3_s, strict=True)
        )
    ]
    lubrication = replace(machine.lubrication, nominal_flowrates_m3_s=frozen_array(flowrates))
    return replace(machine, lubrication=lubrication)


def _with_static_load_directions(machine: Machine) -> Machine:
    """``machine`` with each bearing's load direction the statics' when the file gives ``[[static_forces]]``
    (:attr:`Rotor.bearing_load_angles_rad`, solved with the forces); the file then gives no bearing's load
    itself."""
    if not machine.static_forces:
        return machine
    given = [i for i, load in enumerate(machine.static_loads_given_n) if load is not None]
    turned = [i for i, b in enumerate(machine.bearings) if b.load_angle_rad != DOWNWARD_LOAD_RAD]
    if given or turned:
        raise InputError(
            "[[static_forces]] make each bearing's static load the statics': give them, or a bearing's "
            f"load (static_load_n, load_angle_deg: bearing {(given or turned)[0] + 1}), not both"
        )
    from .rotor.assembly import Rotor

    angles = Rotor.from_machine(machine).bearing_load_angles_rad
    bearings = tuple(
        replace(b, load_angle_rad=float(a)) for b, a in zip(machine.bearings, angles, strict=True)
    )
    return replace(machine, bearings=bearings)


def machine_from_dict(data: Mapping[str, Any], source_path: Path | str = "<dict>") -> Machine:
    """Validate a parsed machine file and return the :class:`Machine` in SI units.

    Raises :class:`InputError` naming the offending field for any missing, non-numeric, negative
    or inconsistent value. A bearing whose nominal flowrate neither its ``[[bearings.override]]`` nor
    ``[lubrication]`` gives (``nominal_flowrate_ml_min``) gets it computed at ``nominal_supply_pressure_bar``
    with its own geometry and static load (:func:`nominal_flowrate_from_pressure`).
    """
    head = read_table(data, "machine")
    name = head.get("name", Path(str(source_path)).stem)
    if not isinstance(name, str):
        raise InputError(f"machine.name must be text, got {name!r}")
    mat = read_table(data, "material")
    material = Material(
        youngs_modulus_pa=read_real(mat, "material", "youngs_modulus_pa", "Pa"),
        poisson_ratio=read_real(mat, "material", "poisson_ratio", "", low=-1.0, high=0.5),
        density_kg_m3=read_real(mat, "material", "density_kg_m3", "kg/m^3"),
    )
    shaft = read_table(data, "shaft")
    lengths = read_positive_array(shaft, "shaft", "element_length_mm", "mm") / 1e3
    diameters = read_positive_array(shaft, "shaft", "element_diameter_mm", "mm") / 1e3
    if lengths.size != diameters.size:
        raise InputError(
            f"shaft.element_length_mm has {lengths.size} entries but shaft.element_diameter_mm "
            f"has {diameters.size}: give one length and one diameter per element"
        )
    n_nodes = lengths.size + 1
    unb = read_table(data, "unbalance")
    unbalance = Unbalance(
        node=as_node(read_key(unb, "unbalance", "node"), "unbalance.node", n_nodes),
        iso_grade_m_s=read_real(unb, "unbalance", "iso_grade_mm_s", "mm/s", strict=False) / 1e3,
        phase_rad=math.radians(read_real(unb, "unbalance", "phase_deg", "deg", low=None)),
    )
    bearing_nodes, bearings, load_split = read_bearings(data, diameters, n_nodes)
    oil, oil_temperature = read_oil(data)
    damping = data.get("rotor_damping", {})
    if not isinstance(damping, Mapping):
        raise InputError("[rotor_damping] must be a table")
    beta = 0.0
    if "stiffness_proportional_s" in damping:
        beta = read_real(damping, "rotor_damping", "stiffness_proportional_s", "s", strict=False)
    reduced_model = data.get("reduced_model", {})
    if not isinstance(reduced_model, Mapping):
        raise InputError("[reduced_model] must be a table")
    cutoff = DEFAULT_REDUCTION_CUTOFF_HZ
    if "cutoff_hz" in reduced_model:
        cutoff = read_real(reduced_model, "reduced_model", "cutoff_hz", "Hz")
    machine = Machine(
        name=name,
        source_path=Path(str(source_path)),
        nominal_speed_hz=read_real(head, "machine", "nominal_speed_hz", "Hz"),
        gravity_m_s2=read_real(head, "machine", "gravity_m_s2", "m/s^2", strict=False),
        material=material,
        element_lengths_m=frozen_array(lengths),
        element_diameters_m=frozen_array(diameters),
        discs=read_discs(data, diameters, n_nodes),
        unbalance=unbalance,
        bearing_nodes=bearing_nodes,
        bearings=bearings,
        load_split=load_split,
        lubrication=read_lubrication(data, bearing_nodes),
        structural_damping_s=beta,
        raw=data,
        oil=oil,
        nominal_oil_temperature_c=oil_temperature,
        dynamic_coefficients=require_kind(
            read_table(data, "bearings").get("dynamic_coefficients", DEFAULT_KIND),
            "bearings.dynamic_coefficients",
        ),
        reduction_cutoff_hz=cutoff,
        static_loads_given_n=read_static_loads(data, bearing_nodes),
        static_forces=read_static_forces(data, n_nodes),
    )
    return _with_nominal_flowrates(_with_static_load_directions(machine))


def load_machine(path: str | Path | None = None) -> Machine:
    """Read and validate a machine file; ``None`` reads the bundled generic turbine, and the name of a
    bundled machine (:data:`BUNDLED_MACHINES`) its file.

    Raises :class:`InputError` when the file is missing, is not valid TOML, or holds a missing,
    non-numeric, negative or inconsistent value (the message names the field).
    """
    source = BUNDLED_MACHINE if path is None else machine_file_path(path)
    text = read_text_file("machine file", source, "a TOML machine file such as models/turbine.toml")
    data = _parsed(source, text)
    with naming_file("machine file", source):
        return machine_from_dict(data, source)


PARSED_TWIN_SUFFIX = ".parsed.json"
"""A machine file's parsed twin (``turbine.toml`` -> ``turbine.toml.parsed.json``): its data as JSON with
the SHA-256 of the text it was parsed from. An FMU's build writes one beside every machine file it bundles
(:func:`write_parsed_twin`), so that the FMU runs in a Python 3.10 environment, whose standard library has
no TOML reader (``tomllib`` is 3.11's)."""


def _text_digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _twin_path(source: Path) -> Path:
    return source.with_name(source.name + PARSED_TWIN_SUFFIX)


def _parsed(source: Path, text: str) -> dict:
    """The data of the machine file ``source`` whose text is ``text``: parsed by ``tomllib``, or without it
    (Python 3.10) read from its parsed twin when the twin is of this very text."""
    if tomllib is not None:
        try:
            return tomllib.loads(text)
        except tomllib.TOMLDecodeError as error:
            raise InputError(f"machine file {str(source)!r} is not valid TOML: {error}") from None
    try:
        stored = json.loads(_twin_path(Path(source)).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        stored = None
    if not isinstance(stored, dict) or stored.get("sha256") != _text_digest(text):
        version = f"{sys.version_info.major}.{sys.version_info.minor}"
        raise InputError(
            f"machine file {str(source)!r}: reading TOML needs Python 3.11 or newer (tomllib), this is "
            f"Python {version}; run with 3.11 or newer, or build the FMU with this machine file (its build "
            "stores the file parsed)"
        )
    return stored["data"]


def write_parsed_twin(path: str | Path) -> Path:
    """Write the parsed twin of the TOML machine file ``path`` (:data:`PARSED_TWIN_SUFFIX`) and return its
    path. InputError naming the file when it is not valid TOML or holds a value JSON cannot (a date)."""
    source = Path(path)
    text = read_text_file("machine file", source, "a TOML machine file such as models/turbine.toml")
    data = _parsed(source, text)
    try:
        body = json.dumps({"sha256": _text_digest(text), "data": data})
    except TypeError as error:
        raise InputError(
            f"machine file {str(source)!r}: a value is neither a number, text, a list nor a table ({error})"
        ) from None
    twin = _twin_path(source)
    twin.write_text(body + "\n", encoding="utf-8")
    return twin
