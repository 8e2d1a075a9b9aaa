"""The bins behind estimate's views (oilwatch.monitoring.history): running means over fixed bins that widen
(pairs merged) past a cap, the same whatever the block sizes, equal to the direct means over the final bins;
the trend of a long record stays within its cap; the summary's CPU cost per tenth of the record."""

from __future__ import annotations

import types

import numpy as np

from oilwatch.monitoring.history import MAX_TREND_BINS, History, _Bins
from oilwatch.monitoring.timing import CpuMarks, LatencyHistogram


def _direct(values: np.ndarray, times: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Means over whole bins of ``size`` samples, a trailing part-filled bin averaged into the one before."""
    starts = np.arange(0, values.shape[0], size)
    if values.shape[0] % size and starts.size > 1:
        starts = starts[:-1]
    finite = np.isfinite(values)
    sums = np.add.reduceat(np.where(finite, values, 0.0), starts, axis=0)
    counts = np.add.reduceat(finite.astype(float), starts, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return times[starts], np.where(counts > 0, sums / counts, np.nan)


def test_bins_widen_past_their_cap_and_equal_the_direct_means_whatever_the_blocks():
    rng = np.random.default_rng(3)
    n = 10_007
    values = rng.normal(size=(n, 3))
    values[rng.random((n, 3)) < 0.05] = np.nan
    values[2000:2300, 1] = np.nan  # whole bins without a finite value stay NaN
    times = 1e-3 * np.arange(n) + 0.5
    results = []
    for cuts in (np.array([n]), np.sort(rng.choice(np.arange(1, n), 40, replace=False)), np.arange(1, n, 7)):
        bins = _Bins(5, 3, max_bins=300)
        for start, stop in zip(np.r_[0, cuts], np.r_[cuts, n], strict=True):
            if stop > start:
                bins.add(np.arange(start, stop), times[start:stop], values[start:stop])
        assert bins.size == 5 * 2**3  # 10 007 / 5 = 2002 bins -> 1001, 501, 251 <= 300
        results.append(bins.arrays())
    expected_t, expected = _direct(values, times, 40)
    for t, means in results:
        np.testing.assert_array_equal(t, expected_t)
        np.testing.assert_allclose(means, expected, rtol=1e-12, equal_nan=True)


def test_a_trailing_bin_of_one_sample_is_averaged_into_the_whole_bin_before_it():
    """The centreline's last point (and its e/c) and the NIS panel's last value: a record one sample past a
    bin's edge ends on a mean over 501 samples, not on that one sample."""
    values = np.full((1001, 1), 1.0)
    values[-1] = 100.0  # the last sample alone would draw a point at 100
    bins = _Bins(500, 1, max_bins=100)
    bins.add(np.arange(1001), 1e-3 * np.arange(1001), values)
    times, means = bins.arrays()
    np.testing.assert_array_equal(times, [0.0, 0.5])
    np.testing.assert_allclose(means[:, 0], [1.0, (500 * 1.0 + 100.0) / 501])
    whole = _Bins(500, 1, max_bins=100)  # a record ending on an edge keeps every bin as it is
    whole.add(np.arange(1000), 1e-3 * np.arange(1000), values[:1000])
    assert whole.arrays()[0].size == 2


def test_the_trend_of_a_long_record_stays_within_its_cap():
    columns = ["time_s", "q1", "q2", "s1", "s2", "starved1", "starved2", "nis", "n", "converged", "ok"]
    columns += ["x1_um", "y1_um", "x2_um", "y2_um", "speed_hz", "oil_temperature_c"]
    history = History(1e-3, 75.0, (1e-4, 1e-4))
    block_rows = 8192
    total = 600 * 1000  # 10 min at 1 kHz: 60 000 trend bins of 10 ms before the cap
    for start in range(0, total, block_rows):
        k = np.arange(start, min(total, start + block_rows)) + 1
        rows = np.zeros((k.size, len(columns)))
        rows[:, 0], rows[:, 1:3], rows[:, 3:5] = k * 1e-3, 600.0, 3.0
        history.add(types.SimpleNamespace(k=k), rows, columns)
    history.flush()
    times, values = history.trend.arrays()
    assert MAX_TREND_BINS // 2 < times.size <= MAX_TREND_BINS
    np.testing.assert_allclose(values[:, :2], 600.0)
    assert history.samples == total


def test_the_cost_per_tenth_of_the_record_follows_the_cpu_marks_whose_spacing_doubles():
    marks = CpuMarks(10)
    done, cpu = 0, 0.0
    while done < 100_000:  # 40 us per sample in the first half, 60 in the second
        done += 7
        cpu += 7 * (40e-6 if done <= 50_000 else 60e-6)
        marks.add(done, cpu)
    marks.add(done, cpu, last=True)
    assert len(marks.marks) <= 1024 and marks.spacing > 10
    tenths = marks.by_tenth_us()
    np.testing.assert_allclose(tenths[:4], 40.0, rtol=1e-3)
    np.testing.assert_allclose(tenths[6:], 60.0, rtol=1e-3)
    assert CpuMarks(8192).by_tenth_us() is None


def test_the_latency_histogram_gives_quantiles_to_its_bin_width_and_the_exact_maximum():
    rng = np.random.default_rng(5)
    latencies = rng.lognormal(np.log(6e-4), 0.8, 20_000)
    histogram = LatencyHistogram()
    for value in latencies:
        histogram.add(float(value))
    summary = histogram.summary_ms()
    assert summary["blocks"] == latencies.size and summary["max"] == round(latencies.max() * 1e3, 4)
    for key, q in (("median", 0.5), ("p99", 0.99)):
        assert abs(summary[key] / (np.quantile(latencies, q) * 1e3) - 1.0) < 0.015
