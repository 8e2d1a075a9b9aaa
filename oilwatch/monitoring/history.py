"""What a run keeps of its estimates for the summary and the views, in memory bounded whatever the record's
length: a ring of the last 30 s at full rate (the final window), 10 ms bins of the trends, 0.5 s bins of the
shaft centreline and probe health (both at most :data:`MAX_TREND_BINS` / :data:`MAX_SLOW_BINS` bins: wider on
a long record), the first and last second of positions (the orbits), and the alarm events."""

from __future__ import annotations

import math

import numpy as np

TREND_BIN_S = 0.01
SLOW_BIN_S = 0.5
MAX_TREND_BINS = 4096
MAX_SLOW_BINS = 8192
"""Bins kept at most (then twice as wide): a view of 4096 points is finer than its pixels; 0.5 s centreline
bins up to 68 min of record."""
ORBIT_S = 1.0
FINAL_RING_S = 30.0
BATCH_ROWS = 1024
# estimates.csv column positions (oilwatch.monitoring.columns.estimate_columns)
TIME, Q, STD, STARVED, NIS, CONVERGED, OK, POSITION, SPEED, TEMPERATURE = (
    0, slice(1, 3), slice(3, 5), slice(5, 7), 7, 9, 10, slice(11, 15), 15, 16
)  # fmt: skip


class _Bins:
    """Running means of a (n, m) series over fixed bins of ``size`` samples (NaN ignored), at most
    ``max_bins`` of them: past that, adjacent pairs are merged and the bins made twice as wide, so that memory
    and the views' drawing stay bounded whatever the record's length (a bin's time is its first sample's).

    A record rarely ends on a bin's edge: :meth:`arrays` averages a trailing part-filled bin into the whole
    bin before it, so that the last point (and what is read off it: the centreline's e/c, the NIS) is a mean
    over at least one whole bin, never over the one or few samples after the last edge."""

    def __init__(self, size: int, width: int, max_bins: int) -> None:
        self.size, self.width, self.max_bins = size, width, max_bins
        self._sums: list[np.ndarray] = []
        self._counts: list[np.ndarray] = []
        self._times: list[np.ndarray] = []
        self._bins = 0
        self._open: int | None = None
        self._last_index = -1

    def add(self, index: np.ndarray, times: np.ndarray, values: np.ndarray) -> None:
        bins = index // self.size
        starts = np.flatnonzero(np.r_[True, bins[1:] != bins[:-1]])
        finite = np.isfinite(values)
        sums = np.add.reduceat(np.where(finite, values, 0.0), starts, axis=0)
        counts = np.add.reduceat(finite.astype(float), starts, axis=0)
        first = int(bins[starts[0]])
        if self._open is not None and first == self._open:
            self._sums[-1][-1] += sums[0]
            self._counts[-1][-1] += counts[0]
            sums, counts, starts = sums[1:], counts[1:], starts[1:]
        if starts.size:
            self._sums.append(sums)
            self._counts.append(counts)
            self._times.append(times[starts])
            self._bins += starts.size
        self._open = int(bins[-1])
        self._last_index = int(index[-1])
        while self._bins > self.max_bins:
            self._coarsen()

    def _coarsen(self) -> None:
        """Merge bins 2j and 2j + 1 (bins are numbered from the record's first sample, all present)."""
        sums, counts, times = np.vstack(self._sums), np.vstack(self._counts), np.concatenate(self._times)
        pairs = np.arange(0, times.size, 2)
        self._sums = [np.add.reduceat(sums, pairs, axis=0)]
        self._counts = [np.add.reduceat(counts, pairs, axis=0)]
        self._times = [times[pairs]]
        self._bins = pairs.size
        self.size *= 2
        self._open //= 2

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if not self._times:
            return np.zeros(0), np.zeros((0, self.width))
        sums, counts = np.vstack(self._sums), np.vstack(self._counts)
        times = np.concatenate(self._times)
        tail_samples = self._last_index + 1 - self._open * self.size
        if tail_samples < self.size and times.size > 1:
            sums = np.vstack([sums[:-2], sums[-2] + sums[-1]])
            counts = np.vstack([counts[:-2], counts[-2] + counts[-1]])
            times = times[:-1]
        with np.errstate(invalid="ignore", divide="ignore"):
            return times, np.where(counts > 0, sums / counts, np.nan)


class _Ring:
    """The last ``size`` rows of a (n, width) series (a circular buffer: O(rows added) per call)."""

    def __init__(self, size: int, width: int) -> None:
        self.data = np.full((size, width), np.nan)
        self.count = 0

    def add(self, values: np.ndarray) -> None:
        size = self.data.shape[0]
        values = values[-size:]
        n = values.shape[0]
        start = self.count % size
        first = min(n, size - start)
        self.data[start : start + first] = values[:first]
        self.data[: n - first] = values[first:]
        self.count += n

    def last(self, n: int) -> np.ndarray:
        """The last ``n`` rows in order (at most the buffer's size, at most those added)."""
        size = self.data.shape[0]
        n = min(n, size, self.count)
        index = (self.count - n + np.arange(n)) % size
        return self.data[index]


