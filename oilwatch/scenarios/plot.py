"""estimates.png in the style of the paper's Figs. 10-12: per bearing, the true and the estimated supply
flowrate [ml/min] against time [s], with the estimate's +-2 std band, the nominal flowrate, the alarm's set
threshold (as in ``oilwatch estimate``'s trend view), the centre of the flowrate change and the alarms."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from oilwatch.outputs.atomic import atomic_path

from . import ScenarioRun


def _rising_edges(time_s: np.ndarray, alarm: np.ndarray) -> np.ndarray:
    on = alarm != 0
    return time_s[np.flatnonzero(on & ~np.concatenate(([False], on[:-1])))]


def plot_estimates(run: ScenarioRun, columns: dict[str, np.ndarray], summary: dict, path: str | Path) -> Path:
    """Draw the figure from result.csv ``columns`` and the run ``summary``; return ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from oilwatch.estimator.alarm_config import AlarmConfig

    time_s = columns["time_s"]
    on_fraction = float(run.ekf_parameters().get("alarm_on_fraction", AlarmConfig().on_fraction))
    figure, axes = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True, constrained_layout=True)
    for b, ax in zip((1, 2), axes, strict=True):
        nominal = run.nominal_ml_min[b - 1]
        true, estimate = columns[f"q{b}_true_ml_min"], columns[f"q{b}_est_ml_min"]
        std = columns[f"q{b}_std_ml_min"]
        ax.fill_between(time_s, estimate - 2 * std, estimate + 2 * std, color="C0", alpha=0.25, lw=0,
                        label="estimate +- 2 std")  # fmt: skip
        ax.plot(time_s, estimate, color="C0", lw=1.0, label="estimated")
        ax.plot(time_s, true, color="k", lw=1.4, ls="--", label="true")
        ax.axhline(nominal, color="0.4", ls="--", lw=0.8, label=f"nominal {nominal:.1f}")
        ax.axhline(on_fraction * nominal, color="C3", ls=":", lw=0.8,
                   label=f"alarm set ({100 * on_fraction:.0f} % of nominal)")  # fmt: skip
        ax.axvline(run.fault_time_s, color="0.5", lw=0.8, ls="-.", label="centre of the flow change")
        for k, at in enumerate(_rising_edges(time_s, columns[f"starved{b}"])):
            ax.axvline(at, color="C3", lw=1.2, label="starvation alarm" if k == 0 else None)
        before, after = summary.get(f"q{b}_err_pct_before"), summary.get(f"q{b}_err_pct_after")
        delay = summary.get(f"alarm_delay_s_b{b}")
        note = "error before {}, after {}; alarm {}".format(
            "n/a" if before is None else f"{before:.2f} %",
            "n/a" if after is None else f"{after:.2f} %",
            "none" if delay is None else f"{delay:+.2f} s from the centre",
        )
        ax.set_title(f"Bearing {b}: {note}", fontsize=9)
        ax.set_ylabel(f"q{b} [ml/min]")
        # Limits from the truth: the first few samples' excursion (P0 is wide) would flatten the rest.
        margin = 0.15 * (true.max() - true.min()) + 40.0
        low, high = min(true.min(), on_fraction * nominal), max(true.max(), nominal)
        ax.set_ylim(low - margin, high + margin)
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    figure.suptitle(f"{run.scenario.title} ({run.scenario.name}), measurement noise {run.noise_um:g} um")
    path = Path(path)
    with atomic_path(path) as temporary:  # whole or not at all (oilwatch.outputs.atomic)
        figure.savefig(temporary, dpi=120, format="png")
    plt.close(figure)
    return path
