"""Readers of recorded measurements: CSV (a file or standard input), Parquet and NI TDMS, in chunks.

Each reader yields :class:`Chunk` objects of at most ``chunk_rows`` samples, so that memory stays bounded
whatever the record's length, and reports the bytes or rows read through a progress callback. Columns are
named as in the file (TDMS: the channel name, or ``group/channel`` when a name is not unique); the time
is the ``time_column`` (TDMS without such a channel: the waveform properties ``wf_start_offset`` and
``wf_increment`` of the first requested channel). Every problem raises :class:`RecordError`, one line naming
the record, the column and the row (rows count data samples from 1).

Parquet needs ``pyarrow``, TDMS ``npTDMS`` (the ``records`` extra: ``pip install "oilwatch[records]"``).
"""

from __future__ import annotations

import itertools
import math
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from oilwatch.models.validation import InputError

STDIN = "-"
SMALL_CHUNK = 64
"""Fewer lines than this are parsed cell by cell (numpy's parser costs more per call than it saves)."""
FORMATS = {".csv": "csv", ".txt": "csv", ".parquet": "parquet", ".pq": "parquet", ".tdms": "tdms"}
Progress = Callable[[int], None]
"""Called with the amount read since the last call (bytes for CSV, rows otherwise)."""


class RecordError(InputError):
    """A record that cannot be read as it is (one line: record, column, row)."""


@dataclass
class Chunk:
    """Consecutive samples: ``first_row`` (1-based data row of the first), ``time_s`` (n,) and the requested
    ``columns`` (name -> (n,) float array; a column the record lacks is absent)."""

    first_row: int
    time_s: np.ndarray
    columns: dict[str, np.ndarray]


class RecordReader:
    """Base of the readers: ``name``, ``available`` (column names), ``units`` (name -> unit text when the
    format stores one), ``total`` (for the progress bar: bytes or rows, None when unknown) and
    :meth:`chunks`."""

    name: str
    available: tuple[str, ...]
    units: dict[str, str]
    total: int | None
    progress_unit: str = "row"

    def require(self, column: str, role: str) -> None:
        if column not in self.available:
            raise RecordError(
                f"{self.name}: missing column {column!r} ({role}); the record has: "
                f"{', '.join(self.available)}"
            )

    def chunks(
        self, columns: Sequence[str], chunk_rows: int, progress: Progress | None = None
    ) -> Iterator[Chunk]:
        raise NotImplementedError

    def close(self) -> None:
        """Release the file."""


def record_format(source: str) -> str:
    """``csv``, ``parquet`` or ``tdms`` from the file name (``-``: CSV on standard input)."""
    if source == STDIN:
        return "csv"
    suffix = Path(source).suffix.lower()
    if suffix not in FORMATS:
        raise RecordError(
            f"{source}: unknown record format {suffix or '(no suffix)'!r}; allowed: "
            f"{', '.join(sorted(FORMATS))}"
        )
    return FORMATS[suffix]


def open_record(source: str, time_column: str) -> RecordReader:
    """The reader of ``source`` (a path or ``-`` for standard input)."""
    kind = record_format(source)
    if source != STDIN and not Path(source).is_file():
        raise RecordError(f"{source}: no such record file")
    if kind == "csv":
        return CsvReader(source, time_column)
    if kind == "parquet":
        return ParquetReader(source, time_column)
    return TdmsReader(source, time_column)


# ------------------------------------------------------------------------------------------------- CSV
def _parse_cell(text: str) -> float:
    text = text.strip()
    return math.nan if text == "" else float(text)