class History:
    """Accumulates the rows of :class:`oilwatch.monitoring.estimate.EstimateRun` (module docstring)."""

    def __init__(
        self, dt_s: float, speed_hz: float, clearances_m: tuple[float, ...], probe_angle_deg: float = 0.0
    ) -> None:
        self.dt, self.speed_hz, self.clearances_m = dt_s, speed_hz, tuple(clearances_m)
        self.probe_angle_deg = probe_angle_deg
        """The estimator's probe frame: its offsets are along probe axes at this angle (0: x and y)."""
        self.samples = 0
        self.first_k: int | None = None
        # q1 q2 std1 std2 starved1 starved2; positions, valid, ok, nis
        self.trend = _Bins(max(1, round(TREND_BIN_S / dt_s)), 6, MAX_TREND_BINS)
        self.slow = _Bins(max(1, round(SLOW_BIN_S / dt_s)), 4 + 4 + 2, MAX_SLOW_BINS)
        self.extra_bins: _Bins | None = None
        self.extra_names: list[str] = []
        self.flagged_samples = np.zeros(4, dtype=np.int64)
        """Per probe, the samples it was flagged faulty (probe_status != 0)."""
        self.last_status: np.ndarray | None = None
        self.mismatch_samples = np.zeros(3, dtype=np.int64)
        """Samples at each model-mismatch status (oilwatch.estimator.baseline_change: 0 consistent, 1 read
        from the baseline change, 2 held); all zero for an estimator without the status."""
        self.last_mismatch: int | None = None
        self._mismatch: int | None = None
        self.last_offsets_um = np.zeros(4)
        """The estimator's last probe offset estimates (along the probes' axes at :attr:`probe_angle_deg`;
        zeros when it does not estimate them)."""
        self._final = _Ring(max(1, round(FINAL_RING_S / dt_s)), 4)
        self._orbit_n = max(2, round(ORBIT_S / dt_s))
        self._start_k: list[np.ndarray] = []
        self._start_p: list[np.ndarray] = []
        self._start_count = 0
        self._end = _Ring(self._orbit_n, 5)  # k, positions
        self.alarms: list[dict] = []
        self.last_starved = np.zeros(2, dtype=bool)
        self._speed = [math.inf, -math.inf, 0.0, 0]  # min, max, sum, count
        self.last_time_s: float | None = None
        self.first_time_s: float | None = None
        self._pending: list[tuple[np.ndarray, np.ndarray]] = []
        self._pending_rows = 0
        self._columns: list[str] = []

    @property
    def duration_s(self) -> float:
        return (self.samples + self._pending_rows) * self.dt

    def add(self, block, rows: np.ndarray, columns: list[str]) -> None:
        """Keep a block's rows (processed in batches of :data:`BATCH_ROWS`: a live record comes line by line,
        and the bins cost per call, not per row)."""
        self._pending.append((block.k, rows))
        self._pending_rows += rows.shape[0]
        self._columns = columns
        if self._pending_rows >= BATCH_ROWS:
            self.flush()

    def flush(self) -> None:
        """Process the rows kept by :meth:`add` (call before reading the results)."""
        if not self._pending:
            return
        k = np.concatenate([item[0] for item in self._pending])
        rows = np.vstack([item[1] for item in self._pending])
        self._pending, self._pending_rows = [], 0
        self._process(k, rows, self._columns)

    def _process(self, k: np.ndarray, rows: np.ndarray, columns: list[str]) -> None:
        count = rows.shape[0]
        if self.first_k is None:
            self.first_k = int(k[0])
            self.first_time_s = float(rows[0, TIME])
            self.extra_names = [name for name in columns[17:] if _is_health(name)]
            if self.extra_names:
                self.extra_bins = _Bins(self.slow.size, len(self.extra_names), MAX_SLOW_BINS)
            self._extra_index = [columns.index(name) for name in self.extra_names]
            self._flag_columns = [name.startswith(STATUS_PREFIX) for name in self.extra_names]
            status = [f"{STATUS_PREFIX}{name}" for name in ("x1", "y1", "x2", "y2")]
            self._status_index = [columns.index(n) for n in status] if set(status) <= set(columns) else None
            offsets = [f"offset_{name}_um" for name in ("x1", "y1", "x2", "y2")]
            self._offset_index = [columns.index(n) for n in offsets] if set(offsets) <= set(columns) else None
            self._consistent = columns.index("model_consistent") if "model_consistent" in columns else None
            self._mismatch = columns.index("model_mismatch") if "model_mismatch" in columns else None
        if self._mismatch is not None:
            status = rows[:, self._mismatch].astype(np.int64)
            self.mismatch_samples += np.bincount(status, minlength=3)[:3]
            self.last_mismatch = int(status[-1])
        index = k - self.first_k
        times = rows[:, TIME]
        self.last_time_s = float(times[-1])
        self.trend.add(index, times, np.column_stack([rows[:, Q], rows[:, STD], rows[:, STARVED]]))
        measured = rows[:, POSITION]
        positions = measured  # for the centreline and the orbits: without the samples of faulty probes
        if self._status_index is not None:
            flagged = rows[:, self._status_index] != 0.0
            positions = np.where(flagged, np.nan, measured)
            self.flagged_samples += flagged.sum(axis=0)
            self.last_status = rows[-1, self._status_index].astype(np.int64)
        ok = rows[:, OK]
        nis = np.where(ok > 0, rows[:, NIS], np.nan)
        self.slow.add(index, times, np.column_stack([positions, np.isfinite(measured), ok, nis]))
        if self.extra_bins is not None:
            health = rows[:, self._extra_index]
            # a probe status is binned as "flagged faulty" (code != 0), a flag as itself
            health = np.where(self._flag_columns, health != 0.0, health > 0.5).astype(np.float64)
            self.extra_bins.add(index, times, health)
        if self._offset_index is not None:
            self.last_offsets_um = rows[-1, self._offset_index].copy()
        self._alarm_events(rows)
        self._final_ring(rows)
        self._orbits(k, positions)
        speed = rows[:, SPEED]
        finite = speed[np.isfinite(speed)]
        if finite.size:
            s = self._speed
            s[0], s[1] = min(s[0], float(finite.min())), max(s[1], float(finite.max()))
            s[2] += float(finite.sum())
            s[3] += finite.size
        self.samples += count

    def _alarm_events(self, rows: np.ndarray) -> None:
        starved = rows[:, STARVED] > 0.5
        previous = np.vstack([self.last_starved[None, :], starved[:-1]])
        for b in (0, 1):
            for i in np.flatnonzero(starved[:, b] & ~previous[:, b]):
                consistent = None if self._consistent is None else bool(rows[i, self._consistent] > 0.5)
                self.alarms.append(
                    {"bearing": b + 1, "time_s": float(rows[i, TIME]), "consistent": consistent}
                )
            for i in np.flatnonzero(~starved[:, b] & previous[:, b]):
                for alarm in reversed(self.alarms):
                    if alarm["bearing"] == b + 1 and "cleared_s" not in alarm:
                        alarm["cleared_s"] = float(rows[i, TIME])
                        break
        self.last_starved = starved[-1].copy()

    def _final_ring(self, rows: np.ndarray) -> None:
        self._final.add(np.column_stack([rows[:, Q], rows[:, STD]]))

    def _orbits(self, k: np.ndarray, positions: np.ndarray) -> None:
        if self._start_count < self._orbit_n:
            take = self._orbit_n - self._start_count
            self._start_k.append(k[:take])
            self._start_p.append(positions[:take])
            self._start_count += min(take, k.size)
        self._end.add(np.column_stack([k, positions]))

    def final_means(self, window_s: float) -> dict:
        """Mean estimate and mean reported std over the last ``window_s`` (and the estimate's spread)."""
        tail = self._final.last(max(1, round(window_s / self.dt)))
        out = {}
        for b in (0, 1):
            q, std = tail[:, b], tail[:, 2 + b]
            out[f"q{b + 1}_final_ml_min"] = _finite(np.nanmean(q))
            out[f"q{b + 1}_std_final_ml_min"] = _finite(np.nanmean(std))
            out[f"q{b + 1}_spread_final_ml_min"] = _finite(np.nanstd(q))
        return out

    def speed_summary(self, model_speed_hz: float) -> dict:
        low, high, total, count = self._speed
        if count == 0:
            return {"model_speed_hz": model_speed_hz, "recorded": False}
        deviation = max(abs(low - model_speed_hz), abs(high - model_speed_hz)) / model_speed_hz
        return {
            "model_speed_hz": model_speed_hz,
            "recorded": True,
            "min_hz": low,
            "max_hz": high,
            "mean_hz": total / count,
            "max_deviation_fraction": deviation,
        }

    def orbits(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """{"start": (k, positions), "end": (k, positions)} at full rate (positions [um])."""
        start = (np.concatenate(self._start_k), np.vstack(self._start_p)) if self._start_p else None
        end = self._end.last(self._orbit_n)
        return {"start": start, "end": (end[:, 0].astype(np.int64), end[:, 1:])}


STATUS_PREFIX = "probe_status_"


def _is_health(name: str) -> bool:
    """The estimator's health outputs drawn in the probe-health view: each probe's status and the model's
    consistency and mismatch status (an alarm's consistency is in the alarm list)."""
    return name.startswith(STATUS_PREFIX) or name in ("model_consistent", "model_mismatch")


def _finite(value: float) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def offsets_in_model_frame(offsets_um: np.ndarray, probe_angle_deg: float) -> np.ndarray:
    """(4,) probe offsets along the axes of pairs at ``probe_angle_deg`` -> (x1, y1, x2, y2) offsets [um]
    (the inverse of ``oilwatch.estimator.measurement.probe_rotation``)."""
    angle = math.radians(probe_angle_deg)
    c, s = math.cos(angle), math.sin(angle)
    out = np.empty(4)
    for b in (0, 1):
        along_x, along_y = offsets_um[2 * b], offsets_um[2 * b + 1]
        out[2 * b], out[2 * b + 1] = c * along_x - s * along_y, s * along_x + c * along_y
    return out
