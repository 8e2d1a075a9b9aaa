"""Build oilwatch's FMUs and SSP system from this source tree: a thin wrapper of ``oilwatch build-fmus``.

Usage::

    python build.py [--out build] [--only NAME ...] [--machine FILE]

The machinery lives in :mod:`oilwatch.cosim.fmu_build` (so that an installed oilwatch builds the FMUs without
a source tree); its names are re-exported here for scripts that ``import build``.
"""

from __future__ import annotations

import sys
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from oilwatch.cosim.fmu_build import (  # noqa: E402
    DEFAULT_OPTIONS,
    REGISTRY,
    FmuEntry,
    SspEntry,
    build_fmu,
    build_fmus,
    main,
    scenario_system,
    write_system,
)
from oilwatch.models.validation import InputError  # noqa: E402

__all__ = [
    "DEFAULT_OPTIONS",
    "REGISTRY",
    "FmuEntry",
    "InputError",
    "SspEntry",
    "build_fmu",
    "build_fmus",
    "main",
    "scenario_system",
    "write_system",
]

if __name__ == "__main__":
    sys.exit(main())
