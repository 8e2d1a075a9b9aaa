"""Keep numba's on-disk kernel cache of the installed oilwatch in step with its sources.

numba caches each ``cache=True`` kernel in the ``__pycache__`` folder beside its source and checks an entry
against that one file's content only. A kernel compiled with another file's kernel inlined (the step kernel
calls the operating model's interpolation, for instance) therefore keeps running the old callee after that
other file changed: an upgrade of oilwatch (pip leaves the cache files, which no package record lists) or a
checkout of other sources then runs stale code without a word, and an estimator built from it reads a
healthy flow as several percent off. :func:`refresh` compares a digest of every source that uses numba
with the one recorded beside the cache, and drops all of the package's cache files when they differ, so
that numba compiles afresh once.

An FMU's bundled oilwatch is not concerned: its sources and their shipped cache come from one build and are
never rewritten (an unpack is a new folder).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

STAMP = Path("__pycache__") / "numba_sources.sha256"
"""The digest of the sources the cache was compiled from, under the package root."""
INDEX_SUFFIX, OVERLOADS_SUFFIX = ".nbi", ".nbc"
"""numba's cache files: an index per function, its compiled overloads (``<index stem>.<n>.nbc``)."""
NUMBA_SUFFIXES = (INDEX_SUFFIX, OVERLOADS_SUFFIX)


def sources_digest(root: Path) -> str:
    """SHA-256 (hex) of the names and contents of the Python files under ``root`` (the oilwatch folder, the
    linked subpackages of a source tree included) that import numba."""
    found = {}
    for folder, folders, files in os.walk(root, followlinks=True):
        folders[:] = [name for name in folders if name != "__pycache__"]
        for name in files:
            if name.endswith(".py"):
                path = Path(folder, name)
                try:
                    text = path.read_bytes()
                except OSError:
                    continue
                if b"import numba" in text or b"from numba" in text:
                    found[path.relative_to(root).as_posix()] = hashlib.sha256(text).digest()
    digest = hashlib.sha256()
    for name in sorted(found):
        digest.update(name.encode() + b"\0" + found[name])
    return digest.hexdigest()


def refresh(root: Path) -> bool:
    """Drop numba's cache files under ``root`` when the sources that use numba are not those the recorded
    digest names, and record the current digest; True when it dropped them. A folder it cannot write (a
    read-only installation, where numba cannot cache either) is left as it is."""
    stamp = root / STAMP
    current = sources_digest(root)
    try:
        if stamp.read_text(encoding="ascii").strip() == current:
            return False
    except OSError:
        pass
    try:
        for folder, _, files in os.walk(root, followlinks=True):
            for name in files:
                if name.endswith(NUMBA_SUFFIXES):
                    Path(folder, name).unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        partial = stamp.with_name(f".{stamp.name}.{os.getpid()}")
        partial.write_text(current + "\n", encoding="ascii")
        os.replace(partial, stamp)
    except OSError:
        return False
    return True
