"""Readers of one field of a parsed machine file: each checks its value and names the field in its error.

A TOML machine file (:mod:`oilwatch.models.machine`) carries its unit in every key; these read a table, a key,
a number with its bounds, a list of positive numbers or a node number, and raise
:class:`~models.validation.InputError` naming ``section.key`` and the allowed range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .validation import InputError


def read_table(data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    """The table ``[key]`` of ``data``; InputError when it is missing or not a table."""
    value = data.get(key)
    if value is None:
        raise InputError(f"missing table [{key}]")
    if not isinstance(value, Mapping):
        raise InputError(f"[{key}] must be a table")
    return value


def as_number(value: Any, field: str) -> float:
    """``value`` as a finite float (booleans refused); InputError naming ``field`` otherwise."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{field} must be a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise InputError(f"{field} must be finite, got {value!r}")
    return number


def read_key(table: Mapping[str, Any], section: str, key: str) -> Any:
    """``table[key]``; InputError naming ``section.key`` when it is missing."""
    if key not in table:
        raise InputError(f"missing {section}.{key}")
    return table[key]


def read_real(
    table: Mapping[str, Any],
    section: str,
    key: str,
    unit: str,
    *,
    low: float | None = 0.0,
    strict: bool = True,
    high: float | None = None,
    value: Any = None,
    field: str | None = None,
) -> float:
    """Read one number and check ``low < x`` (``<=`` unless strict) and ``x < high``."""
    field = field or f"{section}.{key}"
    number = as_number(read_key(table, section, key) if value is None else value, field)
    u = f" {unit}" if unit else ""
    if low is not None and (number <= low if strict else number < low):
        raise InputError(f"{field} must be {'>' if strict else '>='} {low:g}{u}, got {number:g}")
    if high is not None and number >= high:
        raise InputError(f"{field} must be < {high:g}{u}, got {number:g}")
    return number


def read_positive_array(table: Mapping[str, Any], section: str, key: str, unit: str) -> np.ndarray:
    """``section.key`` as a non-empty array of numbers > 0, each checked as :func:`read_real`."""
    values = read_key(table, section, key)
    if not isinstance(values, list) or not values:
        raise InputError(f"{section}.{key} must be a non-empty list of numbers [{unit}]")
    out = [
        read_real(table, section, key, unit, value=v, field=f"{section}.{key}[{i}]")
        for i, v in enumerate(values)
    ]
    return np.array(out)


def as_node(value: Any, field: str, n_nodes: int) -> int:
    """``value`` as a node number 1..n_nodes (paper numbering); InputError naming ``field`` otherwise."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"{field} must be an integer node number, got {value!r}")
    if not 1 <= value <= n_nodes:
        raise InputError(f"{field} = {value} is not a node of this rotor (nodes 1..{n_nodes})")
    return value


def frozen_array(array: np.ndarray) -> np.ndarray:
    """A read-only float copy of ``array``, so that a frozen Machine's arrays cannot change."""
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array
