"""Progress bars of the command line: tqdm bars driven by the ``progress(done, total)`` callbacks of
``models`` and ``estimator``, which report progress without importing tqdm (code bundled in an FMU imports
only numpy, scipy and numba, as fmpy's callbacks do)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

Progress = Callable[[int, int], None]
"""``progress(done, total)``: called after each unit of work."""


@contextmanager
def progress_bar(description: str, unit: str = "it", enabled: bool = True) -> Iterator[Progress | None]:
    """A ``progress(done, total)`` callback drawing a tqdm bar on stderr (None when not ``enabled``)."""
    if not enabled:
        yield None
        return
    from tqdm import tqdm

    bar = tqdm(desc=description, unit=unit, file=sys.stderr, mininterval=0.5)

    def update(done: int, total: int) -> None:
        if bar.total != total:
            bar.total = total
        bar.update(done - bar.n)

    try:
        yield update
    finally:
        bar.close()
