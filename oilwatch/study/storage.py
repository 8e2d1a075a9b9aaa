"""The study's files: ``cases.csv`` (one row per finished case, appended and synced at once) and
``study.json`` (the settings that make two runs in one folder comparable).

A study stopped at any moment (Ctrl-C, a killed process, a power cut) leaves at worst a torn last line in
``cases.csv``; :meth:`CaseStore.load` drops it (and cuts it off the file, so that the next append starts on
a fresh line), and a restarted study skips every case with a complete row.

One writer at a time per folder: the study holds the folder's lock
(:func:`oilwatch.outputs.lock.output_lock`, as every command that writes a folder) for the whole run, so a
second study into the same ``--out`` is refused at once instead of running every case again. A row is
written with signals held back (:func:`oilwatch.outputs.interrupts.deferred`): Ctrl-C never tears it.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from dataclasses import fields
from pathlib import Path

from oilwatch.models.validation import InputError
from oilwatch.outputs import interrupts
from oilwatch.outputs.atomic import write_json_atomic

from .cases import CaseResult

COLUMNS: tuple[str, ...] = tuple(field.name for field in fields(CaseResult))
_TYPES = {field.name: field.type for field in fields(CaseResult)}
MANIFEST_FORMAT = 1
COMPARABLE_SETTINGS = ("case_model", "duration_s", "discard_s")
"""Settings a restarted study must share with the rows already in the folder."""


def _parse(raw: dict) -> dict | None:
    """A typed row, or None when the row is incomplete or malformed."""
    row = {}
    for name in COLUMNS:
        text = raw.get(name)
        if text is None:
            return None
        kind = _TYPES[name]
        try:
            if kind == "str":
                row[name] = text
            elif kind == "int":
                row[name] = int(text)
            else:
                row[name] = float(text)
        except ValueError:
            return None
    if (
        not row["case_id"]
        or not math.isfinite(row["q1_est_ml_min"])
        or not math.isfinite(row["q2_est_ml_min"])
    ):
        return None
    return row


class CaseStore:
    """Append-only CSV of finished cases, one :class:`CaseResult` per row (columns :data:`COLUMNS`)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._file = None

    def load(self) -> dict[str, dict]:
        """Complete rows by case id (the first row of a case wins); repairs a torn last line on disk."""
        if not self.path.exists():
            return {}
        data = self.path.read_bytes()
        complete_end = data.rfind(b"\n") + 1
        if complete_end < len(data):
            with open(self.path, "r+b") as handle:
                handle.truncate(complete_end)
                handle.flush()
                os.fsync(handle.fileno())
            data = data[:complete_end]
        text = data.decode("utf-8", errors="replace")
        if not text:
            return {}
        reader = csv.DictReader(io.StringIO(text))
        if tuple(reader.fieldnames or ()) != COLUMNS:
            raise InputError(
                f"--out: {self.path} has columns {reader.fieldnames}, not those of this oilwatch version; "
                "use another --out folder"
            )
        rows: dict[str, dict] = {}
        for raw in reader:
            row = _parse(raw)
            if row is not None and row["case_id"] not in rows:
                rows[row["case_id"]] = row
        return rows

    def append(self, row: dict) -> None:
        """Write one row and sync it to disk before returning."""
        if self._file is None:
            new = not self.path.exists() or self.path.stat().st_size == 0
            self._file = open(self.path, "a", newline="", encoding="utf-8")
            if new:
                self._write([*COLUMNS])
        self._write([row[name] for name in COLUMNS])

    def _write(self, values: list) -> None:
        buffer = io.StringIO()
        # csv writes floats with repr(), which reads back exactly: a restarted study sums the same numbers.
        csv.writer(buffer, lineterminator="\n").writerow(values)
        # One write per line: a crash can tear only the line being written, never an earlier one.
        with interrupts.deferred():
            self._file.write(buffer.getvalue())
            self._file.flush()
            os.fsync(self._file.fileno())

    def close(self) -> None:
        """Close the file (appending again reopens it)."""
        if self._file is not None:
            self._file.close()
            self._file = None


def check_manifest(out_dir: Path, settings: dict) -> None:
    """Write ``study.json``, or check that the folder's earlier study used the same comparable settings."""
    path = out_dir / "study.json"
    if path.exists():
        try:
            earlier = json.loads(path.read_text())
        except json.JSONDecodeError as error:
            raise InputError(f"--out: {path} is not valid JSON ({error}); use another --out folder") from None
        for key in COMPARABLE_SETTINGS:
            if earlier.get(key) != settings[key]:
                option = "--" + key.replace("_", "-").replace("case-model", "case")
                raise InputError(
                    f"{option} = {settings[key]!r}, but the study in {out_dir} used {earlier.get(key)!r}; "
                    "use the same value or another --out folder"
                )
    write_json_atomic(path, {"format": MANIFEST_FORMAT, **settings})
