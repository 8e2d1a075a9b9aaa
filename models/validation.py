"""Input validation shared by the physics code: one error type that names the input and its allowed range."""

from __future__ import annotations

import math


class InputError(ValueError):
    """A user-supplied value is missing, malformed or outside its allowed range.

    The message always names the input and says what is allowed, so that the CLI and the FMUs can
    show it as it is.
    """


def require_finite(name: str, value: float) -> float:
    """Return ``value`` as float, or raise :class:`InputError` if it is not a finite number."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise InputError(f"{name} must be finite, got {value!r}")
    return number


def require_positive(name: str, value: float, unit: str = "") -> float:
    """Return ``value`` if it is a finite number > 0, else raise :class:`InputError`."""
    number = require_finite(name, value)
    if number <= 0.0:
        raise InputError(f"{name} must be > 0{(' ' + unit) if unit else ''}, got {number:g}")
    return number


def require_non_negative(name: str, value: float, unit: str = "") -> float:
    """Return ``value`` if it is a finite number >= 0, else raise :class:`InputError`."""
    number = require_finite(name, value)
    if number < 0.0:
        raise InputError(f"{name} must be >= 0{(' ' + unit) if unit else ''}, got {number:g}")
    return number


def require_in_range(
    name: str, value: float, low: float, high: float, unit: str = "", *, open_high: bool = False
) -> float:
    """Return ``value`` if ``low <= value <= high`` (``< high`` with ``open_high``), else raise."""
    number = require_finite(name, value)
    above = number >= high if open_high else number > high
    if number < low or above:
        bracket = ")" if open_high else "]"
        u = f" {unit}" if unit else ""
        raise InputError(f"{name} must lie in [{low:g}, {high:g}{bracket}{u}, got {number:g}{u}")
    return number
