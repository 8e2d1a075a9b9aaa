"""What the running command has kept so far: the end of the one line printed when it stops early.

A command registers each output as it goes (:func:`keep`: a name and a function describing the output's
state, e.g. "estimates.csv keeps 12288 whole rows, to t = 12.287 s"); when the command is interrupted or
cannot write, :func:`oilwatch.cli.main` prints :func:`kept` after the reason.
"""

from __future__ import annotations

from collections.abc import Callable

_KEPT: dict[str, Callable[[], str]] = {}


def keep(name: str, describe: Callable[[], str]) -> None:
    """Register (or replace) the description of output ``name``."""
    _KEPT[name] = describe


def forget(name: str) -> None:
    """Drop the description of ``name`` (the output was completed or removed)."""
    _KEPT.pop(name, None)


def clear() -> None:
    """Forget every description (a new command in the same process)."""
    _KEPT.clear()


def kept() -> str:
    """Every registered description, joined; "nothing written" when there is none."""
    parts = []
    for describe in list(_KEPT.values()):
        try:
            parts.append(describe())
        except Exception as error:  # a description must never hide the reason of the stop
            parts.append(f"(state unknown: {error})")
    return "; ".join(part for part in parts if part) or "no output written"
