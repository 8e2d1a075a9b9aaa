"""Thresholds of the per-bearing starvation alarm, each with its allowed range, unit and description.

The field metadata is read twice: by validation here and by
:data:`oilwatch.estimator.boundary_parameters.ESTIMATOR_PARAMETERS`, which turns every field into a user
parameter (``alarm_<field>``) of the FMU and the CLI.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

from oilwatch.models.validation import InputError, require_in_range


def _bounded(default: float, low: float, high: float, unit: str, description: str):
    """A field with its allowed range [low, high], unit and description (read by validation and tables)."""
    metadata = {"low": low, "high": high, "unit": unit, "description": description}
    return field(default=default, metadata=metadata)


@dataclass(frozen=True)
class AlarmConfig:
    """Thresholds of the per-bearing starvation alarm (rule in :mod:`oilwatch.estimator.alarm`).

    on_fraction : a bearing's alarm sets when the upper confidence bound ``q + z std`` stays below
        ``on_fraction * q_nominal`` (that bearing's nominal flowrate) for ``hold_on_s``.
    off_fraction : it clears when the lower bound ``q - z std`` stays above ``off_fraction * q_nominal`` for
        ``hold_off_s`` (hysteresis: ``off_fraction > on_fraction``).
    confidence_z : number of standard deviations of the bounds (2.0: one-sided 97.7 %).
    """

    on_fraction: float = _bounded(
        0.90,
        0.05,
        1.5,
        "1",
        "Alarm sets when q_est + z std stays below this fraction of the nominal flowrate for alarm_hold_on_s",
    )
    hold_on_s: float = _bounded(0.25, 0.0, 60.0, "s", "Hold time before the alarm sets")
    off_fraction: float = _bounded(
        0.95,
        0.05,
        1.5,
        "1",
        "Alarm clears when q_est - z std stays above this fraction of nominal for alarm_hold_off_s "
        "(>= alarm_on_fraction: hysteresis)",
    )
    hold_off_s: float = _bounded(1.0, 0.0, 600.0, "s", "Hold time before the alarm clears")
    confidence_z: float = _bounded(
        2.0,
        0.0,
        10.0,
        "1",
        "Confidence multiplier z of the alarm's bounds q_est +/- z std (2: one-sided 97.7 %)",
    )

    def __post_init__(self) -> None:
        for spec in fields(self):
            unit = spec.metadata["unit"]
            require_in_range(
                f"AlarmConfig.{spec.name}",
                getattr(self, spec.name),
                spec.metadata["low"],
                spec.metadata["high"],
                "" if unit == "1" else unit,
            )
        if self.off_fraction < self.on_fraction:
            raise InputError(
                f"AlarmConfig.off_fraction must be >= on_fraction ({self.on_fraction:g}) for "
                f"hysteresis, got {self.off_fraction:g}"
            )
