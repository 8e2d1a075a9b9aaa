"""A value for an FMU variable, checked against the variable's FMI type and declared range before it is set.

fmpy converts with ``float()``/``int()`` and ctypes: text raises ``ValueError`` deep in the master, 1.5
becomes 1 for an Integer, and 4294967296 wraps to 0 (``fmi2Integer`` is a C ``int``, 32 bits). Every value
the master sets goes through :func:`fmi_value`, which refuses all of these with one
:class:`~oilwatch.cosim.errors.SystemDescriptionError` naming the input as the user gave it (``label``,
e.g. ``--seed`` or ``--set ekf.velocity_channels``) and what is allowed. An Integer is also checked
against its declared min/max (a value outside them could not be told apart from a wrapped one); a Real's
range is left to the FMU, which checks it at initialization and names the variable and its unit.
"""

from __future__ import annotations

import math

from .errors import SystemDescriptionError

FMI2_INTEGER_RANGE = (-(2**31), 2**31 - 1)
"""Range of an FMI 2.0 Integer (``fmi2Integer`` is a C ``int``: 32-bit signed)."""
BOOLEAN_TEXT = {"true": True, "false": False, "1": True, "0": False}


def _bound(text: str | None, default: float) -> float:
    return default if text in (None, "") else float(text)


def _text(bound: float, integer: bool) -> str:
    if math.isinf(bound):
        return "inf" if bound > 0 else "-inf"
    return f"{int(bound):d}" if integer else f"{bound:g}"


def _allowed(kind: str, low: float, high: float, unit: str | None) -> str:
    """``an integer in [0, 2147483647]``, ``a number in [0, 60] s``, ``a number [s]``."""
    if math.isinf(low) and math.isinf(high):
        return f"{kind} [{unit}]" if unit else kind
    integer = kind == "an integer"
    return f"{kind} in [{_text(low, integer)}, {_text(high, integer)}]" + (f" {unit}" if unit else "")


def fmi_value(variable, value: object, label: str) -> object:
    """``value`` converted to ``variable``'s FMI type (``variable`` has ``type``, ``unit``, ``minimum``,
    ``maximum``, the last two as text from modelDescription.xml); SystemDescriptionError naming ``label``
    if it is not of that type or, for an Integer, lies outside its declared range or 32 bits."""
    kind = variable.type
    if kind == "String":
        return str(value)
    if kind == "Boolean":
        text = str(value).strip().lower()
        if isinstance(value, bool):
            return value
        if text in BOOLEAN_TEXT or (isinstance(value, int | float) and value in (0, 1)):
            return BOOLEAN_TEXT.get(text, bool(value))
        raise SystemDescriptionError(f"{label} must be a Boolean (true, false, 1 or 0), got {value!r}")
    if kind == "Real":
        low, high, name = _bound(variable.minimum, -math.inf), _bound(variable.maximum, math.inf), "a number"
    elif kind in ("Integer", "Enumeration"):
        low = max(_bound(variable.minimum, FMI2_INTEGER_RANGE[0]), FMI2_INTEGER_RANGE[0])
        high = min(_bound(variable.maximum, FMI2_INTEGER_RANGE[1]), FMI2_INTEGER_RANGE[1])
        name = "an integer"
    else:
        raise SystemDescriptionError(f"{label}: unsupported FMI type {kind}")
    allowed = _allowed(name, low, high, variable.unit)
    try:
        number = float(value) if not isinstance(value, int) or isinstance(value, bool) else value
    except (TypeError, ValueError):
        number = None
    if isinstance(value, bool) or number is None or not math.isfinite(number):
        raise SystemDescriptionError(f"{label} must be {allowed}, got {value!r}")
    if kind != "Real":
        if isinstance(number, float) and not number.is_integer():
            raise SystemDescriptionError(f"{label} must be {allowed}, got {value!r}")
        number = int(number)
    if kind != "Real" and not low <= number <= high:
        raise SystemDescriptionError(f"{label} must be {allowed}, got {value!r}")
    return number
