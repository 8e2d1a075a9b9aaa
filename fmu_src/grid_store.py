"""The estimator's flowrate grid stored in the FMU's resources folder: computed once, loaded afterwards.

Most of the estimator's initialization is its flowrate grid
(:class:`oilwatch.models.system.flowrate_grid.FlowrateGrid`: one matrix exponential per node): with
``bearing_table = 0`` the model's own, with ``bearing_table = 1`` the operating model's reference grid on the
dimensionless table (its key says which). The grid
depends only on the machine (its file and tables), the parameters that build the system (speed, unbalance
and its phase), the sample period and the code, so an instance that finds a grid stored under the hash of
exactly those (:func:`grid_key`) in ``resources/oilwatch_grids/`` loads it instead, and one that does not
stores the grid it built there. The FMU build's warm-up run (``oilwatch/cosim/packaging.py``) fills the
folder for the default parameters and ships it; a host that unpacks the FMU read-only loses nothing but
the saving (a failed write is ignored). The code is identified by the FMU's own ``bundle.json`` digest
(:mod:`oilwatch.fmu_src.bundle`: the oilwatch running the FMU has those sources).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from oilwatch.fmu_src.bundle import BUNDLE_FILE
from oilwatch.models.system.factory import machine_files
from oilwatch.models.system.flowrate_grid import FlowrateGrid

GRID_FOLDER = "oilwatch_grids"
"""The stored grids' folder inside an FMU's resources folder."""
_FIELDS = ("q1_nodes_m3_s", "q2_nodes_m3_s", "transition", "forcing")


def grid_key(resources: str | None, machine, parameters: tuple) -> str | None:
    """Hash of what the grid depends on: the FMU's code digest, the machine's files and ``parameters``
    (the values that build the system and the model); None without a resources folder or a bundle."""
    if not resources:
        return None
    stamp = Path(resources) / "oilwatch" / BUNDLE_FILE
    if not stamp.is_file():
        return None
    digest = hashlib.sha256(json.loads(stamp.read_text(encoding="utf-8"))["digest"].encode())
    for path in machine_files(machine):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    digest.update(repr(parameters).encode())
    return digest.hexdigest()[:24]


def load_grid(resources: str | None, key: str | None) -> FlowrateGrid | None:
    """The grid stored under ``key`` in ``resources``, or None."""
    if key is None:
        return None
    path = Path(resources) / GRID_FOLDER / f"{key}.npz"
    if not path.is_file():
        return None
    with np.load(path) as stored:
        return FlowrateGrid(*(np.ascontiguousarray(stored[name]) for name in _FIELDS))


def store_grid(resources: str | None, key: str | None, grid: FlowrateGrid) -> None:
    """Store ``grid`` under ``key`` in ``resources`` (written whole or not at all; a read-only folder is
    left alone)."""
    if key is None:
        return
    folder = Path(resources) / GRID_FOLDER
    try:
        folder.mkdir(exist_ok=True)
        handle, partial = tempfile.mkstemp(dir=folder, suffix=".partial")
        with os.fdopen(handle, "wb") as stream:
            np.savez(stream, **{name: getattr(grid, name) for name in _FIELDS})
        os.replace(partial, folder / f"{key}.npz")
    except OSError:
        return
