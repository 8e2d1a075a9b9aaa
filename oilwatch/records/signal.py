"""Streaming signal conditioning of a record: anti-alias filtering onto the estimator's grid, and the
keyphasor.

* :class:`GridResampler`: a linear-phase FIR low-pass (Kaiser window, :func:`scipy.signal.firwin`,
  :func:`scipy.signal.kaiserord`; Oppenheim & Schafer, Discrete-Time Signal Processing, sec. 7.6) applied at
  the record's rate, its group delay of (N - 1) / 2 samples compensated exactly by giving each output the
  time stamp of the input sample it is centred on, then linear interpolation onto the grid ``k dt`` (exact,
  weight 0 or 1, where the grid falls on a sample, as it does for an integer rate ratio). Pass band to
  0.35 of the grid rate (4.7x the running speed of 75 Hz at 1 kHz), stop band from its Nyquist frequency,
  80 dB; unit gain at 0 Hz (the static position carries most of the flowrate information). A record already
  at the grid's rate is only interpolated. State (the last N - 1 samples) carries across chunks, so the
  output does not depend on how the record was cut; a missing sample (NaN) makes the N outputs whose window
  holds it missing, and nothing more.
* :class:`Keyphasor`: once-per-revolution pulse times, each the threshold crossing interpolated between
  the two samples that straddle it, and the speed from the pulses of the last revolutions.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from oilwatch.models.validation import InputError

PASS_FRACTION = 0.35
"""Pass-band edge as a fraction of the grid's sampling rate."""
STOP_ATTENUATION_DB = 80.0
SAME_RATE_TOLERANCE = 0.01
"""A record within 1 % of the grid's rate is interpolated without filtering."""
SPEED_REVOLUTIONS = 8
"""Revolutions the keyphasor speed is averaged over."""
SNAP = 1e-6
"""An interpolation weight within this of 0 or 1 takes the sample itself (bit-exact pass-through)."""


def anti_alias_taps(input_rate_hz: float, grid_rate_hz: float) -> np.ndarray:
    """Linear-phase low-pass taps (odd length) for resampling from ``input_rate_hz`` to ``grid_rate_hz``."""
    nyquist = 0.5 * input_rate_hz
    low, high = PASS_FRACTION * grid_rate_hz, 0.5 * grid_rate_hz
    numtaps, beta = signal.kaiserord(STOP_ATTENUATION_DB, (high - low) / nyquist)
    numtaps |= 1
    return signal.firwin(numtaps, 0.5 * (low + high), window=("kaiser", beta), fs=input_rate_hz)


