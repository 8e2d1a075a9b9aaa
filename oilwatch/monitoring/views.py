"""The views a monitoring engineer expects from the estimates (matplotlib, PNG files):

* ``trend.png``: each bearing's flowrate estimate with its +-2 std band, the nominal flowrate, the alarm's
  set threshold and the alarms (shaded while set);
* ``centerline.png``: the shaft centreline plot, the average journal position (0.5 s means) inside the
  clearance circle over time, from the bearing centre, with the cold-rest position at the bottom; less the
  estimator's final probe offset estimates when it estimates them (the offsets are what separates the probes'
  zero from the bearing centre);
* ``orbits.png``: the 1x-filtered orbits (the synchronous component over whole revolutions, phase-referenced
  to the estimator's rotor angle, i.e. to the keyphasor when there is one) of the first and the last second,
  about their mean position, with the keyphasor dot (rotor angle 0);
* ``probe_health.png``: per probe the fraction of valid samples, the fraction of samples the estimator
  accepted, the mean NIS against its expectation, and the share of samples each probe was flagged faulty
  (``probe_status`` != 0) and the model inconsistent.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from oilwatch.outputs.atomic import atomic_path

from .history import History, offsets_in_model_frame

VIEW_FILES = {
    "trend": "trend.png",
    "centerline": "centerline.png",
    "orbits": "orbits.png",
    "probe_health": "probe_health.png",
}
PROBES = ("x1", "y1", "x2", "y2")


def write_views(history: History, summary: dict, out_dir: Path) -> dict[str, Path]:
    """Draw the four views into ``out_dir``; return their paths by name."""
    import matplotlib

    matplotlib.use("Agg")
    paths = {}
    for name, draw in (
        ("trend", _trend),
        ("centerline", _centerline),
        ("orbits", _orbits),
        ("probe_health", _probe_health),
    ):
        figure = draw(history, summary)
        path = out_dir / VIEW_FILES[name]
        with atomic_path(path) as temporary:  # whole or not at all (oilwatch.outputs.atomic)
            figure.savefig(temporary, dpi=110, format="png")
        import matplotlib.pyplot as plt

        plt.close(figure)
        paths[name] = path
    return paths


def _trend(history: History, summary: dict):
    import matplotlib.pyplot as plt

    times, values = history.trend.arrays()
    figure, axes = plt.subplots(2, 1, figsize=(9, 6.3), sharex=True, layout="constrained")
    for b, ax in enumerate(axes):
        nominal = summary[f"q{b + 1}_nominal_ml_min"]
        q, std, starved = values[:, b], values[:, 2 + b], values[:, 4 + b] > 0.5
        ax.fill_between(times, q - 2 * std, q + 2 * std, color="tab:blue", alpha=0.25, label="+-2 std")
        ax.plot(times, q, color="tab:blue", lw=1.2, label="estimate")
        ax.axhline(nominal, color="0.4", ls="--", lw=0.8, label=f"nominal {nominal:.1f}")
        ax.axhline(0.9 * nominal, color="tab:red", ls=":", lw=0.8, label="alarm set (90 %)")
        if starved.any():
            ax.fill_between(
                times,
                0,
                1,
                where=starved,
                transform=ax.get_xaxis_transform(),
                color="tab:red",
                alpha=0.12,
                label="alarm",
            )
        for alarm in summary["alarms"]:
            if alarm["bearing"] == b + 1:
                ax.axvline(alarm["time_s"], color="tab:red", lw=1.0)
        final = summary.get(f"q{b + 1}_final_ml_min")
        title = f"bearing {b + 1}: {summary['verdict'][f'bearing{b + 1}']}"
        ax.set_title(title if final is not None else f"bearing {b + 1}", fontsize=10)
        ax.set_ylabel("supply flowrate [ml/min]")
        # the range of the converged part: the first 5 % (at most 1 s) hold the start-up transient
        settled = times >= times[0] + min(1.0, 0.05 * (times[-1] - times[0])) if times.size else times
        low = np.nanmin((q - 2 * std)[settled]) if settled.any() else 0.5 * nominal
        high = np.nanmax((q + 2 * std)[settled]) if settled.any() else 1.5 * nominal
        ax.set_ylim(max(0.0, min(low, 0.85 * nominal)), max(high, 1.05 * nominal))
        ax.grid(alpha=0.3)
    # one legend above both panels: inside a panel it hid the band where the estimate sat (seen in a browser)
    handles = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, handle)
    figure.legend(handles.values(), handles.keys(), loc="outside upper center", ncol=6, fontsize=8)
    axes[-1].set_xlabel("record time [s]")
    return figure


def _centerline(history: History, summary: dict):
    import matplotlib.pyplot as plt

    times, values = history.slow.arrays()
    figure, grid = plt.subplots(2, 2, figsize=(9, 8.4), layout="constrained", height_ratios=(1.0, 0.8))
    axes, zooms = grid[0], grid[1]
    circle = np.linspace(0.0, 2.0 * math.pi, 361)
    offsets = offsets_in_model_frame(history.last_offsets_um, history.probe_angle_deg)
    corrected = bool(np.any(offsets != 0.0))
    for b, ax in enumerate(axes):
        clearance_um = history.clearances_m[b] * 1e6
        x, y = values[:, 2 * b] - offsets[2 * b], values[:, 2 * b + 1] - offsets[2 * b + 1]
        ax.plot(clearance_um * np.cos(circle), clearance_um * np.sin(circle), color="0.3", lw=1.0)
        ax.plot([0], [0], "+", color="0.3", ms=10)
        ax.plot([0], [-clearance_um], "v", color="0.3", ms=6, label="cold rest")
        points = ax.scatter(x, y, c=times, s=10, cmap="viridis", zorder=3)
        ax.plot(x, y, color="0.5", lw=0.5, zorder=2)
        ax.set_aspect("equal")
        ax.set_xlim(-1.1 * clearance_um, 1.1 * clearance_um)
        ax.set_ylim(-1.1 * clearance_um, 1.1 * clearance_um)
        seen = np.flatnonzero(np.isfinite(x) & np.isfinite(y))
        if seen.size > 1:
            _zoom(zooms[b], x[seen], y[seen], times[seen], clearance_um)
        else:
            zooms[b].set_axis_off()
        if seen.size:
            last = seen[-1]
            eccentricity = math.hypot(x[last], y[last]) / clearance_um
            ax.annotate(f"last: ({x[last]:.1f}, {y[last]:.1f}) um, e/c = {eccentricity:.3f}", (0.02, 0.97),
                        xycoords="axes fraction", fontsize=8, va="top")  # fmt: skip
        title = f"bearing {b + 1}: average position (0.5 s means)"
        if corrected:
            title += (
                "\nless the estimated probe offsets ("
                + ", ".join(f"{v:+.1f}" for v in offsets[2 * b : 2 * b + 2])
                + " um)"
            )
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("x [um] (horizontal)")
        ax.set_ylabel("y [um] (vertical)")
        ax.legend(fontsize=7, loc="upper right")
        ax.grid(alpha=0.3)
    figure.colorbar(points, ax=grid, label="record time [s]", shrink=0.6)
    return figure


def _zoom(ax, x: np.ndarray, y: np.ndarray, times: np.ndarray, clearance_um: float) -> None:
    """The centreline's path magnified: a few um of lift or sinking are invisible against the clearance
    circle (seen in the browser: the path was one dot)."""
    span = max(float(np.ptp(x)), float(np.ptp(y)), 0.01 * clearance_um)
    cx, cy = 0.5 * (x.min() + x.max()), 0.5 * (y.min() + y.max())
    ax.plot(x, y, color="0.5", lw=0.5)
    ax.scatter(x, y, c=times, s=12, cmap="viridis", vmin=times.min(), vmax=times.max(), zorder=3)
    ax.plot(x[-1:], y[-1:], "o", mfc="none", mec="k", ms=8, label="last")
    ax.set_xlim(cx - 0.65 * span, cx + 0.65 * span)
    ax.set_ylim(cy - 0.65 * span, cy + 0.65 * span)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    ax.set_title(f"the path magnified ({1.3 * span:.2g} um across)", fontsize=9)
    ax.set_xlabel("x [um]")
    ax.set_ylabel("y [um]")


def synchronous_orbit(k: np.ndarray, positions_um: np.ndarray, dt_s: float, speed_hz: float) -> dict | None:
    """The 1x component of (n, 4) positions over the whole revolutions they span: mean (4,), complex
    amplitude (4,) (x(t) = mean + Re(A exp(i Omega t)), t = k dt the model time) and the revolutions used."""
    revolutions = math.floor(k.size * dt_s * speed_hz)
    if revolutions < 1:
        return None
    n = round(revolutions / (speed_hz * dt_s))
    k, p = k[:n], positions_um[:n]
    good = np.isfinite(p)  # per probe: a faulty probe loses its own channel, not the others'
    count = good.sum(axis=0)
    if count.max() < 0.5 * n:
        return None
    phase = np.exp(-1j * 2.0 * math.pi * speed_hz * dt_s * k)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(good, p, 0.0).sum(axis=0) / count
        amplitude = 2.0 * (np.where(good, p - mean, 0.0) * phase[:, None]).sum(axis=0) / count
    short = count < 0.5 * n
    mean[short], amplitude[short] = np.nan, np.nan
    return {"mean": mean, "amplitude": amplitude, "revolutions": revolutions}


def _orbits(history: History, summary: dict):
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 2, figsize=(9, 4.6), constrained_layout=True)
    theta = np.linspace(0.0, 2.0 * math.pi, 181)
    speed = history.speed_hz
    for label, style in (("start", "-"), ("end", "--")):
        data = history.orbits()[label]
        if data is None:
            continue
        fit = synchronous_orbit(data[0], data[1], history.dt, speed)
        if fit is None:
            continue
        for b, ax in enumerate(axes):
            ax_x, ax_y = fit["amplitude"][2 * b], fit["amplitude"][2 * b + 1]
            if not (np.isfinite(ax_x) and np.isfinite(ax_y)):
                continue  # a probe of this bearing was faulty for most of the second
            x = np.real(ax_x * np.exp(1j * theta))
            y = np.real(ax_y * np.exp(1j * theta))
            line = ax.plot(x, y, style, lw=1.4, label=f"{label} ({fit['revolutions']} rev)")[0]
            ax.plot([np.real(ax_x)], [np.real(ax_y)], "o", color=line.get_color(), ms=5)
    for b, ax in enumerate(axes):
        ax.set_aspect("equal", adjustable="datalim")
        ax.plot([0], [0], "+", color="0.3")
        ax.set_title(f"bearing {b + 1}: 1x orbit about its mean (dot: keyphasor)", fontsize=10)
        ax.set_xlabel("x [um]")
        ax.set_ylabel("y [um]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return figure


def _channels_used(history: History, values: np.ndarray) -> np.ndarray:
    """Per slow bin, the mean number of channels in an accepted sample: the probes with data and not
    excluded as faulty, over the share of samples that updated the estimator (a gap takes all four)."""
    usable = values[:, 4:8].copy()
    status = [f"probe_status_{name}" for name in PROBES]
    if history.extra_bins is not None and set(status) <= set(history.extra_names):
        _, extra = history.extra_bins.arrays()
        if extra.shape[0] == usable.shape[0]:
            flagged = extra[:, [history.extra_names.index(name) for name in status]]
            usable = np.clip(usable - flagged, 0.0, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(values[:, 8] > 0, usable.sum(axis=1) / values[:, 8], np.nan)


def _probe_health(history: History, summary: dict):
    import matplotlib.pyplot as plt

    times, values = history.slow.arrays()
    rows = 3 if history.extra_bins is not None else 2
    figure, axes = plt.subplots(rows, 1, figsize=(9, 2.4 * rows + 0.6), sharex=True, constrained_layout=True)
    ax = axes[0]
    for i, name in enumerate(PROBES):
        ax.step(times, 100.0 * values[:, 4 + i], where="post", lw=1.2, label=f"{name} finite")
    ax.step(
        times, 100.0 * values[:, 8], "k--", where="post", lw=1.0, label="samples that updated the estimator"
    )
    ax.set_ylabel("samples [%]")
    ax.set_ylim(-5, 105)
    ax.legend(fontsize=7, ncol=5, loc="lower left")
    ax.grid(alpha=0.3)
    ax.set_title("probe health (0.5 s bins)", fontsize=10)
    ax = axes[1]
    label = "mean NIS of accepted samples"
    ax.step(times, values[:, 9], color="tab:purple", where="post", lw=1.2, label=label)
    # a consistent filter's NIS averages the channels it used: 4, fewer while a probe is dead or excluded
    # (seen in the browser: the NIS "fell" to 3 against a fixed line at 4 while y2 was dead)
    expected = _channels_used(history, values)
    ax.step(times, expected, "--", color="0.4", where="post", lw=0.8, label="expected (channels used)")
    ax.set_ylabel("NIS")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    if history.extra_bins is not None:
        extra_t, extra = history.extra_bins.arrays()
        ax = axes[2]
        for i, name in enumerate(history.extra_names):
            label = (
                f"{name.removeprefix('probe_status_')} flagged faulty"
                if name.startswith("probe_status_")
                else "model inconsistent (NIS test)"
            )
            share = extra[:, i] if name.startswith("probe_status_") else 1.0 - extra[:, i]
            ax.step(extra_t, 100.0 * share, where="post", lw=1.2, label=label)
        ax.set_ylabel("samples [%]")
        ax.set_ylim(-5, 105)
        ax.set_title("estimator: probes excluded as faulty, model consistency", fontsize=10)
        ax.legend(fontsize=7, ncol=5, loc="upper left")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("record time [s]")
    return figure
