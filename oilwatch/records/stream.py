"""A record as a stream of estimator samples: read, checked, bridged, converted, resampled.

:class:`RecordStream` chains, chunk by chunk (memory bounded whatever the record's length):

1. the reader (:mod:`oilwatch.records.readers`);
2. checks: a non-finite, unsorted or duplicate time, a column whose values cannot be in its unit (a probe in
   um whose readings are all below a nanometre or beyond 20 clearances, a gap voltage that is positive, a
   speed over 2000 Hz, an oil temperature outside -40..250 degC, a sample interval outside 1 us..0.1 s) raise
   :class:`RecordError` naming the column and the row;
3. gaps (an interval over 1.5 nominal intervals, up to :data:`MAX_GAP_S`) bridged with missing samples (NaN,
   which the estimator predicts through) and listed in :attr:`RecordStream.gaps`;
4. the keyphasor, when the set-up names one: its first pulse fixes the estimator's time origin so that the
   model's rotor angle there is ``keyphasor_angle_deg`` (samples before it are dropped); it also gives the
   speed when the record has no speed column;
5. probe readings -> displacements along the probes' axes [m], which the estimator takes when each bearing's
   pair is square and both pairs at one angle (as the estimator FMU with ``probe_angle_deg``), and
   (x1, y1, x2, y2) [m] for the rows and views (:class:`oilwatch.records.probes.PositionConverter`);
6. anti-alias filtering and resampling onto the estimator's grid
   (:class:`oilwatch.records.signal.GridResampler`).

Time: the estimator's model time is ``tau = t - time_shift_s`` (0 without a keyphasor: the record's time is
the model's, as in the plant FMU's outputs); the grid is ``tau = k dt``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np

from .probes import PositionConverter, ProbeSetup
from .readers import STDIN, Chunk, RecordError, RecordReader, open_record, record_format
from .signal import GridResampler, Keyphasor

GAP_FACTOR = 1.5
MAX_GAP_S = 60.0
MAX_LISTED_GAPS = 100
"""Gaps listed one by one in the provenance (all are counted)."""
"""A longer interruption is an error (split the record there)."""
MAX_SPEED_HZ = 2000.0
OIL_TEMPERATURE_RANGE_C = (-40.0, 250.0)
INTERVAL_RANGE_S = (1e-6, 0.1)


@dataclass
class GridBlock:
    """Consecutive estimator samples: grid indices ``k`` (model time k dt), the record's ``time_s``, the
    positions (k, 4) [m] (NaN: missing), ``speed_hz`` and ``oil_temperature_c`` (NaN when not recorded)."""

    k: np.ndarray
    time_s: np.ndarray
    position_m: np.ndarray
    speed_hz: np.ndarray
    oil_temperature_c: np.ndarray
    measurement_m: np.ndarray
    """(k, 4) what the estimator takes [m]: the readings along the probes' axes when
    :attr:`RecordStream.probe_angle_deg` is not None (a missing reading blanks only its own channel), else
    ``position_m``."""


@dataclass
class RecordStream:
    """Iterate :meth:`blocks` once; the attributes describe the record as far as it has been read."""

    source: str
    setup: ProbeSetup
    clearances_m: tuple[float, ...]
    dt_s: float
    model_speed_hz: float
    chunk_rows: int = 8192
    progress: Callable[[int], None] | None = None
    format: str = ""
    rows: int = 0
    first_time_s: float | None = None
    last_time_s: float | None = None
    sample_rate_hz: float | None = None
    time_shift_s: float = 0.0
    rows_before_keyphasor: int = 0
    keyphasor_pulses: int = 0
    anti_alias_taps: int = 1
    speed_source: str = "none"
    gaps: list[dict] = field(default_factory=list)
    gap_count: int = 0
    missing_samples: int = 0
    reader: RecordReader | None = None

    def __post_init__(self) -> None:
        self.format = record_format(self.source)
        self.reader = open_record(self.source, self.setup.time_column)
        reader, setup = self.reader, self.setup
        for probe in setup.probes:
            reader.require(probe.column, f"probes.{probe.name}.column")
            unit = reader.units.get(probe.column)
            if unit is not None and unit.strip() not in ("", probe.unit):
                raise RecordError(
                    f"{reader.name}: column {probe.column!r} is in {unit!r} but probes.{probe.name}.unit is "
                    f"{probe.unit!r}"
                )
        if setup.keyphasor_column:
            reader.require(setup.keyphasor_column, "probes.keyphasor_column")
        self.has_speed = setup.speed_column in reader.available
        self.has_temperature = setup.oil_temperature_column in reader.available
        self.speed_source = (
            "column " + setup.speed_column
            if self.has_speed
            else "keyphasor"
            if setup.keyphasor_column
            else "none"
        )
        self.converter = PositionConverter(setup, self.clearances_m)
        self.probe_angle_deg = self.converter.pair_angle_deg
        self._keyphasor = (
            Keyphasor(setup.keyphasor_edge, setup.keyphasor_threshold_v) if setup.keyphasor_column else None
        )
        self._resampler: GridResampler | None = None
        self._interval: float | None = None
        self._previous: tuple[float, int] | None = None  # last time, its row
        self._pending: Chunk | None = None
        self._origin_found = self._keyphasor is None
        self._bridge_tail: float | None = None

    @property
    def columns(self) -> list[str]:
        setup = self.setup
        names = list(setup.probe_columns)
        if self.has_speed:
            names.append(setup.speed_column)
        if self.has_temperature:
            names.append(setup.oil_temperature_column)
        if setup.keyphasor_column:
            names.append(setup.keyphasor_column)
        return names

    def blocks(self) -> Iterator[GridBlock]:
        """The record as estimator samples, chunk by chunk."""
        try:
            for chunk in self.reader.chunks(self.columns, self.chunk_rows, self.progress):
                block = self._process(chunk)
                if block is not None and block.k.size:
                    yield block
        finally:
            self.reader.close()

    # ----------------------------------------------------------------------------------------- stages
    def _process(self, chunk: Chunk) -> GridBlock | None:
        self._check_times(chunk)
        if self._pending is not None:  # too short to know the sample interval (standard input)
            chunk = _join(self._pending, chunk)
            self._pending = None
        if self._interval is None:
            if chunk.time_s.size < 2:
                self._pending = chunk
                return None
            self._start(chunk)
        chunk = self._bridge(chunk)
        self.rows = self._previous[1]
        self.last_time_s = float(chunk.time_s[-1])
        return self._convert(chunk)

    def _check_times(self, chunk: Chunk) -> None:
        name, column = self.reader.name, self.setup.time_column
        t = chunk.time_s
        bad = np.flatnonzero(~np.isfinite(t))
        if bad.size:
            raise RecordError(
                f"{name}: column {column!r}, row {chunk.first_row + bad[0]}: time is not finite"
            )
        if self._previous is not None:
            t_all = np.concatenate([[self._previous[0]], t])
            first_row = chunk.first_row - 1
        else:
            t_all, first_row = t, chunk.first_row
        step = np.diff(t_all)
        wrong = np.flatnonzero(step <= 0.0)
        if wrong.size:
            i = wrong[0]
            kind = "duplicate time" if step[i] == 0.0 else "time goes backwards (unsorted)"
            raise RecordError(
                f"{name}: column {column!r}, row {first_row + i + 1}: {kind}: {t_all[i + 1]:.9g} s after "
                f"{t_all[i]:.9g} s"
            )
        if t.size:
            self._previous = (float(t[-1]), chunk.first_row + t.size - 1)

    def _start(self, chunk: Chunk) -> None:
        """First chunk: the nominal sample interval, the plausibility of each column's unit."""
        name = self.reader.name
        interval = float(np.median(np.diff(chunk.time_s)))
        low, high = INTERVAL_RANGE_S
        if not low <= interval <= high:
            raise RecordError(
                f"{name}: column {self.setup.time_column!r}, rows {chunk.first_row}-"
                f"{chunk.first_row + chunk.time_s.size - 1}: sample interval {interval:.6g} s cannot be "
                f"right (time in seconds, {low:g} to {high:g} s per sample)"
            )
        self._interval = interval
        self.sample_rate_hz = 1.0 / interval
        self.first_time_s = float(chunk.time_s[0])
        for probe in self.setup.probes:
            values = chunk.columns[probe.column]
            finite = values[np.isfinite(values)]
            if finite.size == 0:
                continue
            row = chunk.first_row + int(np.flatnonzero(np.isfinite(values))[0])
            where = f"{name}: column {probe.column!r}, rows from {row}"
            if probe.unit == "um":
                spread = np.abs(finite - probe.zero_um)
                limit = 20.0 * self.clearances_m[probe.bearing - 1] * 1e6
                if float(spread.max()) < 1e-3:
                    raise RecordError(f"{where}: every reading is below 1 nm: not a displacement in um")
                if float(np.median(spread)) > limit:
                    raise RecordError(
                        f"{where}: median |reading| {float(np.median(spread)):.4g} um exceeds 20 radial "
                        f"clearances ({limit:.4g} um): not a displacement in um from the bearing centre"
                    )
            else:
                median = float(np.median(finite))
                if not -24.0 <= median < 0.0:
                    raise RecordError(
                        f"{where}: median {median:.4g} V cannot be a proximity probe's gap voltage "
                        "(negative, -24 to 0 V)"
                    )
        self._check_range(chunk, self.setup.speed_column, self.has_speed, 0.0, MAX_SPEED_HZ, "Hz")
        self._check_range(
            chunk, self.setup.oil_temperature_column, self.has_temperature, *OIL_TEMPERATURE_RANGE_C, "degC"
        )
        filtered = np.array([True] * 4 + [False, False])
        self._resampler = GridResampler(self.sample_rate_hz, self.dt_s, filtered)
        self.anti_alias_taps = self._resampler.taps.size

    def _check_range(
        self, chunk: Chunk, column: str, present: bool, low: float, high: float, unit: str
    ) -> None:
        if not present:
            return
        values = chunk.columns[column]
        outside = np.flatnonzero(np.isfinite(values) & ~((values > low) & (values < high)))
        if outside.size:
            i = outside[0]
            raise RecordError(
                f"{self.reader.name}: column {column!r}, row {chunk.first_row + i}: {values[i]:.6g} "
                f"cannot be right (expected {low:g} to {high:g} {unit})"
            )

    def _bridge(self, chunk: Chunk) -> Chunk:
        """Missing samples (NaN) at the nominal rate in every gap, listed in :attr:`gaps`."""
        interval = self._interval
        t = chunk.time_s
        if self._bridge_tail is not None:
            t_all = np.concatenate([[self._bridge_tail], t])
        else:
            t_all = t
        step = np.diff(t_all)
        gaps = np.flatnonzero(step > GAP_FACTOR * interval)
        self._bridge_tail = float(t[-1])
        if gaps.size == 0:
            return chunk
        offset = 1 if t_all is not t else 0
        pieces_t, pieces = [], {name: [] for name in chunk.columns}
        start = 0
        for g in gaps:
            index = g + 1 - offset  # first sample after the gap, in the chunk
            span = float(step[g])
            if span > MAX_GAP_S:
                raise RecordError(
                    f"{self.reader.name}: column {self.setup.time_column!r}, row "
                    f"{chunk.first_row + index}: a gap of {span:.6g} s (more than {MAX_GAP_S:g} s): split "
                    "the record there"
                )
            missing = round(span / interval) - 1
            before = float(t_all[g])
            self.gap_count += 1
            self.missing_samples += int(missing)
            if len(self.gaps) < MAX_LISTED_GAPS:
                self.gaps.append(
                    {
                        "row": int(chunk.first_row + index),
                        "from_s": before,
                        "to_s": float(t_all[g + 1]),
                        "missing_samples": int(missing),
                    }
                )
            pieces_t += [t[start:index], before + interval * np.arange(1, missing + 1)]
            for name, values in chunk.columns.items():
                pieces[name] += [values[start:index], np.full(missing, np.nan)]
            start = index
        pieces_t.append(t[start:])
        for name, values in chunk.columns.items():
            pieces[name].append(values[start:])
        return Chunk(
            chunk.first_row,
            np.concatenate(pieces_t),
            {name: np.concatenate(parts) for name, parts in pieces.items()},
        )

    def _convert(self, chunk: Chunk) -> GridBlock | None:
        setup = self.setup
        t = chunk.time_s
        count = t.size
        nan = np.full(count, np.nan)
        speed = chunk.columns[setup.speed_column] if self.has_speed else nan
        temperature = chunk.columns[setup.oil_temperature_column] if self.has_temperature else nan
        keep = slice(None)
        if self._keyphasor is not None:
            pulses = self._keyphasor.push(t, chunk.columns[setup.keyphasor_column])
            self.keyphasor_pulses = self._keyphasor.count
            if not self.has_speed:
                speed = self._keyphasor.speed_hz(t)
            if not self._origin_found:
                if pulses.size == 0:
                    self.rows_before_keyphasor += count
                    return None
                omega = 2.0 * math.pi * self.model_speed_hz
                self.time_shift_s = float(pulses[0]) - math.radians(setup.keyphasor_angle_deg % 360.0) / omega
                self._origin_found = True
                first = int(np.searchsorted(t, self.time_shift_s, side="left"))
                self.rows_before_keyphasor += first
                keep = slice(first, None)
        readings = np.column_stack([chunk.columns[c] for c in setup.probe_columns])[keep]
        along = self.probe_angle_deg is not None
        signals = self.converter.along_axis_m(readings) if along else self.converter.positions_m(readings)
        values = np.column_stack([signals, speed[keep], temperature[keep]])
        k, grid = self._resampler.push(t[keep] - self.time_shift_s, values)
        measurement = grid[:, :4]
        return GridBlock(
            k=k,
            time_s=k * self.dt_s + self.time_shift_s,
            position_m=self.converter.positions_from_axes_m(measurement) if along else measurement,
            speed_hz=grid[:, 4],
            oil_temperature_c=grid[:, 5],
            measurement_m=measurement,
        )

    def provenance(self) -> dict:
        """What was read, for the summary."""
        return {
            "source": "stdin" if self.source == STDIN else self.source,
            "format": self.format,
            "rows": self.rows,
            "first_time_s": self.first_time_s,
            "last_time_s": self.last_time_s,
            "sample_rate_hz": None if self.sample_rate_hz is None else round(self.sample_rate_hz, 6),
            "estimator_rate_hz": round(1.0 / self.dt_s, 6),
            "anti_alias_taps": self.anti_alias_taps,
            "time_shift_s": self.time_shift_s,
            "keyphasor_pulses": self.keyphasor_pulses,
            "rows_before_keyphasor": self.rows_before_keyphasor,
            "speed_source": self.speed_source,
            "gaps": self.gaps,
            "gap_count": self.gap_count,
            "missing_samples": self.missing_samples,
            "probes": self.setup.to_dict(),
        }


def _join(first: Chunk, second: Chunk) -> Chunk:
    return Chunk(
        first.first_row,
        np.concatenate([first.time_s, second.time_s]),
        {name: np.concatenate([first.columns[name], second.columns[name]]) for name in first.columns},
    )
