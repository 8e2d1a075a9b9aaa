"""The coefficient table at whirl frequency = spin speed: K(Omega), C(Omega) of the transient film.

The unbalance response, the plant's linearized model and the estimator's model all see the film at
the synchronous frequency. This table holds, at each flowrate of a quasi-static table (same
equilibria, same file format, so every consumer of :class:`CoefficientTable` reads it unchanged),
the frequency-dependent coefficients of :mod:`oilwatch.models.bearing.dynamic` at omega = Omega. At the
flooded-threshold node the mean of the starved and flooded one-sided impedances is stored, as the
quasi-static table does.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable

import numpy as np

from .coefficient_kinds import COEFFICIENT_KINDS, SYNCHRONOUS
from .dynamic import synchronous_coefficients
from .equilibrium import static_equilibrium
from .geometry import JournalBearing
from .grid import Mesh
from .supply import SupplyFlow
from .table import CoefficientTable, table_row

KIND = COEFFICIENT_KINDS[SYNCHRONOUS]


def synchronous_table(
    bearing: JournalBearing,
    quasi_static: CoefficientTable,
    progress: Callable[[int, int], None] | None = None,
    command: str = "",
) -> CoefficientTable:
    """The table of ``quasi_static``'s flowrates, equilibria and mesh with K, C at omega = spin speed;
    ``progress(done, total)`` is called after each flowrate's row."""
    mesh = Mesh(**quasi_static.metadata["mesh"])
    speed = quasi_static.speed_hz
    rows = []
    for row in quasi_static.rows:
        supply = SupplyFlow(row["supply_flowrate_m3_s"])
        guess = np.array([row["eccentricity_x_m"], row["eccentricity_y_m"]])
        eq = static_equilibrium(bearing, quasi_static.load_n, speed, supply, mesh, initial_guess_m=guess)
        k, c = synchronous_coefficients(eq.film, eq.eccentricity_m, speed, supply)
        new = table_row(eq, k, c)
        if "one_sided_at_flooded_threshold" in row:
            new["at_flooded_threshold"] = "mean of the starved and flooded one-sided impedances"
        rows.append(new)
        if progress is not None:
            progress(len(rows), len(quasi_static.rows))
    meta = {key: value for key, value in quasi_static.metadata.items() if key != "provenance"}
    meta["solver"] = {
        **quasi_static.metadata.get("solver", {}),
        "coefficients": KIND,
    }
    meta["provenance"] = {
        "command": command,
        "date_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "from_table": quasi_static.metadata.get("provenance", {}),
    }
    return CoefficientTable(rows, speed, quasi_static.load_n, meta)
