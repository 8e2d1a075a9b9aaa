"""Recorders: where the master puts the chosen variables after every (n-th) macro step.

A recorder has ``start(columns)``, ``record(time, values)`` and ``close()``; ``columns`` are
``"instance.variable"`` names and ``values`` a sequence in that order (time in s). A plain callable
``f(time, values)`` also works (see :func:`as_recorder`). :class:`CsvRecorder` writes and flushes
every row whole, so a run stopped with Ctrl-C or by a full disk keeps what it had.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from oilwatch.outputs import ledger
from oilwatch.outputs.rows import RowFile


class MemoryRecorder:
    """Keeps every row in memory; :meth:`arrays` returns them as numpy arrays by column."""

    def __init__(self) -> None:
        self.columns: list[str] = []
        self.rows: list[tuple] = []

    def start(self, columns: list[str]) -> None:
        self.columns = list(columns)
        self.rows = []

    def record(self, time: float, values: Sequence) -> None:
        self.rows.append((time, *values))

    def close(self) -> None:
        """Nothing to release."""

    def arrays(self) -> dict[str, np.ndarray]:
        """``{"time": shape (n,), "<instance.variable>": shape (n,), ...}``."""
        table = np.array(self.rows, dtype=float).reshape(len(self.rows), len(self.columns) + 1)
        return {name: table[:, i] for i, name in enumerate(["time", *self.columns])}


class CsvRecorder:
    """Writes ``time,<columns...>`` rows to ``path``, whole rows only
    (:class:`oilwatch.outputs.rows.RowFile`: one write per row, cut back to the last whole row when the disk
    is full), synced every ``sync_every`` rows.

    ``rename`` maps column names (``"plant.q1_ml_min"``) to the CSV's header names.
    """

    def __init__(
        self, path: str | Path, sync_every: int = 1000, rename: dict[str, str] | None = None
    ) -> None:
        self.path = Path(path)
        self.sync_every = max(1, int(sync_every))
        self.rename = rename or {}
        self._file: RowFile | None = None

    def start(self, columns: list[str]) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = RowFile(self.path, sync_every=self.sync_every)
        self._file.write(_line(["time_s", *(self.rename.get(c, c) for c in columns)]))
        ledger.keep(str(self.path), self._kept)

    def record(self, time: float, values: Sequence) -> None:
        self._file.write(_line([repr(float(time)), *(repr(v) for v in values)]))

    def _kept(self) -> str:
        rows = 0 if self._file is None else max(0, self._file.lines - 1)
        return f"{self.path} keeps {rows} whole rows"

    def close(self) -> None:
        if self._file is not None:
            self._file.close()


def _line(fields: list[str]) -> str:
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow(fields)
    return buffer.getvalue()


class _CallableRecorder:
    def __init__(self, function: Callable[[float, Sequence], None]) -> None:
        self.function = function

    def start(self, columns: list[str]) -> None:
        self.columns = columns

    def record(self, time: float, values: Sequence) -> None:
        self.function(time, values)

    def close(self) -> None:
        """Nothing to release."""


def as_recorder(recorder):
    """Return ``recorder`` if it has ``record``; wrap a plain callable; None gives a MemoryRecorder."""
    if recorder is None:
        return MemoryRecorder()
    if hasattr(recorder, "record"):
        return recorder
    if callable(recorder):
        return _CallableRecorder(recorder)
    raise TypeError(f"recorder must have record() or be callable, got {type(recorder).__name__}")
