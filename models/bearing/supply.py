"""How the groove is fed: a prescribed supply flowrate or a prescribed supply (groove) pressure.

One film model covers both without a seam (paper section 2.1): the groove is one control volume
with a pressure p_g >= 0 and a fill fraction 0 <= theta_g <= 1, complementary like every film cell.

* :class:`SupplyFlow` q: q enters the groove's flow balance as a source. Below the flooded
  threshold q_t the groove stays at ambient pressure and runs partly filled (theta_g < 1: starved,
  the inlet film downstream of it is partly filled too); at q_t it is just full at zero gauge
  pressure; above it the groove is full and its pressure rises until the film carries q away.
* :class:`SupplyPressure` p_s >= 0: the groove is full at p_s and the flow drawn is the result.
  ``SupplyPressure(0)`` gives the flooded threshold q_t.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..validation import require_non_negative


@dataclass(frozen=True)
class SupplyFlow:
    """Oil supply flowrate into the groove, q_m3_s >= 0 [m^3/s]."""

    q_m3_s: float

    def __post_init__(self) -> None:
        require_non_negative("supply flowrate q_m3_s", self.q_m3_s, "m^3/s")

    @property
    def q_ml_min(self) -> float:
        """The flowrate in ml/min (user units)."""
        return self.q_m3_s * 6.0e7


@dataclass(frozen=True)
class SupplyPressure:
    """Gauge pressure held in the groove, p_pa >= 0 [Pa]."""

    p_pa: float

    def __post_init__(self) -> None:
        require_non_negative("supply pressure p_pa", self.p_pa, "Pa")


Supply = SupplyFlow | SupplyPressure

ML_MIN_PER_M3_S = 6.0e7
"""1 m^3/s = 6e7 ml/min."""
