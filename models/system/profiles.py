"""Operating-point profiles of a scenario: the speed and the oil supply temperature against time.

Three shapes, in the units of the quantity they drive (``speed_hz`` [Hz], ``oil_temperature_c`` [degC]):

* ``constant``: ``initial`` for ever;
* ``ramp``: ``initial`` until ``start_s``, linear to ``final`` over ``duration_s``, then ``final``;
* ``step``: ``initial`` before ``start_s``, ``final`` from it on.

A profile is written ``constant:V``, ``ramp:V0:V1:START_S:DURATION_S`` or ``step:V0:V1:START_S`` on the
command line (:func:`parse_profile`); values may be given relative to a nominal as ``+dV``/``-dV``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..validation import InputError, require_finite, require_non_negative

SHAPES = ("constant", "ramp", "step")


@dataclass(frozen=True)
class OperatingProfile:
    """One quantity against time: ``shape`` in :data:`SHAPES`, ``initial``, ``final``, ``start_s``,
    ``duration_s`` (ramp only)."""

    shape: str
    initial: float
    final: float | None = None
    start_s: float = 0.0
    duration_s: float = 0.0

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise InputError(f"profile shape must be one of {SHAPES}, got {self.shape!r}")
        require_finite("profile initial value", self.initial)
        if self.shape != "constant":
            require_finite("profile final value", self.final)
            require_non_negative("profile start_s", self.start_s, "s")
        if self.shape == "ramp" and not self.duration_s > 0.0:
            raise InputError(f"a ramp's duration_s must be > 0 s, got {self.duration_s:g}")

    def __call__(self, time_s: float | np.ndarray) -> float | np.ndarray:
        """The value at time(s) ``time_s`` [s]."""
        t = np.asarray(time_s, dtype=float)
        if self.shape == "constant":
            value = np.full_like(t, self.initial)
        elif self.shape == "step":
            value = np.where(t >= self.start_s, self.final, self.initial)
        else:
            fraction = np.clip((t - self.start_s) / self.duration_s, 0.0, 1.0)
            value = self.initial + (self.final - self.initial) * fraction
        return float(value) if np.ndim(value) == 0 else value

    @property
    def extremes(self) -> tuple[float, float]:
        """(lowest, highest) value the profile takes."""
        values = (self.initial,) if self.shape == "constant" else (self.initial, self.final)
        return min(values), max(values)


def parse_profile(text: str, nominal: float, name: str) -> OperatingProfile:
    """A profile from ``constant:V``, ``ramp:V0:V1:START:DURATION`` or ``step:V0:V1:START``; a value
    written ``+d`` or ``-d`` is ``nominal + d``. ``name`` (e.g. ``--speed-profile``) names errors."""
    parts = text.split(":")
    shape, fields = parts[0], parts[1:]
    counts = {"constant": 1, "ramp": 4, "step": 3}
    if shape not in counts or len(fields) != counts[shape]:
        raise InputError(
            f"{name} must be constant:V, ramp:V0:V1:START_S:DURATION_S or step:V0:V1:START_S, got {text!r}"
        )

    def value(field: str, relative: bool) -> float:
        try:
            number = float(field)
        except ValueError:
            raise InputError(f"{name}: {field!r} is not a number") from None
        return nominal + number if relative and field[:1] in "+-" else number

    numbers = [value(f, i < 2) for i, f in enumerate(fields)]
    try:
        if shape == "constant":
            return OperatingProfile("constant", numbers[0])
        if shape == "step":
            return OperatingProfile("step", numbers[0], numbers[1], numbers[2])
        return OperatingProfile("ramp", numbers[0], numbers[1], numbers[2], numbers[3])
    except InputError as error:
        raise InputError(f"{name}: {error}") from None
