"""How far the dimensionless table is from a direct solve at one operating point.

The measures are those the table is held to: the largest error of the eight stiffness entries relative to
the largest stiffness entry (and the same for damping), and the relative error of the eccentricity ratio.
The direct solve takes the coefficients of the table's own kind (quasi-static or synchronous,
:mod:`oilwatch.models.bearing.coefficient_kinds`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .coefficient_kinds import SYNCHRONOUS, table_kind
from .dynamic import synchronous_coefficients
from .equilibrium import coefficients_at, static_equilibrium
from .geometry import JournalBearing
from .grid import Mesh
from .operating_table import OperatingTable
from .supply import SupplyFlow
from .table import flooded_threshold


@dataclass(frozen=True)
class TableError:
    """Table minus direct solve at (speed_hz, viscosity_pa_s, load_n, fraction of q_t).

    stiffness, damping: max |table - direct| over the four entries / max |direct entry| [-];
    eccentricity_ratio: |table - direct| / direct [-]; direct_eccentricity_ratio, flooded_threshold_m3_s.
    """

    speed_hz: float
    viscosity_pa_s: float
    load_n: float
    fraction: float
    stiffness: float
    damping: float
    eccentricity_ratio: float
    direct_eccentricity_ratio: float
    flooded_threshold_m3_s: float


def table_error(
    table: OperatingTable,
    bearing: JournalBearing,
    speed_hz: float,
    viscosity_pa_s: float,
    load_n: float,
    fraction: float,
    mesh: Mesh,
    one_sided: bool = False,
) -> TableError:
    """Solve the point directly (q = fraction * q_t; exactly q_t for fraction 1) and compare with the table
    (``one_sided``: interpolated on each side of the flooded threshold separately, see
    :meth:`OperatingTable.interpolate`)."""
    return table_errors(table, bearing, speed_hz, viscosity_pa_s, load_n, fraction, mesh, (one_sided,))[0]


def table_errors(
    table: OperatingTable,
    bearing: JournalBearing,
    speed_hz: float,
    viscosity_pa_s: float,
    load_n: float,
    fraction: float,
    mesh: Mesh,
    sides: tuple[bool, ...],
) -> tuple[TableError, ...]:
    """:func:`table_error` for each interpolation of ``sides`` (``one_sided`` False, True) against one
    direct solve."""
    at = dataclasses.replace(bearing, viscosity_pa_s=viscosity_pa_s)
    q_t, _ = flooded_threshold(at, load_n, speed_hz, mesh)
    q = q_t if fraction == 1.0 else fraction * q_t
    supply = SupplyFlow(q)
    eq = static_equilibrium(at, load_n, speed_hz, supply, mesh)
    if table_kind(table.metadata) == SYNCHRONOUS:
        stiffness, damping = synchronous_coefficients(eq.film, eq.eccentricity_m, speed_hz, supply)
    else:
        stiffness, damping = coefficients_at(at, eq, speed_hz, supply, mesh)
    errors = []
    for one_sided in sides:
        point = table.evaluate(speed_hz, viscosity_pa_s, load_n, q, one_sided)
        k, c = point.coefficients.stiffness, point.coefficients.damping
        errors.append(
            TableError(
                speed_hz,
                viscosity_pa_s,
                load_n,
                fraction,
                stiffness=float(np.max(np.abs(k - stiffness)) / np.max(np.abs(stiffness))),
                damping=float(np.max(np.abs(c - damping)) / np.max(np.abs(damping))),
                eccentricity_ratio=abs(point.eccentricity_ratio - eq.eccentricity_ratio)
                / eq.eccentricity_ratio,
                direct_eccentricity_ratio=eq.eccentricity_ratio,
                flooded_threshold_m3_s=q_t,
            )
        )
    return tuple(errors)