class GridResampler:
    """Channels sampled at ``input_rate_hz`` -> the same channels on the grid ``t = k dt`` (module docstring).

    ``filtered`` (m,) bool: which columns get the anti-alias filter; the others (speed, temperature) are
    only delayed by the same group delay, so that every column stays aligned.
    """

    def __init__(self, input_rate_hz: float, grid_dt_s: float, filtered: np.ndarray) -> None:
        grid_rate = 1.0 / grid_dt_s
        if input_rate_hz < grid_rate * (1.0 - SAME_RATE_TOLERANCE):
            raise InputError(
                f"sample rate {input_rate_hz:.6g} Hz is below the estimator's {grid_rate:.6g} Hz: the record "
                "cannot be resampled up to the filter's rate"
            )
        self.dt = grid_dt_s
        self.filtered = np.asarray(filtered, dtype=bool)
        if input_rate_hz <= grid_rate * (1.0 + SAME_RATE_TOLERANCE):
            self.taps = np.ones(1)
        else:
            self.taps = anti_alias_taps(input_rate_hz, grid_rate)
        self.delay = (self.taps.size - 1) // 2
        self._history: np.ndarray | None = None
        self._history_t: np.ndarray | None = None
        self._tail: tuple[float, np.ndarray] | None = None  # last filtered sample (time, values)
        self._next_k: int | None = None
        self._first_time: float | None = None

    @property
    def group_delay_samples(self) -> int:
        return self.delay

    def push(self, time_s: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Add samples (n,) times, (n, m) values; return the grid points now complete: (k,) int grid indices
        and (k, m) values."""
        filtered_t, filtered = self._filter(time_s, values)
        return self._interpolate(filtered_t, filtered)

    def _filter(self, time_s: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n_taps = self.taps.size
        if n_taps == 1:
            return time_s, values
        if self._history is None:
            # start as if the first sample had been there for ever (no start-up transient); the outputs
            # before the first sample are dropped below
            self._first_time = float(time_s[0])
            self._history = np.repeat(values[:1], n_taps - 1, axis=0)
            step = (time_s[-1] - time_s[0]) / max(1, time_s.size - 1)
            self._history_t = time_s[0] - step * np.arange(n_taps - 1, 0, -1)
        extended = np.vstack([self._history, values])
        extended_t = np.concatenate([self._history_t, time_s])
        count = values.shape[0]
        out = np.empty_like(values)
        for j in range(values.shape[1]):
            if self.filtered[j]:
                out[:, j] = np.convolve(extended[:, j], self.taps[::-1], mode="valid")[-count:]
            else:
                out[:, j] = extended[n_taps - 1 - self.delay : n_taps - 1 - self.delay + count, j]
        out_t = extended_t[n_taps - 1 - self.delay : n_taps - 1 - self.delay + count]
        self._history = extended[-(n_taps - 1) :]
        self._history_t = extended_t[-(n_taps - 1) :]
        keep = out_t >= self._first_time
        return out_t[keep], out[keep]

    def _interpolate(self, t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        on_grid = self._on_grid(t)
        if on_grid is not None:
            self._tail = (float(t[-1]), v[-1].copy())
            self._next_k = int(on_grid[-1]) + 1
            return on_grid, v
        if self._tail is not None:
            t = np.concatenate([[self._tail[0]], t])
            v = np.vstack([self._tail[1][None, :], v])
        if t.size == 0:
            return np.zeros(0, dtype=np.int64), np.zeros((0, v.shape[1]))
        self._tail = (float(t[-1]), v[-1].copy())
        dt = self.dt
        if self._next_k is None:
            self._next_k = math.ceil(t[0] / dt - SNAP)
        last_k = math.floor(t[-1] / dt + SNAP)
        if last_k < self._next_k:
            return np.zeros(0, dtype=np.int64), np.zeros((0, v.shape[1]))
        k = np.arange(self._next_k, last_k + 1, dtype=np.int64)
        self._next_k = last_k + 1
        grid = k * dt
        right = np.clip(np.searchsorted(t, grid - SNAP * dt, side="left"), 0, t.size - 1)
        left = np.maximum(right - 1, 0)
        span = t[right] - t[left]
        weight = np.where(span > 0, (grid - t[left]) / np.where(span > 0, span, 1.0), 1.0)
        weight = np.where(np.abs(weight - 1.0) < SNAP, 1.0, np.where(np.abs(weight) < SNAP, 0.0, weight))
        left_v, right_v = v[left], v[right]
        w = weight[:, None]
        out = np.where(w == 1.0, right_v, np.where(w == 0.0, left_v, left_v + w * (right_v - left_v)))
        return k, out

    def _on_grid(self, t: np.ndarray) -> np.ndarray | None:
        """The grid indices of ``t`` when every time is a grid point following the last one (a record at the
        grid's rate, the common case, passed through without interpolation), else None."""
        if t.size == 0 or self.taps.size != 1:
            return None
        position = t / self.dt
        k = np.rint(position)
        if np.abs(position - k).max() > SNAP:
            return None
        k = k.astype(np.int64)
        first = self._next_k if self._next_k is not None else int(k[0])
        if k[0] != first or (k.size > 1 and np.any(np.diff(k) != 1)):
            return None
        return k


class Keyphasor:
    """Once-per-revolution pulses of a keyphasor channel (module docstring); streaming, bounded memory."""

    def __init__(self, edge: str, threshold_v: float | None) -> None:
        self.rising = edge == "rising"
        self.threshold = threshold_v
        self._last: tuple[float, float] | None = None  # previous sample (time, value)
        self._recent = np.zeros(0)  # the pulses of the last chunk and the two before them
        self.count = 0
        self.first: float | None = None

    def push(self, time_s: np.ndarray, volts: np.ndarray) -> np.ndarray:
        """Add samples; return the times of the pulses found in them."""
        if self.threshold is None:
            finite = volts[np.isfinite(volts)]
            if finite.size < 2 or finite.max() - finite.min() <= 0.0:
                raise InputError(
                    "keyphasor: no pulse in the first chunk to set the threshold from; give "
                    "probes.keyphasor_threshold_v"
                )
            self.threshold = 0.5 * (float(finite.max()) + float(finite.min()))
        t, v = time_s, volts
        if self._last is not None:
            t = np.concatenate([[self._last[0]], t])
            v = np.concatenate([[self._last[1]], v])
        if t.size:
            self._last = (float(t[-1]), float(v[-1]))
        above = v > self.threshold
        if self.rising:
            crossing = np.flatnonzero(~above[:-1] & above[1:])
        else:
            crossing = np.flatnonzero(above[:-1] & ~above[1:])
        crossing = crossing[np.isfinite(v[crossing]) & np.isfinite(v[crossing + 1])]
        v0, v1 = v[crossing], v[crossing + 1]
        fraction = (self.threshold - v0) / (v1 - v0)
        times = t[crossing] + fraction * (t[crossing + 1] - t[crossing])
        if times.size and self.first is None:
            self.first = float(times[0])
        self.count += times.size
        self._recent = np.concatenate([self._recent[-SPEED_REVOLUTIONS:], times])
        return times

    def speed_hz(self, time_s: np.ndarray) -> np.ndarray:
        """Speed at ``time_s`` (within the last chunk pushed) over the last :data:`SPEED_REVOLUTIONS` complete
        revolutions before it (fewer at the start; NaN before two pulses): averaging over several periods
        keeps the edge timing error of a coarsely sampled pulse (up to 15 us per period at 5 kHz) out of the
        speed."""
        pulses = self._recent
        out = np.full(time_s.shape, np.nan)
        if pulses.size < 2:
            return out
        last = np.searchsorted(pulses, time_s, side="right") - 1
        first = np.maximum(last - SPEED_REVOLUTIONS, 0)
        ok = last > first
        out[ok] = (last[ok] - first[ok]) / (pulses[last[ok]] - pulses[first[ok]])
        return out
