"""Orbit sensitivity to the supply flowrates: the paper's Fig. 5 and Tables 4-5.

The paper does not define its "eccentricity" and "amplitude"; oilwatch uses, for each bearing, the steady
orbit ``r(t) = r_s + Re(X exp(i Omega t))`` of the linear model:

* eccentricity: the distance of the orbit's centre from the bearing centre, ``|r_s|`` (static eccentricity);
* amplitude X (Y): the half peak-to-peak of the horizontal (vertical) displacement, ``|X_x|`` (``|X_y|``);
* variation over an interval "a-b" (flowrate falling from a % to b % of nominal): value at b minus value at a.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .rotor_bearing import RotorBearingSystem

DEFINITIONS = {
    "eccentricity": "distance of the orbit centre (static position) from the bearing centre [um]",
    "amplitude": "half peak-to-peak of the x (or y) displacement over one revolution [um]",
    "variation": "value at the lower flowrate minus value at the higher flowrate of the interval [um]",
}

PAPER_TABLE4 = {
    "ecc_var_um_b1": [0.78, 1.22, 1.55, 1.74, 1.92],
    "ecc_var_um_b2": [0.78, 1.22, 1.55, 1.74, 1.92],
    "amp_x_var_um_b1": [-5.39, 0.95, 3.37, 3.71, 3.54],
    "amp_x_var_um_b2": [-6.84, -2.72, 2.19, 3.42, 3.79],
    "amp_y_var_um_b1": [-0.22, 6.44, 5.72, 5.77, 5.73],
    "amp_y_var_um_b2": [-1.10, 4.42, 5.70, 6.50, 6.87],
}
PAPER_TABLE5 = {
    "ecc_var_um_b1": [0.78, 1.22, 1.55, 1.74, 1.92],
    "ecc_var_um_b2": [0.00, 0.00, 0.00, 0.00, 0.00],
    "amp_x_var_um_b1": [-13.83, -13.27, 0.57, 2.84, 3.32],
    "amp_x_var_um_b2": [7.30, 10.36, 0.74, -1.32, -2.42],
    "amp_y_var_um_b1": [-5.95, -1.38, 6.13, 7.64, 8.12],
    "amp_y_var_um_b2": [5.02, 6.20, -0.40, -1.71, -2.34],
}
TABLE_PERCENTS = (100, 95, 90, 85, 80, 75)


@dataclass(frozen=True)
class Orbit:
    """Steady orbit of each bearing (SI): ``centre_m`` (nb, 2) and complex ``amplitude_m`` (nb, 2)."""

    centre_m: np.ndarray
    amplitude_m: np.ndarray

    @property
    def eccentricity_m(self) -> np.ndarray:
        """(nb,) distance of each orbit's centre from its bearing centre [m]."""
        return np.hypot(self.centre_m[:, 0], self.centre_m[:, 1])

    def trace(self, n_points: int = 181) -> np.ndarray:
        """(nb, n_points, 2) points of each closed orbit over one revolution [m]."""
        phase = np.exp(1j * np.linspace(0.0, 2.0 * np.pi, n_points))
        return self.centre_m[:, None, :] + (self.amplitude_m[:, None, :] * phase[None, :, None]).real


def steady_orbit(system: RotorBearingSystem, flowrates_m3_s: Sequence[float]) -> Orbit:
    """The steady unbalance orbit of each bearing at the flowrates."""
    centre = system.bearing_positions(system.static_coordinates(flowrates_m3_s))
    amplitude = system.bearing_positions(system.unbalance_coordinates(flowrates_m3_s))
    return Orbit(centre, amplitude)


def orbit_variation_table(
    system: RotorBearingSystem,
    nominal_m3_s: Sequence[float],
    both_bearings: bool,
    percents: Sequence[float] = TABLE_PERCENTS,
) -> list[dict]:
    """Rows of Table 4 (``both_bearings``: q1 and q2 fall together) or Table 5 (q1 falls, q2 nominal), each
    bearing's flowrate a percentage of its own nominal in ``nominal_m3_s`` (q1, q2).

    Each row: ``interval_pct`` ("100-95"), ``ecc_var_um_b1``, ``ecc_var_um_b2``, ``amp_x_var_um_b1``,
    ``amp_x_var_um_b2``, ``amp_y_var_um_b1``, ``amp_y_var_um_b2`` (see ``DEFINITIONS``).
    """
    orbits = []
    for pct in percents:
        q1 = nominal_m3_s[0] * pct / 100.0
        q2 = nominal_m3_s[1] * pct / 100.0 if both_bearings else nominal_m3_s[1]
        orbits.append(steady_orbit(system, (q1, q2)))
    rows = []
    for (high, low), (before, after) in zip(
        itertools.pairwise(percents), itertools.pairwise(orbits), strict=True
    ):
        ecc = (after.eccentricity_m - before.eccentricity_m) * 1e6
        amp = (np.abs(after.amplitude_m) - np.abs(before.amplitude_m)) * 1e6
        rows.append(
            {
                "interval_pct": f"{high:g}-{low:g}",
                "ecc_var_um_b1": float(ecc[0]),
                "ecc_var_um_b2": float(ecc[1]),
                "amp_x_var_um_b1": float(amp[0, 0]),
                "amp_x_var_um_b2": float(amp[1, 0]),
                "amp_y_var_um_b1": float(amp[0, 1]),
                "amp_y_var_um_b2": float(amp[1, 1]),
            }
        )
    return rows


def paper_rows(table: dict) -> list[dict]:
    """The paper's Table 4 or 5 in the row format of :func:`orbit_variation_table`."""
    intervals = [f"{a}-{b}" for a, b in itertools.pairwise(TABLE_PERCENTS)]
    return [
        {"interval_pct": interval, **{key: values[i] for key, values in table.items()}}
        for i, interval in enumerate(intervals)
    ]
