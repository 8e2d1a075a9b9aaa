"""oilwatch: the co-simulation master, the scenarios and the command line."""

from pathlib import Path as _Path

from oilwatch.kernel_cache import refresh as _refresh_kernel_cache

_refresh_kernel_cache(_Path(__file__).parent)
