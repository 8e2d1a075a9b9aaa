"""Stage an FMU's Python sources under module names that no other FMU uses.

A pythonfmu FMU runs inside the host's Python interpreter and puts its ``resources/`` folder first
on ``sys.path``. Two FMUs that both bundle a package called ``models`` would share whichever copy
was imported first (and an FMU rebuilt under the same names in one process runs the old code).
So each FMU gets its own copy of the packages under the root ``<prefix>_oilwatch``, and every absolute
import ``from oilwatch.models.x import y`` is rewritten to ``from <prefix>_oilwatch.models.x import y``.

The team's import rule (absolute cross-package imports are written ``from pkg.x import y`` at
module top level) makes this a reliable rewrite. The rewrite works on the syntax tree, not on text
patterns, so a docstring that mentions ``from models`` is left alone. Forms that cannot be relocated
(``import models``, ``import oilwatch.models.x``, or a string such as ``"oilwatch.models.x"`` passed to a
call, as in ``importlib.import_module("oilwatch.models.x")``) make the build fail with the file and line.
"""

from __future__ import annotations

import ast
import fnmatch
import shutil
from pathlib import Path

from oilwatch.models.validation import InputError

SLAVE_SCRIPT_PATTERN = "*_slave.py"
ROOT_PACKAGE = "oilwatch"


class RelocationError(InputError):
    """A bundled source file uses an import form that cannot be relocated."""


def relocated_name(prefix: str, package: str) -> str:
    """The module name of ``package`` inside the FMU built with ``prefix``."""
    return f"{prefix}_{package}"


def _root(module: str | None) -> str | None:
    return module.split(".", 1)[0] if module else None


def rewrite_imports(source: str, mapping: dict[str, str], filename: str) -> str:
    """Return ``source`` with ``from <pkg>...`` imports renamed by ``mapping`` (package -> name).

    Raises :class:`RelocationError` naming the file and line for ``import <pkg>[.x]`` and for string
    constants ``"<pkg>"``/``"<pkg>.x"`` passed as call arguments.
    """
    tree = ast.parse(source, filename=filename)
    lines = source.splitlines(keepends=True)
    edits: list[tuple[int, int, str, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if _root(alias.name) in mapping:
                    raise RelocationError(
                        f"{filename}:{node.lineno}: 'import {alias.name}' cannot be relocated; "
                        f"write 'from {alias.name.rsplit('.', 1)[0]} import ...' instead"
                    )
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            root = _root(node.module)
            if root in mapping:
                edits.append((node.lineno, node.col_offset, root, mapping[root]))
        elif isinstance(node, ast.Call):
            for argument in node.args:
                value = getattr(argument, "value", None)
                if isinstance(argument, ast.Constant) and isinstance(value, str):
                    # a dotted name only: the bare root is also the distribution's name (metadata.version)
                    if "." in value and _root(value) in mapping and value.replace(".", "").isidentifier():
                        raise RelocationError(
                            f"{filename}:{node.lineno}: the module name {value!r} passed to a call "
                            "cannot be relocated; use a relative import or Path(__file__)"
                        )
    for lineno, col, root, new in sorted(edits, reverse=True):
        line = lines[lineno - 1]
        head, tail = line[:col], line[col:]
        after_from = tail[len("from") :]
        stripped = after_from.lstrip()
        if not tail.startswith("from") or not stripped.startswith(root):
            raise RelocationError(f"{filename}:{lineno}: unexpected import layout: {line.strip()}")
        gap = after_from[: len(after_from) - len(stripped)]
        lines[lineno - 1] = head + "from" + gap + new + stripped[len(root) :]
    return "".join(lines)


def copy_package(
    source: Path, destination: Path, data_globs: tuple[str, ...], exclude: tuple[str, ...] = ()
) -> list[Path]:
    """Copy the ``*.py`` files and data files (``data_globs``) of a package tree; return them.

    ``__pycache__``, tests and files matching ``exclude`` (glob on the file name) are skipped.
    """
    if not (source / "__init__.py").is_file():
        raise InputError(f"package folder {source} does not exist or has no __init__.py")
    copied = []
    for path in sorted(source.rglob("*")):
        relative = path.relative_to(source)
        if not path.is_file() or "__pycache__" in relative.parts or "tests" in relative.parts:
            continue
        if any(fnmatch.fnmatch(path.name, pattern) for pattern in exclude):
            continue
        if path.suffix == ".py" or any(fnmatch.fnmatch(path.name, g) for g in data_globs):
            target = destination / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, target)
            copied.append(target)
    return copied


def stage_sources(
    staging: Path,
    package_dirs: dict[str, Path],
    script: Path,
    prefix: str,
    data_globs: tuple[str, ...],
) -> tuple[Path, list[Path]]:
    """Copy ``script`` and the oilwatch subpackages of ``package_dirs`` (name -> folder, installed or in a
    source tree) into ``staging`` under the relocated root package ``<prefix>_oilwatch``, imports rewritten.

    Returns the staged script and the staged root folder (pythonfmu's ``project_files``).
    Slave scripts (``*_slave.py``) inside bundled packages are left out: each FMU carries only
    its own slave, at the top of ``resources/``.
    """
    mapping = {ROOT_PACKAGE: relocated_name(prefix, ROOT_PACKAGE)}
    root = staging / mapping[ROOT_PACKAGE]
    root.mkdir(parents=True)
    (root / "__init__.py").write_text('"""The oilwatch packages one FMU bundles."""\n', encoding="utf-8")
    staged_script = staging / script.name
    shutil.copy2(script, staged_script)
    sources = [(staged_script, script)]
    for package, source in package_dirs.items():
        folder = root / package
        copied = copy_package(source, folder, data_globs, (SLAVE_SCRIPT_PATTERN,))
        sources += [(path, source / path.relative_to(folder)) for path in copied if path.suffix == ".py"]
    for staged, original in sources:
        text = staged.read_text(encoding="utf-8")
        staged.write_text(rewrite_imports(text, mapping, str(original)), encoding="utf-8")
    return staged_script, [root]
