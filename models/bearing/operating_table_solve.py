"""Solving the dimensionless bearing table: the p-theta equilibrium and coefficients over (ln S, f).

At one speed and load every Sommerfeld node is reached by the viscosity, mu = S W / (N L D (R/c)^2)
(:mod:`oilwatch.models.bearing.sommerfeld`); at each node the flooded threshold q_t and
:func:`oilwatch.models.bearing.table.compute_table` at the flowrates f q_t (the project's conventions:
held-partition stiffness, default full-film squeeze, mean of the one-sided limits on f = 1) give the node's
row. On f = 1 the table also keeps the two one-sided limits (starved and flooded), between which K and C
jump, so that its interpolation never crosses the kink. A long run keeps its finished nodes in a checkpoint
file, so a stopped run resumes; the nodes of an earlier table with the same grid can be reused (``reuse``).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import json
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..validation import InputError, require_positive
from .coefficient_kinds import QUASI_STATIC, SYNCHRONOUS, table_kind
from .dynamic import synchronous_one_sided
from .equilibrium import one_sided_coefficients, static_equilibrium
from .geometry import JournalBearing
from .grid import PRODUCTION_MESH, Mesh
from .operating_table import OperatingTable
from .sommerfeld import N_QUANTITIES, couette_flow_m3_s, dimensionless_row, sommerfeld_number
from .supply import SupplyFlow
from .table import compute_table, flooded_threshold, table_row


def compute_operating_table(
    bearing: JournalBearing,
    load_n: float,
    speed_hz: float,
    sommerfeld_nodes,
    fraction_nodes,
    mesh: Mesh | None = None,
    progress: Callable[[int], None] | None = None,
    provenance: dict | None = None,
    coefficients: str = QUASI_STATIC,
    checkpoint: str | Path | None = None,
    reuse: OperatingTable | None = None,
) -> OperatingTable:
    """Solve the dimensionless table at ``speed_hz`` and ``load_n``, setting each S by the viscosity.

    At each Sommerfeld node the viscosity is mu = S W / (N L D (R/c)^2); the flooded threshold and
    then :func:`~oilwatch.models.bearing.table.compute_table` at the flowrates f q_t give the node's row.
    ``coefficients`` is the kind of K, C (:data:`~oilwatch.models.bearing.table.COEFFICIENT_KINDS`): at whirl
    frequency = spin speed the whirl ratio is 1, so the synchronous K c / W and C c Omega / W are functions
    of (S, f) too. ``progress(n)`` is called after each solved point (n = 1) and each threshold (n = 0).
    ``checkpoint``: a JSON file that holds every finished Sommerfeld node; a stopped run started again
    with the same file, nodes, mesh and kind resumes after the last finished node. ``reuse``: an earlier
    table of the same nodes, mesh, kind, speed and load whose node values are taken as they are; only what
    it lacks (the one-sided limits on f = 1 of a table made before they were kept) is solved.
    """
    mesh = PRODUCTION_MESH if mesh is None else mesh
    load = require_positive("load_n", load_n, "N")
    speed = require_positive("speed_hz", speed_hz, "Hz")
    s_nodes = np.asarray(sommerfeld_nodes, dtype=float)
    f_nodes = np.asarray(fraction_nodes, dtype=float)
    q_c = couette_flow_m3_s(bearing, speed)
    unit_viscosity = sommerfeld_number(bearing, 1.0, speed, load)
    values = np.empty((s_nodes.size, f_nodes.size, N_QUANTITIES))
    threshold = np.empty(s_nodes.size)
    sides = np.empty((s_nodes.size, 2, N_QUANTITIES))
    on_threshold = int(np.flatnonzero(np.isclose(f_nodes, 1.0, rtol=0, atol=1e-12))[0])
    started = time.perf_counter()
    resume = _Checkpoint(checkpoint, s_nodes, f_nodes, mesh, coefficients, speed, load)
    if reuse is not None:
        resume.seed(reuse)
    for i, s in enumerate(s_nodes):
        at_s = dataclasses.replace(bearing, viscosity_pa_s=float(s / unit_viscosity))
        if resume.has(i):
            threshold[i], values[i], sides[i] = resume.node(i)
            if np.isnan(sides[i]).any():
                sides[i] = threshold_sides(
                    at_s, load, speed, threshold[i] * q_c, mesh, coefficients, values[i, on_threshold]
                )
                resume.store(i, threshold[i], values[i], sides[i], resume.metadata)
            if progress is not None:
                progress(0)
                progress(f_nodes.size)
            continue
        q_t, _ = flooded_threshold(at_s, load, speed, mesh)
        threshold[i] = q_t / q_c
        if progress is not None:
            progress(0)
        flows = q_t * f_nodes
        flows[np.isclose(f_nodes, 1.0, rtol=0, atol=1e-12)] = q_t  # exactly on the threshold
        table = compute_table(
            at_s, load, speed, flows, mesh, flooded_threshold_m3_s=q_t, coefficients=coefficients
        )
        for j, row in enumerate(table.rows):
            values[i, j] = dimensionless_row(at_s, row, speed, load)
            if progress is not None:
                progress(1)
        sides[i] = threshold_sides(at_s, load, speed, q_t, mesh, coefficients, values[i, on_threshold])
        resume.store(i, threshold[i], values[i], sides[i], table.metadata)
    meta = {k: v for k, v in resume.metadata.items() if k in ("mesh", "solver")}
    meta["solver"] = {
        **meta["solver"],
        "per_node": "models.bearing.table.compute_table at mu = S W / (N L D (R/c)^2)",
    }
    meta.update(
        {
            "quantities": "values[i][j] at (S_i, f_j): e_x/c, e_y/c, K c/W (xx, xy, yx, yy), "
            "C c Omega/W (xx, xy, yx, yy), groove pressure c^2/(mu Omega R^2); threshold_sides[i] the same "
            "quantities on f = 1 at S_i as the starved and the flooded one-sided limits",
            "solved_at": {"speed_hz": speed, "load_n": load},
            "interpolation": "tensor-product Catmull-Rom in (ln S, f), ghost nodes linearly extrapolated, "
            "separately over the starved (f <= 1) and the flooded (f >= 1) nodes, each ending on its "
            "one-sided limit on f = 1; q_t/q_c in ln-ln over S",
            "provenance": {
                **resume.metadata["provenance"],
                "compute_s": round(time.perf_counter() - started, 1),
                **(provenance or {}),
            },
        }
    )
    return OperatingTable(s_nodes, f_nodes, values, threshold, dataclasses.asdict(bearing), meta, sides)


def threshold_sides(
    bearing: JournalBearing,
    load_n: float,
    speed_hz: float,
    q_t: float,
    mesh: Mesh,
    coefficients: str,
    on_threshold: np.ndarray,
) -> np.ndarray:
    """(2, 11) dimensionless rows on the flooded threshold q_t: the starved and the flooded one-sided limits
    of the coefficients (the equilibrium and groove pressure are the same on both sides). ``on_threshold`` is
    the node's row on f = 1, whose equilibrium starts the solve."""
    supply = SupplyFlow(q_t)
    c = bearing.clearance_m
    guess = np.asarray(on_threshold[0:2]) * c
    eq = static_equilibrium(bearing, load_n, speed_hz, supply, mesh, initial_guess_m=guess)
    if coefficients == SYNCHRONOUS:
        limits = synchronous_one_sided(eq.film, eq.eccentricity_m, speed_hz)
    else:
        limits = one_sided_coefficients(bearing, eq, speed_hz, supply, mesh)
    return np.array(
        [
            dimensionless_row(bearing, table_row(eq, *limits[side]), speed_hz, load_n)
            for side in ("starved", "flooded")
        ]
    )


