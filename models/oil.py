"""The lubricating oil: viscosity against temperature (ASTM D341) and the viscosity index (ASTM D2270).

Kinematic viscosity follows the Walther equation of ASTM D341 (Standard Practice for Viscosity-Temperature
Equations and Charts for Liquid Petroleum or Hydrocarbon Products):

    log10(log10(nu + 0.7)) = A - B log10(T),   nu in mm^2/s (cSt), T in K,

a straight line on the D341 chart, fixed by two viscosities. D341 adds small correction terms to Z = nu + 0.7
below 2 cSt; lubricating oils in a bearing stay far above that, so they are left out and :class:`Oil`
refuses a law that falls below 2 cSt in its temperature range.

An oil is described either by two measured (temperature, viscosity) points, or by its ISO 3448 viscosity
grade (ISO VG n: nu = n cSt at 40 degC, the grade's mid-point) and its viscosity index VI (ASTM D2270 /
ISO 2909), which fixes nu at 100 degC. D2270 defines VI through L and H, the 40 degC viscosities of the
VI 0 and VI 100 reference oils that have the oil's 100 degC viscosity Y:

    VI <= 100:  VI = 100 (L - U) / (L - H);        VI > 100:  VI = (10^N - 1) / 0.00715 + 100,
    N = (log10 H - log10 U) / log10 Y,             U = nu at 40 degC.

D2270's Table 1 lists L and H for Y from 2 to 70 cSt; above 70 cSt it gives L = 0.8353 Y^2 + 14.67 Y - 216
and H = 0.1684 Y^2 + 11.85 Y - 97. Between 2 and 70 cSt oilwatch uses the standard piecewise-quadratic
representation of Table 1 (L, H = a Y^2 + b Y + c on 15 intervals; the same coefficients appear in ISO 2909
calculators and GOST 25371), which reproduces the table to its printed precision (0.3 % at worst;
tests/test_oil.py checks it against Table 1 entries). Given U and VI, Y is the root of VI(U, Y) = VI, which
is monotone in Y: found by bisection to the last bit.

Dynamic viscosity, the bearing's mu, is rho(T) nu(T), with the density falling linearly from its 15 degC
value by a volumetric thermal expansion coefficient (ASTM D1250 / API MPMS 11.1 give about 6.4e-4 1/K for a
mineral oil of 860 kg/m^3).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from .validation import InputError, require_finite, require_in_range, require_positive

KELVIN = 273.15
ISO_VG_GRADES = (2, 3, 5, 7, 10, 15, 22, 32, 46, 68, 100, 150, 220, 320, 460, 680, 1000, 1500, 2200, 3200)
"""ISO 3448 viscosity grades: ISO VG n has n mm^2/s at 40 degC (mid-point, +-10 %)."""
DEFAULT_THERMAL_EXPANSION_PER_K = 6.4e-4
"""Volumetric thermal expansion of a mineral oil of about 860 kg/m^3 (ASTM D1250) [1/K]."""
MIN_WALTHER_VISCOSITY_CST = 2.0

# ASTM D2270 Table 1 as piecewise quadratics in Y = nu(100 degC) [cSt]: (Y_low, a, b, c, d, e, f) with
# L = a Y^2 + b Y + c and H = d Y^2 + e Y + f on [Y_low, next Y_low); the last row is D2270's own formula
# above 70 cSt.
_D2270_PIECES = (
    (2.0, 1.14673, 1.7576, -0.109, 0.84155, 1.5521, -0.077),
    (3.8, 3.38095, -15.4952, 33.196, 0.78571, 1.7929, -0.183),
    (4.4, 2.5, -7.2143, 13.812, 0.82143, 1.5679, 0.119),
    (5.0, 0.101, 16.635, -45.469, 0.04985, 9.1613, -18.557),
    (6.4, 3.35714, -23.5643, 78.466, 0.22619, 7.7369, -16.656),
    (7.0, 0.01191, 21.475, -72.870, 0.79762, -0.7321, 14.61),
    (7.7, 0.41858, 16.1558, -56.040, 0.05794, 10.5156, -28.240),
    (9.0, 0.88779, 7.5527, -16.600, 0.26665, 6.7015, -10.810),
    (12.0, 0.7672, 10.7972, -38.180, 0.20073, 8.4658, -22.490),
    (15.0, 0.97305, 5.3135, -2.200, 0.28889, 5.9741, -4.930),
    (18.0, 0.97256, 5.25, -0.980, 0.24504, 7.416, -16.730),
    (22.0, 0.91413, 7.4759, -21.820, 0.20323, 9.1267, -34.230),
    (28.0, 0.87031, 9.7157, -50.770, 0.18411, 10.1015, -46.750),
    (40.0, 0.84703, 12.6752, -133.310, 0.17029, 11.4866, -80.620),
    (55.0, 0.85921, 11.1009, -83.19, 0.1713, 11.368, -76.940),
    (70.0, 0.8353, 14.67, -216.0, 0.1684, 11.85, -97.0),
)


def reference_oils_l_h(nu100_cst: float) -> tuple[float, float]:
    """(L, H) of ASTM D2270 [cSt]: 40 degC viscosities of the VI 0 and VI 100 oils with this nu(100 degC)."""
    y = require_in_range("kinematic viscosity at 100 degC", nu100_cst, 2.0, math.inf, "cSt")
    piece = next(p for p in reversed(_D2270_PIECES) if y >= p[0])
    _, a, b, c, d, e, f = piece
    return (a * y + b) * y + c, (d * y + e) * y + f


def viscosity_index(nu40_cst: float, nu100_cst: float) -> float:
    """ASTM D2270 viscosity index (unrounded) from the kinematic viscosities at 40 and 100 degC [cSt]."""
    u = require_positive("kinematic viscosity at 40 degC", nu40_cst, "cSt")
    low, high = reference_oils_l_h(nu100_cst)
    if u >= high:
        return 100.0 * (low - u) / (low - high)
    n = (math.log10(high) - math.log10(u)) / math.log10(nu100_cst)
    return (10.0**n - 1.0) / 0.00715 + 100.0


def monotone_root(function: Callable[[float], float], low: float, high: float) -> float:
    """The root of a monotone ``function`` that changes sign over [``low``, ``high``], to the last bit.

    Bisection until the bracket's ends are neighbouring floats (at most about 60 halvings here): a few
    hundred microseconds, and no scipy.optimize, whose import would cost every FMU 0.15 s at its start
    (the machine file's oil grade is read there).
    """
    f_low, f_high = function(low), function(high)
    if f_low == 0.0:
        return low
    for _ in range(2100):  # enough halvings for any pair of finite floats
        middle = 0.5 * (low + high)
        if middle in (low, high):
            break
        f_middle = function(middle)
        if f_middle == 0.0:
            return middle
        if (f_middle > 0.0) == (f_low > 0.0):
            low, f_low = middle, f_middle
        else:
            high, f_high = middle, f_middle
    return low if abs(f_low) <= abs(f_high) else high


def nu100_from_viscosity_index(nu40_cst: float, vi: float) -> float:
    """Kinematic viscosity at 100 degC [cSt] of the oil with ``nu40_cst`` at 40 degC and index ``vi``."""
    u = require_positive("kinematic viscosity at 40 degC", nu40_cst, "cSt")
    vi = require_in_range("viscosity index", vi, -100.0, 400.0)
    lo, hi = 2.0, u  # VI rises monotonically with nu(100) at fixed nu(40)
    if not viscosity_index(u, lo) <= vi <= viscosity_index(u, hi * (1 - 1e-12)):
        raise InputError(
            f"viscosity index {vi:g} is not reachable at {u:g} cSt (40 degC) with nu(100 degC) in "
            f"[{lo:g}, {u:g}] cSt (ASTM D2270 range)"
        )
    return monotone_root(lambda y: viscosity_index(u, y) - vi, lo, hi * (1 - 1e-12))


def _walther(nu_cst: float) -> float:
    return math.log10(math.log10(nu_cst + 0.7))


@dataclass(frozen=True)
class Oil:
    """A lubricating oil: ASTM D341 constants, density and where it came from.

    Attributes
    ----------
    walther_a, walther_b : A and B of log10(log10(nu + 0.7)) = A - B log10(T) (nu in cSt, T in K).
    density_15c_kg_m3 : density at 15 degC [kg/m^3].
    thermal_expansion_per_k : volumetric expansion coefficient alpha, rho(T) = rho15 (1 - alpha (T - 15)).
    description : how the oil was specified (grade and VI, or the measured points).
    """

    walther_a: float
    walther_b: float
    density_15c_kg_m3: float
    thermal_expansion_per_k: float = DEFAULT_THERMAL_EXPANSION_PER_K
    description: str = ""

    def __post_init__(self) -> None:
        require_positive("oil walther_b (viscosity falls with temperature)", self.walther_b)
        require_positive("oil density_15c_kg_m3", self.density_15c_kg_m3, "kg/m^3")
        require_in_range("oil thermal_expansion_per_k", self.thermal_expansion_per_k, 0.0, 0.01, "1/K")

    @classmethod
    def from_points(
        cls,
        points_c_cst: tuple[tuple[float, float], tuple[float, float]],
        density_15c_kg_m3: float,
        thermal_expansion_per_k: float = DEFAULT_THERMAL_EXPANSION_PER_K,
    ) -> Oil:
        """The oil through two measured (temperature [degC], kinematic viscosity [cSt]) points."""
        (t1, nu1), (t2, nu2) = points_c_cst
        for name, t in (("first", t1), ("second", t2)):
            require_in_range(f"oil {name} point temperature", t, -60.0, 300.0, "degC")
        for name, nu in (("first", nu1), ("second", nu2)):
            require_in_range(f"oil {name} point viscosity", nu, MIN_WALTHER_VISCOSITY_CST, 1e6, "cSt")
        if t1 == t2:
            raise InputError(f"oil points must be at two different temperatures, got {t1:g} degC twice")
        if (nu1 - nu2) * (t1 - t2) >= 0.0:
            raise InputError(
                f"oil viscosity must fall as temperature rises, got {nu1:g} cSt at {t1:g} degC and "
                f"{nu2:g} cSt at {t2:g} degC"
            )
        x1, x2 = math.log10(t1 + KELVIN), math.log10(t2 + KELVIN)
        b = (_walther(nu1) - _walther(nu2)) / (x2 - x1)
        a = _walther(nu1) + b * x1
        text = f"{nu1:g} cSt at {t1:g} degC, {nu2:g} cSt at {t2:g} degC"
        return cls(a, b, density_15c_kg_m3, thermal_expansion_per_k, text)

    @classmethod
    def from_grade(
        cls,
        iso_vg: float,
        viscosity_index_value: float,
        density_15c_kg_m3: float,
        thermal_expansion_per_k: float = DEFAULT_THERMAL_EXPANSION_PER_K,
    ) -> Oil:
        """An ISO 3448 grade (nu at 40 degC = the grade's mid-point) of the given ASTM D2270 index."""
        if iso_vg not in ISO_VG_GRADES:
            raise InputError(f"ISO VG grade must be one of {ISO_VG_GRADES}, got {iso_vg!r}")
        nu100 = nu100_from_viscosity_index(float(iso_vg), viscosity_index_value)
        oil = cls.from_points(
            ((40.0, float(iso_vg)), (100.0, nu100)), density_15c_kg_m3, thermal_expansion_per_k
        )
        text = f"ISO VG {iso_vg:g}, VI {viscosity_index_value:g} ({nu100:.4g} cSt at 100 degC)"
        return cls(oil.walther_a, oil.walther_b, density_15c_kg_m3, thermal_expansion_per_k, text)

    def kinematic_viscosity_cst(self, temperature_c: float) -> float:
        """nu(T) [mm^2/s = cSt] by ASTM D341."""
        t = require_in_range("oil temperature", temperature_c, -60.0, 300.0, "degC")
        nu = 10.0 ** (10.0 ** (self.walther_a - self.walther_b * math.log10(t + KELVIN))) - 0.7
        if nu < MIN_WALTHER_VISCOSITY_CST:
            raise InputError(
                f"oil temperature {t:g} degC gives {nu:.3g} cSt, below the {MIN_WALTHER_VISCOSITY_CST:g} cSt "
                "where the ASTM D341 law without its low-viscosity terms holds"
            )
        return nu

    def density_kg_m3(self, temperature_c: float) -> float:
        """rho(T) [kg/m^3], linear in temperature from the 15 degC value."""
        t = require_finite("oil temperature", temperature_c)
        return self.density_15c_kg_m3 * (1.0 - self.thermal_expansion_per_k * (t - 15.0))

    def dynamic_viscosity_pa_s(self, temperature_c: float) -> float:
        """mu(T) = rho(T) nu(T) [Pa s]."""
        return self.density_kg_m3(temperature_c) * self.kinematic_viscosity_cst(temperature_c) * 1e-6

    def temperature_at_viscosity_c(self, viscosity_pa_s: float) -> float:
        """The temperature [degC] at which mu(T) = ``viscosity_pa_s`` (mu falls monotonically with T)."""
        mu = require_positive("dynamic viscosity", viscosity_pa_s, "Pa s")
        low, high = -20.0, 150.0
        span = (self.dynamic_viscosity_pa_s(high), self.dynamic_viscosity_pa_s(low))
        if not span[0] <= mu <= span[1]:
            raise InputError(
                f"dynamic viscosity {mu:g} Pa s is outside this oil's range [{span[0]:.4g}, {span[1]:.4g}] "
                f"Pa s over [{low:g}, {high:g}] degC"
            )
        return monotone_root(lambda t: self.dynamic_viscosity_pa_s(t) - mu, low, high)
