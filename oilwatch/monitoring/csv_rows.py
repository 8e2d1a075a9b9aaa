"""estimates.csv rows as text, fast: fixed-point decimal formatting of a float block in numba.

Python's ``"%.9g" % row`` costs about 0.2 us per value, 8-14 us per 42-column estimate row: at 1 kHz that is a
fifth of the estimator's own step and the largest cost of ``oilwatch estimate`` after it. Here a block of rows
is written into one byte buffer by a compiled loop (under 0.05 us per value). Each column has a fixed number
of decimals (rounded half away from zero, trailing zeros and a bare decimal point dropped, so flags read
``0``/``1``); a missing value (NaN) is an empty cell, as in the record format; +-inf is ``inf``/``-inf``. A
value too large for 18 digits at its decimals (> 9.2e18 / 10^decimals) is written by Python's ``repr``
instead (the whole block; never met in an estimate, kept so that nothing is ever written wrong).
"""

from __future__ import annotations

from typing import TextIO

import numba
import numpy as np

LARGEST_SCALED = 9.2e18
"""|value| x 10^decimals must stay below this for the int64 digit loop."""
PAIRS = np.frombuffer("".join(f"{i:02d}" for i in range(100)).encode(), dtype=np.uint8)
"""The ASCII digits of 00 ... 99, two bytes each: the digit loop writes two digits per division."""


@numba.njit(cache=True)
def _format_block(rows, decimals, out):  # pragma: no cover - compiled; covered through format_rows
    """Write ``rows`` (n, m) into ``out`` (bytes, large enough) as CSV lines; return the length, or -1 when a
    value is too large for the digit loop."""
    n, m = rows.shape
    pos = 0
    digits = np.empty(20, dtype=np.uint8)
    powers = np.empty(m, dtype=np.int64)
    for j in range(m):
        powers[j] = 10 ** decimals[j]
    for i in range(n):
        for j in range(m):
            if j > 0:
                out[pos] = 44  # ,
                pos += 1
            v = rows[i, j]
            if v != v:
                continue  # NaN: an empty cell
            if v < 0.0:
                negative = True
                v = -v
            else:
                negative = False
            if v == np.inf:
                if negative:
                    out[pos] = 45
                    pos += 1
                out[pos] = 105  # inf
                out[pos + 1] = 110
                out[pos + 2] = 102
                pos += 3
                continue
            d = decimals[j]
            power = powers[j]
            scaled_f = v * power + 0.5
            if scaled_f >= LARGEST_SCALED:
                return -1
            scaled = np.int64(scaled_f)
            whole = scaled // power
            fraction = scaled - whole * power
            while d > 0 and fraction % 10 == 0:  # drop trailing zeros
                fraction //= 10
                d -= 1
            if negative and scaled != 0:
                out[pos] = 45  # -
                pos += 1
            count = 0  # the whole part's digits, last first, two at a time
            while whole >= 100:
                pair = 2 * (whole % 100)
                whole //= 100
                digits[count] = PAIRS[pair + 1]
                digits[count + 1] = PAIRS[pair]
                count += 2
            if whole >= 10:
                digits[count] = PAIRS[2 * whole + 1]
                digits[count + 1] = PAIRS[2 * whole]
                count += 2
            else:
                digits[count] = 48 + whole
                count += 1
            for c in range(count - 1, -1, -1):
                out[pos] = digits[c]
                pos += 1
            if d > 0:
                out[pos] = 46  # .
                pos += 1
                c = d - 1
                while c >= 1:
                    pair = 2 * (fraction % 100)
                    fraction //= 100
                    out[pos + c] = PAIRS[pair + 1]
                    out[pos + c - 1] = PAIRS[pair]
                    c -= 2
                if c == 0:
                    out[pos] = 48 + fraction
                pos += d
        out[pos] = 10  # newline
        pos += 1
    return pos


def format_rows(rows: np.ndarray, decimals: np.ndarray) -> str:
    """CSV text of ``rows`` (n, m) with ``decimals`` (m,) per column (module docstring)."""
    rows = np.ascontiguousarray(rows, dtype=np.float64)
    n, m = rows.shape
    out = np.empty(n * (m * 24 + 1), dtype=np.uint8)
    length = _format_block(rows, np.asarray(decimals, dtype=np.int64), out)
    if length >= 0:
        return out[:length].tobytes().decode("ascii")
    return "".join(
        ",".join("" if value != value else repr(value) for value in row) + "\n" for row in rows.tolist()
    )


class RowWriter:
    """estimates.csv (and the live stream, e.g. standard output), flushed after every block; every
    ``every``-th row is written, counted over the whole run."""

    def __init__(self, file: TextIO, live: TextIO | None, every: int) -> None:
        self.file, self.live, self.every = file, live, every
        self.samples = 0
        """Samples given so far (written or skipped): where a resumed run continues the every-N-th count."""
        self._decimals = np.zeros(0, dtype=np.int64)

    def header(self, columns: list[str], decimals: np.ndarray, to_file: bool = True) -> None:
        """Write the header line (to the file only when ``to_file``: a resumed file has it)."""
        self._decimals = np.asarray(decimals, dtype=np.int64)
        line = ",".join(columns) + "\n"
        for target in (self.file if to_file else None, self.live):
            if target is not None:
                target.write(line)
                target.flush()

    def write(self, rows: np.ndarray) -> None:
        every = self.every
        start = (-self.samples) % every
        self.samples += rows.shape[0]
        picked = rows[start::every]
        if picked.shape[0] == 0:
            return
        text = format_rows(picked, self._decimals)
        self.file.write(text)
        self.file.flush()  # a text file's; oilwatch.outputs.rows.RowFile writes at once, whole rows
        if self.live is not None:
            self.live.write(text)
            self.live.flush()
