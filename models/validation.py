"""Input validation shared by the physics code: one error type that names the input and its allowed range."""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

# Upper bounds of user inputs that have no narrower physical one (FMU parameters and inputs): above them a
# value is a typing slip, not a machine, and is refused instead of computed with.
MAX_FLOWRATE_ML_MIN = 1.0e5
"""100 l/min: over a hundred times the supply of any fluid-film bearing oilwatch models."""
MAX_PROBE_UM = 1000.0
"""1 mm: beyond a proximity probe's range (noise, process-noise std along a displacement)."""
NEVER_S = 1.0e9
"""The "never" of fault and change times (their default), also their largest value."""
MAX_UNBALANCE_G_MM = 1.0e6
"""1 kg m: far above any rotor's ISO G40 unbalance."""
PHASE_RANGE_DEG = (-360.0, 360.0)
MAX_SEED = 2**31 - 1
"""The largest FMI 2.0 Integer."""
MAX_AGE_DAYS = 36500.0
"""A century: the age of a baseline."""


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


def read_text_file(kind: str, path: str | Path, hint: str = "") -> str:
    """The text of the UTF-8 input file ``path`` (a ``kind``, e.g. "machine file"); InputError naming
    it when it is missing, unreadable, empty or not text (``hint``: what it should be, e.g. "a TOML file")."""
    source = Path(path)
    should = f"; give {hint}" if hint else ""
    try:
        data = source.read_bytes()
    except FileNotFoundError:
        raise InputError(f"cannot read {kind} {str(source)!r}: not found") from None
    except OSError as error:
        raise InputError(f"cannot read {kind} {str(source)!r}: {error.strerror}") from None
    if not data.strip():
        raise InputError(f"{kind} {str(source)!r} is empty{should}")
    try:
        if b"\0" in data:
            raise UnicodeDecodeError("utf-8", data, data.index(b"\0"), data.index(b"\0") + 1, "NUL byte")
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise InputError(
            f"{kind} {str(source)!r} is not a text file (binary data at byte {error.start}){should}"
        ) from None


@contextmanager
def naming_file(kind: str, path: str | Path) -> Iterator[None]:
    """Re-raise an InputError of the block with ``kind path:`` in front, unless it names the file already:
    a message about a field of a file must say which file."""
    try:
        yield
    except InputError as error:
        if str(path) in str(error):
            raise
        raise InputError(f"{kind} {str(path)!r}: {error}") from None


_KIND_NAMES = {
    float: "a number",
    int: "a number",
    str: "text",
    list: "a list",
    dict: "an object",
    bool: "true/false",
}


def require_fields(mapping: object, where: str, fields: dict[str, type | tuple[type, ...]]) -> Mapping:
    """``mapping`` if it is a JSON/TOML object holding every key of ``fields`` with a value of its type
    (``float`` accepts an int, never a bool); InputError naming ``where`` and the missing or bad key."""
    if not isinstance(mapping, Mapping):
        raise InputError(
            f"{where} must be an object with keys {', '.join(fields)}, got {type(mapping).__name__}"
        )
    for key, kind in fields.items():
        if key not in mapping:
            raise InputError(f"{where} has no key {key!r} (needs {', '.join(fields)})")
        value = mapping[key]
        kinds = kind if isinstance(kind, tuple) else (kind,)
        if float in kinds:
            kinds = (*kinds, int)
        if (isinstance(value, bool) and bool not in kinds) or not isinstance(value, kinds):
            names = " or ".join(dict.fromkeys(_KIND_NAMES.get(k, k.__name__) for k in kinds))
            raise InputError(f"{where}.{key} must be {names}, got {value!r}")
    return mapping
