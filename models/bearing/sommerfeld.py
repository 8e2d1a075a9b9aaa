"""The scaling of the steady p-theta film: the Sommerfeld number, the Couette flow and the dimensionless row.

For a given bearing geometry (R, L, c, groove) the steady mass-conserving film scales exactly: pressure with
mu Omega (R/c)^2, force with mu Omega R L (R/c)^2, flow with the film's Couette flow q_c = Omega R c L / 2
(Lund 1987; Childs 1993, ch. 3). These are the units of the dimensionless bearing table
(:mod:`oilwatch.models.bearing.operating_table`), whose grid is uniform in ln S (:func:`sommerfeld_grid`).
"""

from __future__ import annotations

import math

import numpy as np

from ..validation import InputError
from .geometry import JournalBearing

_PAIRS = ("xx", "xy", "yx", "yy")
N_QUANTITIES = 11
"""Per node: e_x / c, e_y / c, K c / W (4, row-major), C c Omega / W (4), p_g c^2 / (mu Omega R^2)."""

ON_THRESHOLD = 1.0e-4
"""|f - 1| below which a flowrate is on the flooded threshold, where the table gives the mean of the
one-sided limits, as a direct solve does there (``equilibrium.THRESHOLD_TOLERANCE``). The table's q_t is
interpolated over S: a flowrate this close to it cannot be told from the true threshold (docs/bearings.md
gives the interpolation's accuracy), so the table does not pick one side of the jump by chance."""


def sommerfeld_number(
    bearing: JournalBearing, viscosity_pa_s: float, speed_hz: float, load_n: float
) -> float:
    """S = mu N L D (R/c)^2 / W [-] (N in rev/s)."""
    r, c = bearing.radius_m, bearing.clearance_m
    return viscosity_pa_s * speed_hz * bearing.length_m * 2.0 * r * (r / c) ** 2 / load_n


def couette_flow_m3_s(bearing: JournalBearing, speed_hz: float) -> float:
    """The film's Couette flow q_c = Omega R c L / 2 [m^3/s], the flow unit of the dimensionless table."""
    return math.pi * speed_hz * bearing.radius_m * bearing.clearance_m * bearing.length_m


def dimensionless_row(bearing: JournalBearing, row: dict, speed_hz: float, load_n: float) -> np.ndarray:
    """The 11 dimensionless quantities of one row of a
    :class:`~oilwatch.models.bearing.table.CoefficientTable`."""
    c = bearing.clearance_m
    omega = 2.0 * math.pi * speed_hz
    k = [row["stiffness_n_per_m"][p] * c / load_n for p in _PAIRS]
    d = [row["damping_n_s_per_m"][p] * c * omega / load_n for p in _PAIRS]
    p_ref = bearing.viscosity_pa_s * omega * (bearing.radius_m / c) ** 2
    return np.array(
        [row["eccentricity_x_m"] / c, row["eccentricity_y_m"] / c, *k, *d, row["supply_pressure_pa"] / p_ref]
    )


def sommerfeld_grid(centre: float, low: float, high: float, ratio: float) -> np.ndarray:
    """Nodes centre * ratio^k (uniform in ln S), from the last <= ``low`` to the first >= ``high``."""
    if not 0 < low <= high:
        raise InputError(f"Sommerfeld range must satisfy 0 < low <= high, got [{low:g}, {high:g}]")
    if ratio <= 1.0:
        raise InputError(f"Sommerfeld node ratio must be > 1, got {ratio:g}")
    k_low = math.floor(math.log(low / centre) / math.log(ratio) + 1e-9)
    k_high = math.ceil(math.log(high / centre) / math.log(ratio) - 1e-9)
    return centre * ratio ** np.arange(k_low, k_high + 1, dtype=float)
