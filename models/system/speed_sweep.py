"""Bearing coefficients over spin speed at one supply flowrate, for the speed-dependent stability analysis.

The flowrate coefficient table is computed at one speed. The first critical speed and the instability
threshold need the film's stiffness and damping at every speed of a sweep; this module computes them at a
fixed supply flowrate (the machine's nominal one by default) and stores them, with provenance, in a JSON file
that ``oilwatch speed-sweep`` writes and ``oilwatch report`` reads.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import platform
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from ..bearing.equilibrium import coefficients_at, static_equilibrium
from ..bearing.geometry import JournalBearing
from ..bearing.grid import PRODUCTION_MESH, Mesh
from ..bearing.supply import ML_MIN_PER_M3_S, SupplyFlow
from ..validation import InputError, require_in_range, require_positive


@dataclass(frozen=True)
class SpeedSweep:
    """Equilibrium and coefficients of one bearing over speed at a fixed supply flowrate (SI units).

    Attributes
    ----------
    speeds_hz : (n,) spin speeds [Hz], increasing.
    flowrate_m3_s : the supply flowrate [m^3/s].
    load_n : the bearing load [N].
    eccentricity_m : (n, 2) equilibrium positions [m].
    stiffness : (n, 2, 2) [N/m]; damping : (n, 2, 2) [N s/m] (Lund's convention).
    provenance : how the sweep was computed (bearing geometry, mesh, squeeze model, version, date, command).
    """

    speeds_hz: np.ndarray
    flowrate_m3_s: float
    load_n: float
    eccentricity_m: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    provenance: dict

    def coefficients(self, speed_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """K and C at ``speed_hz`` by linear interpolation between sweep points; outside the sweep: error."""
        speed = require_in_range(
            "speed_hz", speed_hz, float(self.speeds_hz[0]), float(self.speeds_hz[-1]), "Hz"
        )
        k = np.empty((2, 2))
        c = np.empty((2, 2))
        for i in range(2):
            for j in range(2):
                k[i, j] = np.interp(speed, self.speeds_hz, self.stiffness[:, i, j])
                c[i, j] = np.interp(speed, self.speeds_hz, self.damping[:, i, j])
        return k, c

    def save(self, path: str | Path) -> None:
        """Write the sweep as JSON, units in the key names."""
        data = {
            "description": "journal bearing equilibrium and linearized coefficients over spin speed",
            "provenance": self.provenance,
            "flowrate_ml_min": self.flowrate_m3_s * ML_MIN_PER_M3_S,
            "load_n": self.load_n,
            "speed_hz": self.speeds_hz.tolist(),
            "eccentricity_um": (self.eccentricity_m * 1e6).tolist(),
            "stiffness_n_per_m": self.stiffness.tolist(),
            "damping_n_s_per_m": self.damping.tolist(),
        }
        Path(path).write_text(json.dumps(data, indent=1) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> SpeedSweep:
        """Read a sweep written by :meth:`save`; a missing or malformed file raises InputError."""
        try:
            data = json.loads(Path(path).read_text())
            sweep = cls(
                speeds_hz=np.asarray(data["speed_hz"], dtype=float),
                flowrate_m3_s=float(data["flowrate_ml_min"]) / ML_MIN_PER_M3_S,
                load_n=float(data["load_n"]),
                eccentricity_m=np.asarray(data["eccentricity_um"], dtype=float) * 1e-6,
                stiffness=np.asarray(data["stiffness_n_per_m"], dtype=float),
                damping=np.asarray(data["damping_n_s_per_m"], dtype=float),
                provenance=dict(data.get("provenance", {})),
            )
        except (OSError, ValueError, KeyError, TypeError) as error:
            raise InputError(f"speed sweep file {path}: cannot be read ({error})") from None
        n = sweep.speeds_hz.size
        shapes = {
            "speed_hz": (sweep.speeds_hz, (n,)),
            "eccentricity_um": (sweep.eccentricity_m, (n, 2)),
            "stiffness_n_per_m": (sweep.stiffness, (n, 2, 2)),
            "damping_n_s_per_m": (sweep.damping, (n, 2, 2)),
        }
        for key, (array, shape) in shapes.items():
            if array.shape != shape or not np.isfinite(array).all():
                raise InputError(
                    f"speed sweep file {path}: {key} must be finite numbers of shape {shape}, "
                    f"got shape {array.shape}"
                )
        if n < 2 or np.any(np.diff(sweep.speeds_hz) <= 0):
            raise InputError(f"speed sweep file {path}: speed_hz must hold at least 2 increasing speeds")
        return sweep


def compute_speed_sweep(
    bearing: JournalBearing,
    load_n: float,
    speeds_hz: np.ndarray,
    flowrate_m3_s: float,
    mesh: Mesh | None = None,
    command: str = "",
    progress: Callable[[int, int], None] | None = None,
    squeeze: str = "full-film",
) -> SpeedSweep:
    """Equilibrium and coefficients at each speed of ``speeds_hz`` [Hz] for supply flowrate [m^3/s].

    ``squeeze`` selects the squeeze-term model of the film solver (see ``oilwatch.models.bearing.film``);
    ``progress(done, total)`` is called after each speed.
    """
    speeds = np.asarray(speeds_hz, dtype=float)
    if speeds.ndim != 1 or speeds.size < 2 or np.any(np.diff(speeds) <= 0):
        raise InputError("speeds_hz must hold at least 2 increasing speeds")
    for speed in speeds:
        require_positive("speed_hz", speed, "Hz")
    mesh = mesh or PRODUCTION_MESH
    supply = SupplyFlow(flowrate_m3_s)
    positions, stiffness, damping = [], [], []
    guess = None
    for done, speed in enumerate(speeds):
        if progress is not None:
            progress(done, speeds.size)
        eq = static_equilibrium(bearing, load_n, speed, supply, mesh, squeeze=squeeze, initial_guess_m=guess)
        k, c = coefficients_at(bearing, eq, speed, supply, mesh, squeeze=squeeze)
        guess = eq.eccentricity_m
        positions.append(eq.eccentricity_m)
        stiffness.append(k)
        damping.append(c)
    provenance = {
        "command": command,
        "bearing": dataclasses.asdict(bearing),
        "oilwatch_version": __version__,
        "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "mesh": {"n_circ": mesh.n_circ, "n_axial": mesh.n_axial},
        "squeeze": squeeze,
        "python": platform.python_version(),
    }
    return SpeedSweep(
        speeds,
        float(flowrate_m3_s),
        float(load_n),
        np.array(positions),
        np.array(stiffness),
        np.array(damping),
        provenance,
    )
