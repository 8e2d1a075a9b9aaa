"""Where a command writes: ``--out`` checked once before any work, with one error naming the flag.

:func:`check_output` runs before every command (:func:`oilwatch.cli.main`) and creates nothing, so that a
command refused for another input leaves no empty folder behind. What cannot be written (a file where a
folder must be, a folder where a file must be, a file on the way, no permission) is an
:class:`~models.validation.InputError` naming the flag, the path and what is allowed: one line and exit
code 2 instead of a traceback after minutes of computing. Missing folders are created when the output is
written (:func:`output_folder`, :func:`output_file`), as ``mkdir -p`` would.
"""

from __future__ import annotations

import os
from pathlib import Path

from oilwatch.models.validation import InputError


def check_output(flag: str, value: str | Path, kind: str) -> Path:
    """``value`` of option ``flag`` as a Path if a ``kind`` (``folder`` or ``file``) can be written there
    (creating the missing folders); InputError naming the flag otherwise. Creates nothing."""
    path = Path(value)
    if kind == "folder" and path.exists() and not path.is_dir():
        raise InputError(f"{flag} {str(path)!r} is an existing file; give a folder (created if missing)")
    if kind == "file" and path.is_dir():
        raise InputError(f"{flag} {str(path)!r} is a folder; give a file name inside it")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(
                    f"{flag} {str(path)!r}: {str(parent)!r} is a file, so no {kind} can be made inside it; "
                    "give another path"
                )
            if not os.access(parent, os.W_OK | os.X_OK) and not (path.exists() and kind == "folder"):
                raise InputError(f"{flag} {str(path)!r}: the folder {str(parent)!r} is not writable")
            break
    if path.exists() and not os.access(path, os.W_OK):
        raise InputError(f"{flag} {str(path)!r}: the {kind} exists and is not writable")
    return path


def _make_folder(flag: str, folder: Path) -> None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f"{flag} {str(folder)!r}: cannot create the folder ({error.strerror})") from None


def output_folder(flag: str, value: str | Path) -> Path:
    """The output folder ``value`` of option ``flag``, created if missing; InputError if it cannot be."""
    folder = check_output(flag, value, "folder")
    _make_folder(flag, folder)
    return folder


def output_file(flag: str, value: str | Path) -> Path:
    """The output file ``value`` of option ``flag``, its folder created if missing; InputError if it is a
    folder or cannot be written."""
    path = check_output(flag, value, "file")
    _make_folder(flag, path.parent)
    return path
