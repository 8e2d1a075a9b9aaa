"""The compiled Catmull-Rom kernels of the dimensionless bearing table, and its slice at one operating point.

:class:`~oilwatch.models.bearing.operating_table.OperatingTable` pads its (ln S, f) grid with ghost nodes
(:mod:`oilwatch.models.catmull_rom`); :func:`interpolate_point` evaluates it and its two derivatives at any
point. A filter or a plant that evaluates many flowrates at one (speed, viscosity, load) interpolates in S
once (:func:`interpolate_column`, :class:`TableSlice`) and then only in f per call (:func:`interpolate_rows`).
In f, one grid across the flooded threshold, or (``one_sided``) two: the starved nodes (f <= 1) and the
flooded ones (f >= 1), each ending on its one-sided limit on the threshold, where the coefficients jump.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numba
import numpy as np

from .. import catmull_rom
from ..validation import InputError
from .sommerfeld import ON_THRESHOLD
from .supply import ML_MIN_PER_M3_S

if TYPE_CHECKING:
    from .operating_table import OperatingTable


@numba.njit(cache=True)
def interpolate_point(padded, s, f, s0, hs, ns, f0, hf, nf, out):  # pragma: no cover - compiled
    """Values, d/d ln S and d/d f (rows of ``out`` (3, 11)) at (ln S = s, f) on the padded grid."""
    i, ts = catmull_rom.cell(s, s0, hs, ns)
    j, tf = catmull_rom.cell(f, f0, hf, nf)
    ws, dws = catmull_rom.weights(ts)
    wf, dwf = catmull_rom.weights(tf)
    out[:, :] = 0.0
    for a in range(4):
        for b in range(4):
            node = padded[i + a, j + b]
            for k in range(node.shape[0]):
                out[0, k] += ws[a] * wf[b] * node[k]
                out[1, k] += dws[a] * wf[b] * node[k] / hs
                out[2, k] += ws[a] * dwf[b] * node[k] / hf


class TableSlice:
    """The dimensionless table at one (speed, viscosity, load): interpolated in S once, in f per call.

    Attributes: sommerfeld, flooded_threshold_m3_s q_t, flowrate_range_m3_s; :meth:`rows` as
    ``OperatingTable.evaluate_many``.
    """

    def __init__(
        self,
        table: OperatingTable,
        speed_hz: float,
        viscosity_pa_s: float,
        load_n: float,
        one_sided: bool = False,
    ):
        g = table.geometry
        r, c, length = g["radius_m"], g["clearance_m"], g["length_m"]
        self.sommerfeld = viscosity_pa_s * speed_hz * length * 2.0 * r * (r / c) ** 2 / load_n
        where = f"the operating point ({speed_hz:g} Hz, {viscosity_pa_s:.4g} Pa s, {load_n:.5g} N)"
        threshold, columns = table.columns_at(self.sommerfeld, one_sided, where)
        self.flooded_threshold_m3_s = math.exp(threshold) * math.pi * speed_hz * r * c * length
        low, high = table.fraction_range
        self.flowrate_range_m3_s = (low * self.flooded_threshold_m3_s, high * self.flooded_threshold_m3_s)
        self._table, self._where, self._columns = table, where, columns
        self._scale = np.concatenate(
            [np.full(2, c), np.full(4, load_n / c), np.full(4, load_n / (c * 2.0 * math.pi * speed_hz))]
        )

    def rows(self, q_m3_s) -> np.ndarray:
        """Rows (m, 10) ``[e_x, e_y, K, C]`` (SI) at the flowrates (m,) [m^3/s]."""
        q = np.atleast_1d(np.asarray(q_m3_s, dtype=float))
        fraction = q / self.flooded_threshold_m3_s
        table = self._table
        low, high = table.fraction_range
        if not (fraction.min() >= low - 1e-12 and fraction.max() <= high + 1e-12):
            bad = fraction.min() if fraction.min() < low - 1e-12 else fraction.max()
            raise InputError(
                f"supply flowrate {bad * self.flooded_threshold_m3_s * ML_MIN_PER_M3_S:.5g} ml/min "
                f"({bad * 100:.4g} % of the flooded threshold) is outside the table's [{low * 100:.4g}, "
                f"{high * 100:.4g}] % at {self._where} (no extrapolation)"
            )
        value = np.zeros((q.size, 10))
        if len(self._columns) == 1:
            sides = (np.ones(fraction.size, dtype=bool),)
        else:
            sides = (fraction <= 1.0 + ON_THRESHOLD, fraction >= 1.0 - ON_THRESHOLD)
        for on_side, (column, f0, n) in zip(sides, self._columns, strict=True):
            if on_side.any():
                part = np.empty((int(on_side.sum()), 10))
                interpolate_rows(column, fraction[on_side], f0, table.fraction_step, n, part)
                value[on_side] += part
        if len(sides) == 2:
            value[sides[0] & sides[1]] *= 0.5  # on the threshold: the mean of the one-sided limits
        value *= self._scale
        return value


@numba.njit(cache=True)
def interpolate_column(padded, log_threshold, s, s0, hs, ns, column):  # pragma: no cover - compiled
    """Interpolate the padded grid in ln S at s into ``column`` (n_f + 2, 11); return ln(q_t / q_c) there."""
    i, ts = catmull_rom.cell(s, s0, hs, ns)
    ws, _ = catmull_rom.weights(ts)
    column[:, :] = 0.0
    threshold = 0.0
    for a in range(4):
        threshold += ws[a] * log_threshold[i + a]
        for j in range(column.shape[0]):
            for k in range(column.shape[1]):
                column[j, k] += ws[a] * padded[i + a, j, k]
    return threshold


@numba.njit(cache=True)
def interpolate_rows(column, fractions, f0, hf, nf, out):  # pragma: no cover - compiled
    """The first 10 values of a column (n_f + 2, 11) at each f of ``fractions`` into ``out`` (m, 10)."""
    for m in range(fractions.shape[0]):
        j, tf = catmull_rom.cell(fractions[m], f0, hf, nf)
        wf, _ = catmull_rom.weights(tf)
        for k in range(out.shape[1]):
            acc = 0.0
            for b in range(4):
                acc += wf[b] * column[j + b, k]
            out[m, k] = acc