class CsvReader(RecordReader):
    """Comma-separated text with a header line; empty cells and ``nan`` are missing values.

    Standard input is read as it arrives (a pipe from a data acquisition): each complete line is processed
    as soon as it is there, several together when they arrived together."""

    progress_unit = "B"

    def __init__(self, source: str, time_column: str) -> None:
        self.name = "standard input" if source == STDIN else source
        self.live = source == STDIN
        self.total = None if self.live else Path(source).stat().st_size
        self._pending = b""
        if self.live:
            self._stream = sys.stdin.buffer
            header = next(self._live_lines(header=True), [""])[0]
        else:
            self._stream = open(source, encoding="utf-8", newline="")  # closed by close()
            header = self._stream.readline()
        if not header.strip():
            raise RecordError(f"{self.name}: empty record (no header line)")
        self.available = tuple(name.strip() for name in header.strip().split(","))
        self.units = {}
        self.received_s = 0.0
        self._header_bytes = len(header.encode())
        self.time_column = time_column
        self.require(time_column, "time")

    def chunks(
        self, columns: Sequence[str], chunk_rows: int, progress: Progress | None = None
    ) -> Iterator[Chunk]:
        index = [self.available.index(c) for c in columns if c in self.available]
        present = [c for c in columns if c in self.available]
        time_index = self.available.index(self.time_column)
        width = len(self.available)
        row = 1
        if progress:
            progress(self._header_bytes)
        batches = self._live_lines() if self.live else self._file_lines(chunk_rows)
        for batch in batches:
            lines = [line for line in batch if line.strip()]
            if not lines:
                continue
            self.received_s = time.perf_counter()
            table = self._parse(lines, row, width)
            if progress:
                progress(sum(len(line) for line in lines))
            selected = {c: table[:, i] for c, i in zip(present, index, strict=True)}
            yield Chunk(row, table[:, time_index], selected)
            row += len(lines)

    def _file_lines(self, chunk_rows: int) -> Iterator[list[str]]:
        while True:
            lines = list(itertools.islice(self._stream, chunk_rows))
            if not lines:
                return
            yield lines

    def _live_lines(self, header: bool = False) -> Iterator[list[str]]:
        """The complete lines available on standard input as soon as there is one (``header``: only the
        first line)."""
        while True:
            cut = self._pending.find(b"\n") if header else self._pending.rfind(b"\n")
            if cut >= 0:
                complete, self._pending = self._pending[: cut + 1], self._pending[cut + 1 :]
                yield complete.decode().splitlines()
                if header:
                    return
                continue
            data = self._stream.read1(1 << 16)
            if not data:
                if self._pending.strip():
                    rest, self._pending = self._pending, b""
                    yield [rest.decode()]
                return
            self._pending += data

    def _parse(self, lines: list[str], first_row: int, width: int) -> np.ndarray:
        if len(lines) < SMALL_CHUNK:
            return self._parse_slowly(lines, first_row, width)
        try:
            table = np.loadtxt(lines, delimiter=",", ndmin=2, dtype=np.float64)
            if table.shape[1] == width:
                return table
        except ValueError:
            pass
        return self._parse_slowly(lines, first_row, width)

    def _parse_slowly(self, lines: list[str], first_row: int, width: int) -> np.ndarray:
        """Cell by cell (few lines, or a line numpy cannot read): empty cells are NaN; errors name the
        cell."""
        table = np.empty((len(lines), width))
        for k, line in enumerate(lines):
            cells = line.rstrip("\r\n").split(",")
            if len(cells) != width:
                raise RecordError(
                    f"{self.name}: row {first_row + k} has {len(cells)} fields, the header {width}"
                )
            for j, cell in enumerate(cells):
                try:
                    table[k, j] = _parse_cell(cell)
                except ValueError:
                    raise RecordError(
                        f"{self.name}: column {self.available[j]!r}, row {first_row + k}: not a number: "
                        f"{cell!r}"
                    ) from None
        return table

    def close(self) -> None:
        if not self.live:
            self._stream.close()


# --------------------------------------------------------------------------------------------- Parquet
def _import(module: str, package: str):
    try:
        return __import__(module, fromlist=["_"])
    except ImportError:
        raise RecordError(
            f"reading this record needs the {package} package: pip install {package} "
            '(or pip install "oilwatch[records]")'
        ) from None


