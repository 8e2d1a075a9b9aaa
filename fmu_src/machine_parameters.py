"""What both oilwatch FMUs share: the parameters ``machine_file``, the unbalance, the probes' mounting angle
and ``bearing_table``, and the operating-point inputs ``speed_hz`` and ``oil_temperature_c``.

Both the plant and the estimator build the same rotor-bearing system from the same parameters (the filter
must know the machine, the unbalance and the probes the plant has), so they declare, resolve and build it
here: one declaration and one description per fact. Machine facts are never start values: 0 (speed,
flowrates), -1 (unbalance), -300 (oil temperature) or -999 (probe angle: the machine file's ``[probes]``
layout, :mod:`oilwatch.models.probes`) stand for "the machine file's value", resolved at initialization from
the machine file, which is the FMU's own bundled one unless ``machine_file`` names another. The inputs' values
at initialization (their start values, settable like a parameter: ``--set plant.speed_hz=80``) are the start
speed and oil temperature. The estimator FMU also reads ``[probes]`` for the offsets' prior and drift.

Where the bundled machine lives: ``resources/oilwatch/fmu_src/machine/<stem>.toml`` and its tables in
``machine/tables/`` (written by ``oilwatch build-fmus --machine FILE``); an FMU built without that folder
uses the bundled generic turbine of its ``models`` package.
"""

from __future__ import annotations

import math
from pathlib import Path

from oilwatch.fmu_src.fmi_variables import UnitDefinition, register_unit
from oilwatch.models.machine import BUNDLED_MACHINE, Machine, load_machine
from oilwatch.models.probes import read_probes
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.rotor_bearing import RotorBearingSystem
from oilwatch.models.validation import MAX_UNBALANCE_G_MM, PHASE_RANGE_DEG, InputError

MACHINE_FOLDER = "machine"
"""Folder of the FMU's own machine file and its tables, inside the bundled ``fmu_src`` package."""

register_unit(UnitDefinition("degC", {"K": 1}, 1.0, 273.15))
NOMINAL_TEMPERATURE = -300.0
"""Value of ``oil_temperature_c`` standing for the machine's nominal oil temperature."""
MACHINE_LAYOUT = -999.0
"""Value of ``probe_angle_deg`` standing for the machine file's ``[probes]`` layout."""
PROBE_ANGLE_RANGE_DEG = (-360.0, 360.0)
OPERATING_INPUTS = (
    (
        "speed_hz",
        0.0,
        "Hz",
        0.0,
        1000.0,
        "Measured spin speed (held over each step); 0: the machine file's nominal speed. Its value at "
        "initialization is the start speed (bearing_table = 0: a flowrate table must exist for it, and the "
        "input must stay there)",
    ),
    (
        "oil_temperature_c",
        NOMINAL_TEMPERATURE,
        "degC",
        NOMINAL_TEMPERATURE,
        150.0,
        "Measured oil supply temperature (held over each step); -300: the machine file's nominal oil "
        "temperature (bundled turbine: 30.81 degC, where its oil has 0.094 Pa s)",
    ),
)
"""Real inputs both FMUs declare (the operating point): name, start, unit, min, max, description."""
MACHINE_REALS = (
    ("unbalance_g_mm", -1.0, "g.mm", -1.0, MAX_UNBALANCE_G_MM,
     "Unbalance moment at the machine's unbalance node (the plant's and the estimator's must agree); -1: "
     "the machine file's ISO grade"),
    ("unbalance_phase_deg", 0.0, "deg", *PHASE_RANGE_DEG,
     "Unbalance phase phi of Eqs. 5-6 (same in both FMUs)"),
    ("probe_angle_deg", MACHINE_LAYOUT, "deg", MACHINE_LAYOUT, PROBE_ANGLE_RANGE_DEG[1],
     "Mounting angle of each bearing's X probe, counter-clockwise from horizontal (+x), its Y probe 90 deg "
     "further (0: horizontal/vertical; 45: the API 670 pair either side of top dead centre); the positions "
     "are along the probes' axes. -999: the machine file's [probes] layout (bundled turbine: 0); else "
     "within [-360, 360] deg (same in both FMUs)"),
)  # fmt: skip
"""Real parameters both FMUs declare: name, start, unit, min, max, description."""
BEARING_TABLE_DESCRIPTION = (
    "0: the flowrate table at the start speed and nominal viscosity (speed_hz and oil_temperature_c must "
    "stay at their start values); 1: the dimensionless table, following speed_hz and oil_temperature_c "
    "(needs the machine file's [oil]; same in both FMUs)"
)


