"""The README's libcosimpy example without OPENBLAS_NUM_THREADS against the same host with it and against
oilwatch's fmpy master (with it).

Usage: ``python benchmarks/host_blas_threads.py [--fmu-dir DIR] [--stop-s 4]`` (DIR holds OilStarvation.ssp;
default: a fresh ``oilwatch build-fmus``). Prints the wall seconds per simulated second of the three and the
ratios to the unset libcosim host: the FMUs limit their own BLAS threads, so libcosim costs the same with and
without the setting (the ratio near 1); FMUs that left the threads to the host were several times slower. Run
it on FMUs built before the FMUs limited their own BLAS threads (e.g. ``python build.py`` of an older commit)
for the "before" figure.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / "tests"))

from fixtures.host_timing import LIBCOSIM, time_host, wall_per_simulated_second  # noqa: E402
from fixtures.venvs import clean_env  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fmu-dir", help="folder with OilStarvation.ssp (default: build one)")
    parser.add_argument("--warm-s", type=float, default=0.5)
    parser.add_argument("--stop-s", type=float, default=4.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(args.fmu_dir) if args.fmu_dir else Path(scratch)
        if not args.fmu_dir:
            from oilwatch.cosim.fmu_build import build_in_subprocess

            build_in_subprocess(folder)
        libcosim, fmpy = wall_per_simulated_second(
            folder / "OilStarvation.ssp",
            args.warm_s,
            args.stop_s,
            clean_env(OILWATCH_FMU_CACHE="0"),
            clean_env(OPENBLAS_NUM_THREADS="1", OILWATCH_FMU_CACHE="0"),
            Path(scratch),
        )
        limited = time_host(
            LIBCOSIM,
            folder / "OilStarvation.ssp",
            args.warm_s,
            args.stop_s,
            clean_env(OPENBLAS_NUM_THREADS="1", OILWATCH_FMU_CACHE="0"),
            Path(scratch),
        )["wall_s"] / (args.stop_s - args.warm_s)
    print(
        f"wall s per simulated s: libcosim (no OPENBLAS_NUM_THREADS) {libcosim:.3f}, libcosim with "
        f"OPENBLAS_NUM_THREADS=1 {limited:.3f}, fmpy master {fmpy:.3f}"
    )
    print(
        f"ratio libcosim unset / set: {libcosim / limited:.2f}; libcosim / fmpy master: {libcosim / fmpy:.2f}"
    )


if __name__ == "__main__":
    main()