class ParquetReader(RecordReader):
    """An Apache Parquet table (pyarrow), read batch by batch."""

    def __init__(self, source: str, time_column: str) -> None:
        parquet = _import("pyarrow.parquet", "pyarrow")
        self.name = source
        try:
            self._file = parquet.ParquetFile(source)
        except Exception as error:  # pyarrow raises its own ArrowInvalid
            raise RecordError(f"{source}: not a readable Parquet file ({error})") from None
        self.available = tuple(self._file.schema_arrow.names)
        self.units = {}
        self.total = self._file.metadata.num_rows
        self.time_column = time_column
        self.require(time_column, "time")

    def chunks(
        self, columns: Sequence[str], chunk_rows: int, progress: Progress | None = None
    ) -> Iterator[Chunk]:
        present = [c for c in columns if c in self.available]
        wanted = list(dict.fromkeys([self.time_column, *present]))
        row = 1
        for batch in self._file.iter_batches(batch_size=chunk_rows, columns=wanted):
            arrays = {}
            for name in wanted:
                try:
                    arrays[name] = np.asarray(
                        batch.column(name).to_numpy(zero_copy_only=False), dtype=np.float64
                    )
                except (TypeError, ValueError):
                    raise RecordError(
                        f"{self.name}: column {name!r}, rows {row}-{row + batch.num_rows - 1}: not numbers "
                        f"({batch.schema.field(name).type})"
                    ) from None
            if progress:
                progress(batch.num_rows)
            yield Chunk(row, arrays[self.time_column], {c: arrays[c] for c in present})
            row += batch.num_rows


# ------------------------------------------------------------------------------------------------ TDMS
class TdmsReader(RecordReader):
    """An NI TDMS file (npTDMS, streaming mode: only the slices asked for are read)."""

    def __init__(self, source: str, time_column: str) -> None:
        nptdms = _import("nptdms", "npTDMS")
        self.name = source
        try:
            self._file = nptdms.TdmsFile.open(source)
        except Exception as error:  # npTDMS raises ValueError/KeyError on malformed files
            raise RecordError(f"{source}: not a readable TDMS file ({error})") from None
        channels = [(g.name, c) for g in self._file.groups() for c in g.channels()]
        names = [c.name for _, c in channels]
        self._channels = {}
        for group, channel in channels:
            self._channels[f"{group}/{channel.name}"] = channel
            if names.count(channel.name) == 1:
                self._channels[channel.name] = channel
        self.available = tuple(self._channels)
        self.units = {
            name: str(ch.properties["unit_string"])
            for name, ch in self._channels.items()
            if "unit_string" in ch.properties
        }
        self.time_column = time_column
        self.total = max((len(channel) for _, channel in channels), default=0)  # from the metadata

    def chunks(
        self, columns: Sequence[str], chunk_rows: int, progress: Progress | None = None
    ) -> Iterator[Chunk]:
        present = [c for c in columns if c in self._channels]
        if not present:
            raise RecordError(
                f"{self.name}: none of the columns {', '.join(columns)} is a channel of the file"
            )
        lengths = {c: len(self._channels[c]) for c in present}
        length = min(lengths.values())
        short = [c for c, n in lengths.items() if n != length]
        if short:
            raise RecordError(
                f"{self.name}: channel {short[0]!r} has {lengths[short[0]]} samples, other channels "
                f"{length}: channels of one record must have the same length"
            )
        clock = self._clock(present[0])
        self.total = length
        for start in range(0, length, chunk_rows):
            stop = min(length, start + chunk_rows)
            arrays = {c: np.asarray(self._channels[c][start:stop], dtype=np.float64) for c in present}
            if clock is None:
                time_s = np.asarray(self._channels[self.time_column][start:stop], dtype=np.float64)
            else:
                time_s = clock[0] + clock[1] * np.arange(start, stop, dtype=np.float64)
            if progress:
                progress(stop - start)
            yield Chunk(start + 1, time_s, arrays)

    def _clock(self, reference: str) -> tuple[float, float] | None:
        """(start, increment) of the waveform clock, or None when the record has a time channel."""
        if self.time_column in self._channels:
            return None
        properties = self._channels[reference].properties
        if "wf_increment" not in properties:
            raise RecordError(
                f"{self.name}: no time channel {self.time_column!r} and channel {reference!r} has no "
                "wf_increment property (a waveform's sample interval)"
            )
        start = properties.get("wf_start_offset", 0.0)
        return float(start), float(properties["wf_increment"])

    def close(self) -> None:
        self._file.close()
