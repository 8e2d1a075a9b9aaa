"""Bearing tables at the machine's instantaneous operating point (speed, oil viscosity), for the plant.

:class:`ConditionedTable` presents the dimensionless table (:mod:`oilwatch.models.bearing.operating_table`) at
one bearing load as the flowrate table the rotor-bearing system and the integrator consume (``evaluate``,
``evaluate_many``, ``flowrate_range_m3_s``), at the operating conditions last set with
:meth:`ConditionedTable.set_conditions`. :func:`operating_system` builds the full-order plant system on
such tables, so that speed and viscosity can change during a run (``oilwatch.models.system.newmark`` takes the
gyroscopic and unbalance terms to the instantaneous speed).
"""

from __future__ import annotations

import math

import numpy as np

from ..bearing.coefficient_kinds import QUASI_STATIC, table_kind
from ..bearing.operating_table import OperatingTable, operating_table_path
from ..bearing.table import BearingCoefficients
from ..machine import Machine
from ..rotor.assembly import Rotor
from ..validation import InputError, require_positive
from .factory import geometry_number, map_command
from .rotor_bearing import RotorBearingSystem


class ConditionedTable:
    """One bearing's view of the dimensionless table at its load and the current (speed, viscosity).

    ``one_sided``: the starved and the flooded nodes interpolated separately, each up to its own limit on the
    flooded threshold (:meth:`oilwatch.models.bearing.operating_table.OperatingTable.interpolate`): the jump
    of K and C there, as a direct solve has it; else (the default, the estimator's) one cubic across it."""

    def __init__(
        self,
        table: OperatingTable,
        load_n: float,
        speed_hz: float,
        viscosity_pa_s: float,
        one_sided: bool = False,
    ):
        self.table = table
        self.one_sided = bool(one_sided)
        self.load_n = require_positive("bearing load", load_n, "N")
        # "bearing" as in a flowrate table's metadata; its viscosity is the one the table was set up at.
        bearing = {
            **table.geometry,
            "viscosity_pa_s": require_positive("film viscosity", viscosity_pa_s, "Pa s"),
        }
        self.metadata = {"bearing": bearing, "mesh": table.metadata.get("mesh")}
        self.set_conditions(speed_hz, viscosity_pa_s)

    def set_conditions(self, speed_hz: float, viscosity_pa_s: float) -> None:
        """Move to another speed [Hz] and film viscosity [Pa s] (checked against the table's range)."""
        self.speed_hz = require_positive("speed", speed_hz, "Hz")
        self.viscosity_pa_s = require_positive("film viscosity", viscosity_pa_s, "Pa s")
        self._slice = self.table.at(
            self.speed_hz, self.table_viscosity_pa_s(self.viscosity_pa_s), self.load_n, self.one_sided
        )

    def table_viscosity_pa_s(self, viscosity_pa_s: float) -> float:
        """The viscosity [Pa s] the dimensionless table is read at for the film's ``viscosity_pa_s``: the same
        for the machine's own bearing."""
        return viscosity_pa_s

    @property
    def conditions(self) -> tuple[float, float]:
        """(speed [Hz], viscosity [Pa s]) the table is evaluated at."""
        return self.speed_hz, self.viscosity_pa_s

    @property
    def flowrate_range_m3_s(self) -> tuple[float, float]:
        """Flowrates [m^3/s] the table covers at the current conditions."""
        return self._slice.flowrate_range_m3_s

    @property
    def flowrates_m3_s(self) -> np.ndarray:
        """The table's flowrate nodes [m^3/s] at the current conditions (its fractions times q_t)."""
        return self.table.fraction_nodes * self._slice.flooded_threshold_m3_s

    def evaluate_many(self, q_m3_s: np.ndarray) -> np.ndarray:
        """Rows (m, 10) ``[e_x, e_y, K, C]`` (SI) at the flowrates (m,) [m^3/s]."""
        return self._slice.rows(q_m3_s)

    def evaluate(self, q_m3_s: float) -> BearingCoefficients:
        """Equilibrium and coefficients at one flowrate [m^3/s]."""
        row = self.evaluate_many(np.array([q_m3_s]))[0]
        return BearingCoefficients(row[0:2], row[2:6].reshape(2, 2), row[6:10].reshape(2, 2))


