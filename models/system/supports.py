"""The fluid-film bearings as linear supports (K, C per bearing) for the rotor's modal analyses.

At a speed with a quasi-static flowrate table (``oilwatch bearing-table``) the coefficients come from it at
any flowrates in its range; at other speeds they come from the speed sweep (``oilwatch speed-sweep``),
which holds the nominal flowrate only. Anything else is an error that says which table to compute.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from ..bearing.coefficient_kinds import QUASI_STATIC
from ..machine import Machine
from ..rotor.assembly import Rotor
from ..rotor.supports import LinearBearing
from ..validation import InputError
from .factory import flowrate_tables_exist, load_speed_sweeps, load_tables, table_command
from .speed_sweep import SpeedSweep

NOMINAL_RTOL = 1e-9


def fluid_film_bearings(
    machine: Machine, rotor: Rotor, speed_hz: float, flowrates_m3_s: Sequence[float]
) -> list[LinearBearing]:
    """Linearized fluid-film bearings at ``speed_hz`` [Hz] and the bearings' supply flowrates [m^3/s]."""
    if len(flowrates_m3_s) != len(rotor.bearing_nodes):
        raise InputError(
            f"need one flowrate per bearing ({len(rotor.bearing_nodes)}), got {len(flowrates_m3_s)}"
        )
    # The modes' own coefficients: quasi-static (constant synchronous ones are right for the 1x orbit only,
    # and destabilize the free modes: oilwatch.models.system.rotor_bearing).
    if flowrate_tables_exist(machine, speed_hz, QUASI_STATIC):
        tables = load_tables(machine, rotor, speed_hz, coefficients=QUASI_STATIC)
        coefficients = [table.evaluate(q) for table, q in zip(tables, flowrates_m3_s, strict=True)]
        return [
            LinearBearing(node, c.stiffness, c.damping)
            for node, c in zip(rotor.bearing_nodes, coefficients, strict=True)
        ]
    sweeps = load_speed_sweeps(machine, rotor)
    for q, sweep in zip(flowrates_m3_s, sweeps, strict=True):
        if abs(q - sweep.flowrate_m3_s) > NOMINAL_RTOL * sweep.flowrate_m3_s:
            raise InputError(
                f"speed_hz = {speed_hz:g} Hz has no flowrate table, and the speed sweep holds only "
                f"{sweep.flowrate_m3_s * 6e7:g} ml/min: compute one with "
                f"`{table_command(machine, speed_hz, QUASI_STATIC, None)}`"
            )
    return swept_bearings(rotor, sweeps)(speed_hz)


def fluid_film_bearings_over_speed(machine: Machine, rotor: Rotor) -> Callable[[float], list[LinearBearing]]:
    """``speed_hz -> bearings`` from the speed sweep (nominal flowrate), for Campbell diagrams."""
    return swept_bearings(rotor, load_speed_sweeps(machine, rotor))


def swept_bearings(rotor: Rotor, sweeps: Sequence[SpeedSweep]) -> Callable[[float], list[LinearBearing]]:
    """``speed_hz -> bearings`` with each bearing's coefficients interpolated from its speed sweep."""
    if len(sweeps) != len(rotor.bearing_nodes):
        raise InputError(f"need one speed sweep per bearing ({len(rotor.bearing_nodes)}), got {len(sweeps)}")

    def bearings_at(speed_hz: float) -> list[LinearBearing]:
        return [
            LinearBearing(node, *sweep.coefficients(speed_hz))
            for node, sweep in zip(rotor.bearing_nodes, sweeps, strict=True)
        ]

    return bearings_at
