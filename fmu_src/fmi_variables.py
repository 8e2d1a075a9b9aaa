"""FMI 2.0 scalar variables with units, ranges and descriptions for pythonfmu slaves.

pythonfmu 0.7.0 writes a ``<ScalarVariable>`` with only name, causality, variability, initial and
start. This module subclasses its ``Real``/``Integer``/``Boolean``/``String`` so that every variable
also carries a unit (Real), a description and ``min``/``max`` (Real, Integer), and keeps a table of
units (:data:`UNITS`) from which the slave writes the ``<UnitDefinitions>`` element that the unit
attributes refer to (FMI 2.0 standard, section 2.2.2).

Units are the field's units at the user boundary (``um``, ``ml/min``, ``Hz``, ...); each one maps to
SI base units with a factor: value_SI = factor * value + offset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Variability
from pythonfmu.variables import Boolean, Integer, Real, String

_BASE_UNIT_KEYS = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


@dataclass(frozen=True)
class UnitDefinition:
    """One FMI unit: exponents of the SI base units and value_SI = factor * value + offset."""

    name: str
    exponents: dict[str, int] = field(default_factory=dict)
    factor: float = 1.0
    offset: float = 0.0

    def to_xml(self) -> Element:
        """The ``<Unit>`` element with its ``<BaseUnit>`` child."""
        unit = Element("Unit", {"name": self.name})
        attrib = {key: str(self.exponents[key]) for key in _BASE_UNIT_KEYS if key in self.exponents}
        if self.factor != 1.0:
            attrib["factor"] = f"{self.factor:.16g}"
        if self.offset != 0.0:
            attrib["offset"] = f"{self.offset:.16g}"
        SubElement(unit, "BaseUnit", attrib)
        return unit


def _unit(name: str, factor: float = 1.0, **exponents: int) -> UnitDefinition:
    return UnitDefinition(name, exponents, factor)


# The units the oilwatch FMUs use. Add to it with register_unit() rather than editing slaves.
UNITS: dict[str, UnitDefinition] = {
    u.name: u
    for u in (
        _unit("1"),
        _unit("s", s=1),
        _unit("ms", 1e-3, s=1),
        _unit("d", 86400.0, s=1),
        _unit("Hz", s=-1),
        _unit("m", m=1),
        _unit("mm", 1e-3, m=1),
        _unit("um", 1e-6, m=1),
        _unit("um/s", 1e-6, m=1, s=-1),
        _unit("m/s", m=1, s=-1),
        _unit("ml/min", 1e-6 / 60.0, m=3, s=-1),
        _unit("m3/s", m=3, s=-1),
        _unit("bar", 1e5, kg=1, m=-1, s=-2),
        _unit("Pa", kg=1, m=-1, s=-2),
        _unit("Pa.s", kg=1, m=-1, s=-1),
        _unit("N", kg=1, m=1, s=-2),
        _unit("N/m", kg=1, s=-2),
        _unit("N.s/m", kg=1, s=-1),
        _unit("kg", kg=1),
        _unit("g.mm", 1e-6, kg=1, m=1),
        _unit("rad", rad=1),
        _unit("deg", math.pi / 180.0, rad=1),
        _unit("%", 1e-2),
    )
}


def register_unit(unit: UnitDefinition) -> None:
    """Add ``unit`` to :data:`UNITS`; a different definition under an existing name is an error."""
    known = UNITS.get(unit.name)
    if known is not None and known != unit:
        raise ValueError(f"unit {unit.name!r} is already defined differently: {known}")
    UNITS[unit.name] = unit


def unit_definitions_xml(unit_names: set[str]) -> Element:
    """The ``<UnitDefinitions>`` element for the given unit names (sorted, so builds are stable)."""
    element = Element("UnitDefinitions")
    for name in sorted(unit_names):
        if name not in UNITS:
            raise ValueError(f"unit {name!r} is not in fmu_src.fmi_variables.UNITS; register it first")
        element.append(UNITS[name].to_xml())
    return element


def _fmt(value: float) -> str:
    return f"{value:.16g}"


def _decorate(element: Element, type_tag: str, extra: dict[str, str]) -> Element:
    """Put ``extra`` attributes before ``start`` on the type child (FMI's attribute order)."""
    child = element.find(type_tag)
    attrib = {**extra, **child.attrib}
    child.attrib.clear()
    child.attrib.update(attrib)
    return element


class UnitReal(Real):
    """A pythonfmu ``Real`` that also writes ``unit``, ``min`` and ``max``.

    ``minimum``/``maximum`` of None mean unbounded; they are checked by the slave at initialization
    for parameters (see :class:`oilwatch.fmu_src.slave_base.OilwatchSlave`).
    """

    def __init__(
        self,
        name: str,
        *,
        unit: str,
        minimum: float | None = None,
        maximum: float | None = None,
        **kwargs,
    ):
        if unit not in UNITS:
            raise ValueError(f"variable {name}: unit {unit!r} is not in UNITS; register it first")
        if not kwargs.get("description"):
            raise ValueError(f"variable {name}: a description is required")
        super().__init__(name, **kwargs)
        self.unit = unit
        self.minimum = minimum
        self.maximum = maximum

    def to_xml(self) -> Element:
        extra = {"unit": self.unit}
        if self.minimum is not None:
            extra["min"] = _fmt(self.minimum)
        if self.maximum is not None:
            extra["max"] = _fmt(self.maximum)
        return _decorate(super().to_xml(), "Real", extra)


class RangedInteger(Integer):
    """A pythonfmu ``Integer`` that also writes ``min`` and ``max`` (FMI 2.0 Integers have no unit)."""

    def __init__(self, name: str, *, minimum: int | None = None, maximum: int | None = None, **kwargs):
        if not kwargs.get("description"):
            raise ValueError(f"variable {name}: a description is required")
        super().__init__(name, **kwargs)
        self.unit = None
        self.minimum = minimum
        self.maximum = maximum

    def to_xml(self) -> Element:
        extra = {}
        if self.minimum is not None:
            extra["min"] = str(int(self.minimum))
        if self.maximum is not None:
            extra["max"] = str(int(self.maximum))
        return _decorate(super().to_xml(), "Integer", extra)


class DescribedBoolean(Boolean):
    """A pythonfmu ``Boolean`` that insists on a description."""

    def __init__(self, name: str, **kwargs):
        if not kwargs.get("description"):
            raise ValueError(f"variable {name}: a description is required")
        super().__init__(name, **kwargs)
        self.unit = self.minimum = self.maximum = None


class DescribedString(String):
    """A pythonfmu ``String`` that insists on a description."""

    def __init__(self, name: str, **kwargs):
        if not kwargs.get("description"):
            raise ValueError(f"variable {name}: a description is required")
        super().__init__(name, **kwargs)
        self.unit = self.minimum = self.maximum = None


_CAUSALITY = {c.name: c for c in Fmi2Causality}
_VARIABILITY = {v.name: v for v in Fmi2Variability}


def variable_attributes(causality: str, type_name: str, variability: str | None) -> dict:
    """pythonfmu keyword arguments for a causality, with the defaults FMI and ``fmpy validate`` want.

    - parameter: variability ``fixed`` (set before initialization only) unless ``tunable`` is asked;
    - input: ``continuous`` for Real, ``discrete`` otherwise;
    - output: ``initial="exact"`` with a start value (``fmpy validate`` rejects pythonfmu outputs
      without it), ``continuous`` for Real, ``discrete`` otherwise;
    - local: like an output.
    """
    if causality not in ("parameter", "input", "output", "local"):
        raise ValueError(f"causality must be parameter, input, output or local, got {causality!r}")
    if variability is None:
        if causality == "parameter":
            variability = "fixed"
        elif type_name == "Real":
            variability = "continuous"
        else:
            variability = "discrete"
    attributes = {"causality": _CAUSALITY[causality], "variability": _VARIABILITY[variability]}
    if causality in ("output", "local"):
        attributes["initial"] = Fmi2Initial.exact
    return attributes
