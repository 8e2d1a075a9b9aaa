"""Recorders: where the master puts the chosen variables after every (n-th) macro step.

A recorder has ``start(columns)``, ``record(time, values)`` and ``close()``; ``columns`` are
``"instance.variable"`` names and ``values`` a sequence in that order (time in s). A plain callable
``f(time, values)`` also works (see :func:`as_recorder`). :class:`CsvRecorder` writes and flushes
every row, so a run stopped with Ctrl-C keeps what it had.
"""

from __future__ import annotations

import csv
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np


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
    """Writes ``time,<columns...>`` rows to ``path``, flushing every ``flush_every`` rows.

    ``rename`` maps column names (``"plant.q1_ml_min"``) to the CSV's header names.
    """

    def __init__(self, path: str | Path, flush_every: int = 1, rename: dict[str, str] | None = None) -> None:
        self.path = Path(path)
        self.flush_every = max(1, int(flush_every))
        self.rename = rename or {}
        self._file = None
        self._writer = None
        self._count = 0

    def start(self, columns: list[str]) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = self.path.open("w", newline="", encoding="utf-8")
        self._writer = csv.writer(self._file)
        self._writer.writerow(["time_s", *(self.rename.get(c, c) for c in columns)])
        self._file.flush()
        self._count = 0

    def record(self, time: float, values: Sequence) -> None:
        self._writer.writerow([repr(float(time)), *(repr(v) for v in values)])
        self._count += 1
        if self._count % self.flush_every == 0:
            self._file.flush()

    def close(self) -> None:
        if self._file is not None and not self._file.closed:
            self._file.flush()
            self._file.close()


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