def declare_machine_parameters(slave, bearing_table_start: int = 0, bearing_table_note: str = "") -> None:
    """Declare ``machine_file``, the unbalance, probe-angle and ``bearing_table`` parameters, and the
    operating-point inputs, on a slave; ``bearing_table_start`` -1 (with ``bearing_table_note`` saying what it
    stands for) lets the slave resolve it."""
    for name, start, unit, low, high, text in MACHINE_REALS:
        slave.declare_real(
            name, "parameter", start=start, unit=unit, minimum=low, maximum=high, description=text
        )
    for name, start, unit, low, high, text in OPERATING_INPUTS:
        slave.declare_real(name, "input", start=start, unit=unit, minimum=low, maximum=high, description=text)
    slave.declare_string(
        "machine_file",
        "parameter",
        start="",
        description="Machine file (TOML); empty: the machine bundled in this FMU",
    )
    slave.declare_integer(
        "bearing_table",
        "parameter",
        start=bearing_table_start,
        minimum=min(0, bearing_table_start),
        maximum=1,
        description=BEARING_TABLE_DESCRIPTION + bearing_table_note,
    )


def probe_angle_deg(slave, machine: Machine) -> float:
    """The probes' mounting angle [deg] of a slave's ``probe_angle_deg`` (-999: the machine file's
    ``[probes]`` layout); one-line InputError outside [-360, 360] deg."""
    if slave.probe_angle_deg == MACHINE_LAYOUT:
        return read_probes(machine).angle_deg
    low, high = PROBE_ANGLE_RANGE_DEG
    if not low <= slave.probe_angle_deg <= high:
        raise InputError(
            f"probe_angle_deg must lie in [{low:g}, {high:g}] deg or be {MACHINE_LAYOUT:g} (the machine "
            f"file's [probes] layout), got {slave.probe_angle_deg:g} deg"
        )
    return float(slave.probe_angle_deg)


def require_oil(slave, machine: Machine) -> None:
    """One-line InputError when ``bearing_table = 1`` on a machine without an oil."""
    if slave.bearing_table == 1 and machine.oil is None:
        raise InputError("bearing_table = 1 needs the machine's oil ([oil] in the machine file)")


def held_operating_point(slave, machine: Machine, start: tuple[float, float | None]):
    """The operating conditions of a slave's inputs now (:func:`operating_conditions`); with
    ``bearing_table = 0`` an InputError when they left their start values ``start``."""
    conditions = operating_conditions(slave, machine)
    if slave.bearing_table == 0 and conditions != start:
        speed, temperature = conditions
        oil = "no oil" if temperature is None else f"{temperature:g} degC"
        raise InputError(
            "speed_hz and oil_temperature_c must stay at their start values with bearing_table = 0, got "
            f"{speed:g} Hz and {oil} (bearing_table = 1 follows them)"
        )
    return conditions


def operating_conditions(slave, machine: Machine) -> tuple[float, float | None]:
    """(speed [Hz], oil temperature [degC] or None for a machine without an oil) from a slave's inputs, the
    sentinels resolved from the machine file."""
    speed = slave.speed_hz if slave.speed_hz > 0.0 else machine.nominal_speed_hz
    if slave.oil_temperature_c > NOMINAL_TEMPERATURE:
        return speed, slave.oil_temperature_c
    return speed, machine.nominal_oil_temperature_c


def bundled_machine_file(resources: str | None) -> Path:
    """The machine file bundled in an FMU instance's resources folder (module docstring).

    Found through the instance's own ``resources`` path, not the module's ``__file__``: a host that loads the
    FMU twice (or two oilwatch FMUs) imports the package once, from the first extraction folder, which it
    may have deleted since, and two FMUs may bundle different machines.
    """
    if not resources:
        return BUNDLED_MACHINE
    own = Path(resources, *__name__.split(".")[:-1], MACHINE_FOLDER)
    machines = sorted(own.glob("*.toml")) if own.is_dir() else []
    if machines:
        return machines[0]
    return Path(resources, *load_machine.__module__.split(".")[:-1], BUNDLED_MACHINE.name)


def machine_of(machine_file: str, resources: str | None) -> Machine:
    """The machine of the ``machine_file`` parameter (empty: the bundled one)."""
    if machine_file and not Path(machine_file).is_file():
        raise InputError(f"machine_file: no such file: {machine_file!r}")
    return load_machine(machine_file or bundled_machine_file(resources))


def rotor_bearing_system(
    machine_file: str,
    resources: str | None,
    speed_hz: float,
    unbalance_g_mm: float,
    unbalance_phase_deg: float,
    *,
    reduced: bool,
) -> RotorBearingSystem:
    """The system of the FMU parameters: ``machine_file`` (empty: the bundled machine), ``speed_hz`` (0: the
    machine's nominal), ``unbalance_g_mm`` (negative: the machine file's ISO-grade unbalance) and
    ``unbalance_phase_deg``."""
    machine = machine_of(machine_file, resources)
    return build_system(
        machine,
        speed_hz if speed_hz > 0.0 else None,
        reduced=reduced,
        unbalance_moment_kg_m=None if unbalance_g_mm < 0.0 else unbalance_g_mm * 1e-6,
        unbalance_phase_rad=math.radians(unbalance_phase_deg),
    )
