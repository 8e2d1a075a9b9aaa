"""Resuming ``oilwatch estimate`` where a stopped run left off, with the estimates of an uninterrupted run.

A run saves its resume point (:data:`STATE_NAME` in the output folder) at a block boundary every
:data:`SAVE_EVERY_S` seconds and when it is stopped between blocks: the estimator's state
(``get_state``), the views' history, the rows written and the length of ``estimates.csv`` up to them. A run
started into a folder whose ``summary.json`` says ``completed: false`` and whose resume point has the same
identity (:func:`run_identity`: the record's file, the machine file, the baseline and every option that
changes an estimate) reads the record again from its start (the conditioning filters need every sample),
skips the blocks already estimated, cuts ``estimates.csv`` back to the saved length, restores the state
and goes on: ``estimates.csv`` then holds the rows of an uninterrupted run, byte for byte.

The resume point is a pickle read with an unpickler that rebuilds only numpy arrays, the history's own
classes and plain containers (:class:`_StateUnpickler`): a file planted in the folder cannot run code.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import pickle
from pathlib import Path
from typing import ClassVar

from oilwatch.models.validation import InputError
from oilwatch.outputs.atomic import write_bytes_atomic

STATE_NAME = "resume_state.pickle"
FORMAT = 2
"""The resume point's layout (2: :class:`oilwatch.monitoring.trust.TrustShares` holds each bearing's table
limits); a point of another is not resumed."""
SAVE_EVERY_S = 2.0
"""Wall-clock seconds between two resume points: a SIGKILL loses at most this much work."""
RESUME_CHOICES = ("auto", "yes", "no")
"""``--resume``: auto (resume a partial run of the same identity, else start over), yes (resume or refuse),
no (start over)."""
IDENTITY_EXCLUDED = ("views", "live", "resume")
"""EstimateOptions fields that change no estimate."""
EDGE_BYTES = 1 << 20


def _file_digest(path: str | Path | None, whole: bool = True) -> str | None:
    """SHA-256 of a file (a record: of its size, its first and last MiB), None for none."""
    if path is None:
        return None
    path = Path(path)
    digest = hashlib.sha256()
    try:
        size = path.stat().st_size
        with open(path, "rb") as handle:
            if whole or size <= 2 * EDGE_BYTES:
                digest.update(handle.read())
            else:
                digest.update(handle.read(EDGE_BYTES))
                handle.seek(size - EDGE_BYTES)
                digest.update(handle.read())
    except OSError:
        return None
    digest.update(str(size).encode())
    return digest.hexdigest()


def run_identity(source: str, machine_path: Path, options) -> str:
    """The hash of what makes two runs' estimates the same: the record (path, size, first and last MiB),
    the machine file, the baseline file and the options (less :data:`IDENTITY_EXCLUDED`)."""
    settings = {k: v for k, v in dataclasses.asdict(options).items() if k not in IDENTITY_EXCLUDED}
    document = {
        "record": str(Path(source).resolve()),
        "record_digest": _file_digest(source, whole=False),
        "machine_digest": _file_digest(machine_path),
        "baseline_digest": _file_digest(options.baseline_file),
        "options": settings,
    }
    return hashlib.sha256(json.dumps(document, sort_keys=True, default=str).encode()).hexdigest()[:32]


class _StateUnpickler(pickle.Unpickler):
    ALLOWED: ClassVar[set[tuple[str, str]]] = {
        ("numpy", "ndarray"),
        ("numpy", "dtype"),
        ("numpy.core.multiarray", "_reconstruct"),
        ("numpy._core.multiarray", "_reconstruct"),
        ("numpy.core.multiarray", "scalar"),
        ("numpy._core.multiarray", "scalar"),
        ("oilwatch.monitoring.history", "History"),
        ("oilwatch.monitoring.history", "_Bins"),
        ("oilwatch.monitoring.history", "_Ring"),
        ("oilwatch.monitoring.trust", "TrustShares"),
        ("builtins", "set"),
        ("builtins", "frozenset"),
        ("builtins", "slice"),
    }

    def find_class(self, module: str, name: str):
        if (module, name) in self.ALLOWED or (module.startswith("numpy") and name.startswith("dtype")):
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"{module}.{name} is not part of a resume point")


def save_point(out: Path, point: dict) -> None:
    """Write the resume point (whole or not at all)."""
    write_bytes_atomic(out / STATE_NAME, pickle.dumps({"format": FORMAT, **point}, protocol=4))


def load_point(out: Path, identity: str) -> dict | None:
    """The folder's resume point if it is of ``identity`` and its summary says the run did not complete;
    None otherwise (no point, another run's, a completed run, an unreadable file)."""
    try:
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
        if summary.get("completed", True) or summary.get("identity") != identity:
            return None
        point = _StateUnpickler(io.BytesIO((out / STATE_NAME).read_bytes())).load()
    except (OSError, ValueError, pickle.UnpicklingError, EOFError, AttributeError, TypeError):
        return None
    if not isinstance(point, dict) or point.get("format") != FORMAT or point.get("identity") != identity:
        return None
    return point


def resume_point(out: Path, identity: str, choice: str) -> dict | None:
    """The point to resume from under ``--resume`` = ``choice`` (:data:`RESUME_CHOICES`); InputError for
    ``yes`` when there is none."""
    if choice == "no":
        return None
    point = load_point(out, identity)
    if point is None and choice == "yes":
        raise InputError(
            f"--resume yes: {out} holds no partial run of this record, machine and options (summary.json "
            f"with completed false and {STATE_NAME}); use --resume auto or no to start over"
        )
    return point


def forget_point(out: Path) -> None:
    """Remove the resume point (the run completed)."""
    (out / STATE_NAME).unlink(missing_ok=True)
