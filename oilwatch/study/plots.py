"""Error maps of the study (the paper's Figs. 7-8): |relative error| of q1 and q2 over the (q1, q2) grid."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from oilwatch.outputs.atomic import atomic_path


def error_grid(rows: Sequence[dict], percents: np.ndarray) -> np.ndarray:
    """(2, n, n) mean |relative error| [%] of q1 and q2, indexed [bearing, q2 level, q1 level].

    percents: (n,) the grid's flowrate levels [% of nominal]; cells without a finished case are NaN; with
    several seeds a cell holds the mean over the seeds.
    """
    index = {round(float(p), 6): i for i, p in enumerate(percents)}
    total = np.zeros((2, percents.size, percents.size))
    count = np.zeros((percents.size, percents.size))
    for row in rows:
        i, j = index[round(row["q2_pct"], 6)], index[round(row["q1_pct"], 6)]
        total[:, i, j] += np.abs([row["q1_err_pct"], row["q2_err_pct"]])
        count[i, j] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def _edges(percents: np.ndarray) -> np.ndarray:
    """Cell edges around grid levels given in any order."""
    levels = np.sort(percents)
    if levels.size == 1:
        return np.array([levels[0] - 0.5, levels[0] + 0.5])
    middle = 0.5 * (levels[1:] + levels[:-1])
    return np.concatenate([[2 * levels[0] - middle[0]], middle, [2 * levels[-1] - middle[-1]]])


def plot_error_map(
    rows: Sequence[dict],
    percents: np.ndarray,
    noise_um: float,
    path: str | Path,
    note: str = "",
    nominal_ml_min: tuple[float, float] | None = None,
) -> Path:
    """Save the two-panel error map of one noise level to ``path`` (PNG) and return the path; the axes are
    percentages of each bearing's ``nominal_ml_min`` (default: the bundled turbine's nominal flowrates).

    Each panel: the |relative error| of one bearing's identified flowrate over (q1 %, q2 %), a colour bar,
    its largest error marked with a circle; the study's worst case (over both bearings) with a star.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .grid import bundled_nominal_ml_min

    nominal = [round(q, 1) for q in (bundled_nominal_ml_min() if nominal_ml_min is None else nominal_ml_min)]
    order = np.argsort(percents)
    levels = np.asarray(percents)[order]
    grid = error_grid(rows, percents)[:, order][:, :, order]
    edges = _edges(levels)
    finite = grid[np.isfinite(grid)]
    vmax = float(finite.max()) if finite.size else 1.0
    worst = np.unravel_index(np.nanargmax(grid), grid.shape) if finite.size else None
    figure, axes = plt.subplots(1, 2, figsize=(11.5, 4.8), constrained_layout=True)
    for bearing, axis in enumerate(axes):
        mesh = axis.pcolormesh(edges, edges, grid[bearing], cmap="viridis", vmin=0.0, vmax=vmax)
        figure.colorbar(mesh, ax=axis, label=f"|relative error of q{bearing + 1}| [%]")
        if np.isfinite(grid[bearing]).any():
            i, j = np.unravel_index(np.nanargmax(grid[bearing]), grid[bearing].shape)
            axis.plot(
                levels[j],
                levels[i],
                "o",
                mfc="none",
                mec="red",
                ms=12,
                mew=2,
                label=f"max {grid[bearing, i, j]:.2f} %",
            )
        if worst is not None and worst[0] == bearing:
            axis.plot(
                levels[worst[2]],
                levels[worst[1]],
                "*",
                color="white",
                mec="black",
                ms=16,
                label="worst case of the study",
            )
        axis.set_xlabel(f"q1 [% of {nominal[0]:g} ml/min]")
        axis.set_ylabel(f"q2 [% of {nominal[1]:g} ml/min]")
        axis.set_title(f"identified q{bearing + 1}")
        axis.set_aspect("equal")
        axis.legend(loc="lower left", fontsize=8, framealpha=0.8)
    suffix = f" ({note})" if note else ""
    figure.suptitle(f"Relative error of the identified supply flowrates, sigma_v = {noise_um:g} um{suffix}")
    path = Path(path)
    with atomic_path(path) as temporary:  # whole or not at all
        figure.savefig(temporary, dpi=110, format="png")
    plt.close(figure)
    return path


def error_map_name(noise_um: float) -> str:
    """File name of a noise level's map: ``error_map_sigma1.png`` for 1 um."""
    return f"error_map_sigma{noise_um:g}.png"
