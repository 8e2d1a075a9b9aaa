"""Which oilwatch an FMU bundles, and whether the one its process already imported is the same.

An oilwatch FMU carries ``resources/oilwatch/`` (the ``models``, ``estimator`` and ``fmu_src`` subpackages
under their own names, a minimal ``__init__.py``) and ``resources/oilwatch/bundle.json``: the package version
and :func:`source_digest` of those sources. Python keeps one ``oilwatch`` per process, so every oilwatch FMU
in a process (two instances, the plant and the estimator, or an FMU in a host that imported oilwatch itself)
runs the first one imported. That is safe exactly when the sources are the same: every FMU bundles the
same three subpackages, finds its machine file through its own instance's resources folder
(:func:`oilwatch.fmu_src.machine_parameters.bundled_machine_file`), and numba's cache is keyed by source
content. :func:`admit` names the two versions otherwise; the FMU's loader (``fmi2_loader.c``) calls it,
loading this file by path, before the slave is imported, and refuses the instance with that message.

Standard library only: the loader runs this file before it knows which oilwatch the process holds.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

BUNDLE_FILE = "bundle.json"
"""The fingerprint file inside a bundled ``oilwatch`` folder."""
SUBPACKAGES = ("models", "estimator", "fmu_src")
"""What every oilwatch FMU bundles (the same set in each, so that any one of them serves the others)."""


def source_files(root: Path) -> list[Path]:
    """The Python sources of the bundled subpackages under the ``oilwatch`` folder ``root``, in order."""
    files = []
    for package in SUBPACKAGES:
        folder = root / package
        files += [
            path
            for path in folder.rglob("*.py")
            if not {"__pycache__", "tests"} & set(path.relative_to(folder).parts)
        ]
    return sorted(files, key=lambda path: path.relative_to(root).as_posix())


def source_digest(root: Path) -> str:
    """SHA-256 (first 16 hex digits) of the names and contents of :func:`source_files` of ``root``."""
    digest = hashlib.sha256()
    for path in source_files(Path(root)):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def fingerprint(root: Path) -> dict[str, str]:
    """``{"version", "digest"}`` of the oilwatch folder ``root``: its ``bundle.json`` if it has one (an FMU's
    bundle), else computed from its sources (an installed oilwatch)."""
    root = Path(root)
    recorded = root / BUNDLE_FILE
    if recorded.is_file():
        return json.loads(recorded.read_text(encoding="utf-8"))
    try:
        from importlib import metadata

        version = metadata.version("oilwatch")
    except Exception:  # an oilwatch folder on sys.path without installed metadata
        version = "unknown"
    return {"version": version, "digest": source_digest(root)}


def describe(stamp: dict[str, str]) -> str:
    """``oilwatch <version> (sources <digest>)`` of a :func:`fingerprint`."""
    return f"oilwatch {stamp['version']} (sources {stamp['digest']})"


def admit(resources: str) -> str:
    """Whether the process can run the FMU whose resources folder is ``resources``: empty when it can, else
    one line naming the FMU's oilwatch and the one the process already imported.

    When it can and the imported oilwatch is another copy, every imported oilwatch package also searches
    this FMU's copy: a host may delete the first FMU's unpack folder while the second still imports
    subpackages lazily (the sources are the same, so either copy serves)."""
    imported = sys.modules.get("oilwatch")
    own = Path(resources) / "oilwatch"
    if imported is None or not getattr(imported, "__file__", None):
        return ""
    other = Path(imported.__file__).resolve().parent
    if other == own.resolve():
        return ""
    mine = fingerprint(own)
    theirs = getattr(imported, "BUNDLE", None) or fingerprint(other)
    if mine["digest"] != theirs["digest"]:
        return (
            f"this FMU bundles {describe(mine)} but the process already imported {describe(theirs)} from "
            f"{other}: run the FMU in a process of its own or build it with that oilwatch"
        )
    for name, module in list(sys.modules.items()):
        search = getattr(module, "__path__", None)
        if name.split(".")[0] == "oilwatch" and search is not None:
            folder = str(own.joinpath(*name.split(".")[1:]))
            if folder not in search:
                search.append(folder)
    return ""