def operating_table_of(
    machine: Machine, coefficients: str | None = None, bearing_index: int = 0
) -> OperatingTable:
    """The machine's dimensionless table holding ``coefficients`` (None: the machine file's
    ``bearings.dynamic_coefficients``, "synchronous" for the turbine) of bearing ``bearing_index``'s geometry
    (from 0; :func:`oilwatch.models.system.factory.geometry_number`), checked against its geometry and
    kind."""
    kind = machine.dynamic_coefficients if coefficients is None else coefficients
    path = operating_table_path(machine.source_path, kind, geometry_number(machine, bearing_index))
    table = OperatingTable.load(path)
    if table_kind(table.metadata) != kind:
        raise InputError(
            f"dimensionless bearing table {path} holds {table_kind(table.metadata)} coefficients, not "
            f"{kind}: recompute it with `{map_command(machine, kind, bearing_index)}`"
        )
    table.check_geometry(machine.bearings[bearing_index])
    return table


def operating_tables_of(machine: Machine, coefficients: str | None = None) -> list[OperatingTable]:
    """One dimensionless table per bearing (:func:`operating_table_of`; bearings of one geometry share it)."""
    by_geometry = {i: operating_table_of(machine, coefficients, i) for i in machine.distinct_geometries}
    return [by_geometry[machine.geometry_bearing(i) - 1] for i in range(len(machine.bearings))]


def operating_system(
    machine: Machine,
    speed_hz: float,
    viscosity_pa_s: float,
    *,
    table: OperatingTable | None = None,
    unbalance_moment_kg_m: float | None = None,
    unbalance_phase_rad: float | None = None,
    coefficients: str | None = None,
) -> RotorBearingSystem:
    """The full-order rotor-bearing system on the dimensionless table, at an initial speed and viscosity.

    ``table`` None: each bearing's quasi-static table for the dynamics and, for a machine of synchronous
    ``dynamic_coefficients``, its synchronous table for the 1x response (as
    :func:`oilwatch.models.system.factory.build_system`); a given ``table`` serves both and every bearing
    (each of the geometry it was made for). ``coefficients``
    overrides the machine file's kind."""
    synchronous = None
    if table is None:
        tables = operating_tables_of(machine, QUASI_STATIC)
        kind = machine.dynamic_coefficients if coefficients is None else coefficients
        if kind != QUASI_STATIC:
            synchronous = operating_tables_of(machine, kind)
    else:
        for bearing in machine.bearings:
            table.check_geometry(bearing)
        tables = [table] * len(machine.bearings)
    rotor = Rotor.from_machine(machine)
    loads = rotor.bearing_static_loads_n
    conditions = (speed_hz, viscosity_pa_s)
    return RotorBearingSystem(
        rotor,
        [ConditionedTable(t, w, *conditions) for t, w in zip(tables, loads, strict=True)],
        speed_hz,
        None,
        unbalance_moment_kg_m,
        unbalance_phase_rad,
        machine.lubrication.nominal_flowrates_m3_s,
        None
        if synchronous is None
        else [ConditionedTable(t, w, *conditions) for t, w in zip(synchronous, loads, strict=True)],
    )


def set_operating_conditions(system: RotorBearingSystem, speed_hz: float, viscosity_pa_s: float) -> None:
    """Move every bearing table of ``system`` to (speed, viscosity); InputError when a table cannot."""
    if not all(isinstance(t, ConditionedTable) for t in system.tables):
        if math.isclose(speed_hz, system.speed_hz, rel_tol=1e-12) and all(
            math.isclose(viscosity_pa_s, t.metadata["bearing"]["viscosity_pa_s"], rel_tol=1e-9)
            for t in system.tables
        ):
            return
        raise InputError(
            "this plant's bearing tables hold one speed and viscosity: build it on the dimensionless table "
            "(`oilwatch bearing-map`) to change speed or oil temperature"
        )
    for t in system.tables + (system.synchronous_tables or ()):
        t.set_conditions(speed_hz, viscosity_pa_s)
