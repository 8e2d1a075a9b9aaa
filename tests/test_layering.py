"""The one-way layering and what FMU-bundled code may import, read from the source (no import needed).

Code bundled into an FMU (``oilwatch.models``, ``oilwatch.estimator``, ``oilwatch.fmu_src``) imports only the
standard library, numpy, scipy and numba, and only ``fmu_src`` knows pythonfmu; models never import the
estimator, neither imports the FMU shells, and none of the three imports the master, the CLI or the other
``oilwatch`` packages above them.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "oilwatch"
BUNDLED = ("models", "estimator", "fmu_src")
THIRD_PARTY = {"numpy", "scipy", "numba"}
SHELL_ONLY = {"pythonfmu", "pythonfmu3"}
BELOW = {"models": set(), "estimator": {"models"}, "fmu_src": {"models", "estimator"}}


def _imports(path: Path, package: str) -> set[str]:
    """Absolute dotted names ``path`` imports (relative imports resolved against its package)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    parts = ("oilwatch", *path.relative_to(PACKAGE).with_suffix("").parts)
    here = parts[:-1]
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ".".join(here[: len(here) - node.level + 1])
                names.add(f"{base}.{node.module}" if node.module else base)
            else:
                names.add(node.module)
    return names


@pytest.mark.parametrize("package", BUNDLED)
def test_bundled_code_imports_only_numpy_scipy_numba_and_the_layers_below(package):
    wrong = []
    for path in sorted((PACKAGE / package).rglob("*.py")):
        for name in _imports(path, package):
            top = name.split(".")[0]
            if top == "oilwatch":
                layer = name.split(".")[1] if "." in name else ""
                if layer != package and layer not in BELOW[package]:
                    wrong.append(f"{path.relative_to(PACKAGE)}: {name}")
            elif top in SHELL_ONLY:
                if package != "fmu_src":
                    wrong.append(f"{path.relative_to(PACKAGE)}: {name}")
            elif top not in THIRD_PARTY and top not in sys.stdlib_module_names:
                wrong.append(f"{path.relative_to(PACKAGE)}: {name}")
    assert wrong == []


OTHER_LIBRARIES_PRIVATE_API = {
    # pythonfmu's own protocol between its slave class and its C++ wrapper, which the FMI 3.0 shell and the
    # loader call as that wrapper does
    "_get_fmu_state": "pythonfmu",
    "_set_fmu_state": "pythonfmu",
    "_fmu_state_to_bytes": "pythonfmu",
    "_fmu_state_from_bytes": "pythonfmu",
    "_get_log_queue": "pythonfmu",
    "_functions": "fmpy's table of an FMU's C functions, the only way to call one fmpy does not wrap",
    "_fields": "namedtuple's public field list",
    "_exit": "os._exit",
}


def test_no_module_reads_another_objects_private_attributes():
    """An object's underscored attributes are read and written by its own methods only (``self.``, ``cls.``,
    ``super().``): other modules use its public methods. The exceptions are other libraries' own
    conventions."""
    wrong = []
    for folder in ("", *BUNDLED):
        for path in sorted((PACKAGE / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if not isinstance(node, ast.Attribute) or not node.attr.startswith("_"):
                    continue
                owner = node.value
                own = isinstance(owner, ast.Name) and owner.id in ("self", "cls")
                inherited = isinstance(owner, ast.Call) and ast.unparse(owner.func) == "super"
                if node.attr.startswith("__") or own or inherited:
                    continue
                if node.attr not in OTHER_LIBRARIES_PRIVATE_API:
                    wrong.append(f"{path.relative_to(PACKAGE)}:{node.lineno}: {ast.unparse(node)}")
    assert wrong == []