class _Checkpoint:
    """The finished Sommerfeld nodes of :func:`compute_operating_table`, kept in a JSON file (or nowhere)."""

    def __init__(self, path, s_nodes, f_nodes, mesh: Mesh, coefficients: str, speed_hz: float, load_n: float):
        self.path = None if path is None else Path(path)
        self.key = {
            "sommerfeld_nodes": s_nodes.tolist(),
            "fraction_of_threshold_nodes": f_nodes.tolist(),
            "mesh": [mesh.n_circ, mesh.n_axial],
            "coefficients": coefficients,
            "speed_hz": speed_hz,
            "load_n": load_n,
        }
        self.nodes: dict[str, dict] = {}
        self.metadata: dict = {}
        if self.path is not None and self.path.is_file():
            try:
                data = json.loads(self.path.read_text())
            except json.JSONDecodeError as error:
                raise InputError(f"checkpoint {self.path} is not valid JSON: {error}") from None
            if data.get("key") != self.key:
                raise InputError(
                    f"checkpoint {self.path} belongs to another table (nodes, mesh, kind, speed or load "
                    "differ): remove it or choose another --out"
                )
            self.nodes, self.metadata = data["nodes"], data["metadata"]

    def has(self, i: int) -> bool:
        return str(i) in self.nodes

    def node(self, i: int) -> tuple[float, np.ndarray, np.ndarray]:
        """(q_t / q_c, values, threshold sides: NaN where the node has none)."""
        entry = self.nodes[str(i)]
        values = np.asarray(entry["values"])
        sides = np.asarray(entry.get("threshold_sides", np.full((2, values.shape[1]), np.nan)), dtype=float)
        return entry["threshold_flow_ratio"], values, sides

    def seed(self, table: OperatingTable) -> None:
        """Take the nodes of ``table`` (same nodes, mesh, kind, speed and load) as finished."""
        key = {
            "sommerfeld_nodes": table.sommerfeld_nodes.tolist(),
            "fraction_of_threshold_nodes": table.fraction_nodes.tolist(),
            "mesh": [table.metadata.get("mesh", {}).get(k) for k in ("n_circ", "n_axial")],
            "coefficients": table_kind(table.metadata),
            "speed_hz": table.metadata.get("solved_at", {}).get("speed_hz"),
            "load_n": table.metadata.get("solved_at", {}).get("load_n"),
        }
        numbers = [k for k in self.key if k != "coefficients"]
        differ = [k for k in numbers if key[k] is None or not np.allclose(key[k], self.key[k], rtol=1e-12)]
        if key["coefficients"] != self.key["coefficients"]:
            differ.append("coefficients")
        if differ:
            raise InputError(f"the table to reuse differs in {', '.join(differ)}: it cannot be reused")
        self.metadata = {k: table.metadata[k] for k in ("mesh", "solver") if k in table.metadata}
        earlier = table.metadata.get("provenance", {})
        self.metadata["provenance"] = {
            "date_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
            "node_values_from": {
                k: earlier[k] for k in ("date_utc", "compute_s", "command_line") if k in earlier
            },
        }
        for i in range(table.sommerfeld_nodes.size):
            if not self.has(i):
                sides = None if table.threshold_sides is None else table.threshold_sides[i].tolist()
                self.nodes[str(i)] = {
                    "threshold_flow_ratio": float(table.threshold_flow_ratio[i]),
                    "values": table.values[i].tolist(),
                    **({} if sides is None else {"threshold_sides": sides}),
                }

    def store(self, i: int, threshold: float, values: np.ndarray, sides: np.ndarray, metadata: dict) -> None:
        self.nodes[str(i)] = {
            "threshold_flow_ratio": float(threshold),
            "values": values.tolist(),
            "threshold_sides": sides.tolist(),
        }
        self.metadata = metadata
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            text = json.dumps({"key": self.key, "nodes": self.nodes, "metadata": metadata})
            temporary = self.path.with_name(self.path.name + ".tmp")
            temporary.write_text(text)
            temporary.replace(self.path)
