"""What ``oilwatch estimate`` measures of itself, in memory bounded whatever the record's length: the CPU
time spent so far at uniform sample counts (the cost per sample along the record: does it grow with the
length?) and, from standard input, the latency from a line's arrival to its estimate written (a histogram:
a live pipe may run for days)."""

from __future__ import annotations

import math

import numpy as np

MAX_CPU_MARKS = 1024
"""Marks kept at most: twice as far apart whenever there would be more."""
LATENCY_RANGE_S = (1e-6, 100.0)
LATENCY_BINS_PER_DECADE = 200
"""The latency histogram's log-spaced bins: a quantile is known to 1.2 % (one bin)."""


class CpuMarks:
    """(samples estimated, CPU time) about every :attr:`spacing` samples from (0, 0)."""

    def __init__(self, spacing: int) -> None:
        self.spacing = max(1, spacing)
        self.marks: list[tuple[int, float]] = [(0, 0.0)]
        self._next = self.spacing

    def add(self, done: int, cpu_s: float, last: bool = False) -> None:
        """Mark ``done`` samples at ``cpu_s`` when due (``last``: whenever new samples were done)."""
        if done < self._next and not (last and done > self.marks[-1][0]):
            return
        self.marks.append((done, cpu_s))
        self._next = done + self.spacing
        if len(self.marks) > MAX_CPU_MARKS:
            self.marks = self.marks[::2]
            self.spacing *= 2

    def by_tenth_us(self) -> list[float] | None:
        """CPU time per sample [us] in each tenth of the samples, interpolated between the marks (a tenth
        shorter than their spacing gets the mean around it); None with fewer than 10 marks."""
        if len(self.marks) < 10:
            return None
        samples, cpu = np.array(self.marks, dtype=float).T
        edges = np.linspace(0.0, samples[-1], 11)
        spent = np.diff(np.interp(edges, samples, cpu))
        return [round(float(value), 2) for value in spent / np.diff(edges) * 1e6]


class LatencyHistogram:
    """Latencies [s] counted in log-spaced bins over :data:`LATENCY_RANGE_S` (outside: the end bins), with
    the exact count and largest value."""

    def __init__(self) -> None:
        low, high = LATENCY_RANGE_S
        self._decades = math.log10(high / low)
        self._bins = round(self._decades * LATENCY_BINS_PER_DECADE)
        self.counts = np.zeros(self._bins, dtype=np.int64)
        self.count = 0
        self.largest_s = 0.0

    def add(self, latency_s: float) -> None:
        low = LATENCY_RANGE_S[0]
        position = math.log10(max(latency_s, low) / low) / self._decades * self._bins
        self.counts[min(self._bins - 1, int(position))] += 1
        self.count += 1
        self.largest_s = max(self.largest_s, latency_s)

    def quantile_s(self, q: float) -> float:
        """The ``q`` quantile, at the geometric centre of its bin (at most the largest value)."""
        index = int(np.searchsorted(np.cumsum(self.counts), q * self.count, side="left"))
        low = LATENCY_RANGE_S[0]
        centre = low * 10.0 ** ((min(index, self._bins - 1) + 0.5) / self._bins * self._decades)
        return min(centre, self.largest_s)

    def summary_ms(self) -> dict | None:
        if self.count == 0:
            return None
        return {
            "median": round(self.quantile_s(0.5) * 1e3, 4),
            "p99": round(self.quantile_s(0.99) * 1e3, 4),
            "max": round(self.largest_s * 1e3, 4),
            "blocks": self.count,
        }
