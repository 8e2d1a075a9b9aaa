"""Build oilwatch's FMUs and SSP system from this source tree: a thin wrapper of ``oilwatch build-fmus``.

Usage::

    python build.py [--out build] [--only NAME ...] [--machine FILE]

The machinery lives in :mod:`oilwatch.cosim.fmu_build`, so that an installed oilwatch builds the FMUs without
a source tree; code imports it from there.
"""

import sys
from pathlib import Path

if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from oilwatch.cosim.fmu_build import main

    sys.exit(main())
