"""The estimator's model at the measured speed and oil temperature, with a viscosity factor per bearing.

:class:`OperatingAugmentedModel` keeps the exact (q1, q2) grid (``GridAugmentedModel``, built at the
machine's nominal speed and viscosity: the reference operating point p0) and adds a re-centred correction for
the operating point ``p = (speed, ln mu1, ln mu2)``, ``mu_b = mu_oil(T) f_b`` (the machine's oil law at the
measured temperature times bearing b's viscosity factor), with ``x = (q, p)`` and ``d = x - x_c``::

    A_d(q, p) = A_grid(q) + D_c + sum_i dD/dx_i d_i + sum_b [1/2 D_qq,b d_qb^2 + D_qm,b d_qb d_mb
                + 1/2 D_mm,b d_mb^2]                                                       (same for G)

``D = A(q, p) - A(q, p0)``, its derivatives those of the exact maps (:mod:`operating_maps`, on the
dimensionless bearing table: each bearing at its own Sommerfeld number and flowrate over its Couette flow,
gyroscopics, unbalance ~ speed^2 and the exosystem at the speed) at a centre ``x_c``; the second-order terms
are each bearing's in its own flowrate q_b and ln mu_b (:mod:`operating_correction`: forward differences of
the exact first derivatives; the cross-bearing and speed terms are left out, measured). The centre moves to
the current (estimate, operating point) when either has left it by more than the thresholds of
:class:`Recentring` (2 % of speed, 0.015 in ln mu, 0.75 % of flow: small enough in (q, ln mu) for the speed
ramp's noise bias, which the second order makes affordable), at most
every 0.1 s unless it is four thresholds away (a re-centring is one stacked assembly of 38 blocks and 8
exponentials of the (2n + 3) block with 14 Frechet derivatives, :mod:`frechet`: about 8 ms of CPU for the
turbine's 26 states, 3.4 ms at first order). A -40 % viscosity change is thus
followed by re-centring, never by a step from p0. At p = p0 the correction is not applied at all: at
constant nominal conditions this is the grid model, bit for bit.

The unbalance phase is the integral of the measured speed (held over each period, as the plant does), or
the keyphasor's angle when given (:meth:`set_operating_point`).

Model error (``tests/test_operating_model.py``): the static probe positions and 1x orbit amplitudes of the
model's map against the exact map's on the dimensionless table (worst probe) along speed and oil-temperature
ramps, with the centre up to the re-centring thresholds away in every axis, stay a small fraction of the
static sensitivity to a 1 % flow change.
"""

from __future__ import annotations

import math

import numpy as np

from ..bearing.centreline import CLEARANCE_FACTOR_RANGE
from ..bearing.coefficient_kinds import QUASI_STATIC
from ..bearing.operating_table import operating_table_path
from ..machine import Machine
from ..oil import Oil
from ..validation import InputError, require_in_range, require_positive
from .augmented import GridAugmentedModel
from .factory import geometry_number, map_command
from .flowrate_grid import FlowrateGrid
from .operating_correction import SECOND_ORDER_PAIRS, Recentring, fill_correction
from .operating_kernels import (
    GRID_ONLY,
    HELD_CENTRE,
    HELD_CENTRE_STEP,
    HELD_HARD_FACTOR,
    HELD_HAS_CENTRE,
    HELD_LOG_MU,
    HELD_MIN_INTERVAL,
    HELD_POINT,
    HELD_REFERENCE_LOG_MU,
    HELD_REFERENCE_SPEED,
    HELD_SCALES,
    HELD_SPEED,
    RECENTRE,
    OperatingArrays,
    operating_transition,
)
from .operating_maps import OperatingMaps
from .operating_point import ConditionedTable, operating_tables_of
from .rotor_bearing import RotorBearingSystem

NEVER = -(10**12)
"""The step of a centre placed before any transition (so that the next due re-centring is not delayed)."""
SAME_VISCOSITY = 1e-9
"""An oil viscosity within this relative difference of the reference's is the reference's (the oil law at
the nominal temperature reproduces the machine's viscosity to about 1e-12)."""


class OperatingAugmentedModel:
    """The estimator's model following speed, oil temperature and the viscosity factors (module docstring).

    Parameters
    ----------
    reference : the exact-grid model at the machine's nominal speed and viscosity.
    maps : exact maps of the same system on the dimensionless table.
    oil : the machine's oil (None: the viscosity stays the reference's times the factors).
    reference_viscosity_pa_s : the film viscosity of the reference grid's tables.
    recentring : thresholds of the correction's centre.
    second_order : the axis pairs of the correction's second-order terms (``()``: first order).
    """

    def __init__(
        self,
        reference: GridAugmentedModel,
        maps: OperatingMaps,
        oil: Oil | None,
        reference_viscosity_pa_s: float,
        recentring: Recentring | None = None,
        second_order=SECOND_ORDER_PAIRS,
    ) -> None:
        self.reference = reference
        self.maps = maps
        self.oil = oil
        self.recentring = recentring if recentring is not None else Recentring()
        for name in (
            "n_states",
            "dt_s",
            "output_matrix",
            "velocity_output_matrix",
            "bearing_flowrate_bounds_m3_s",
            "speed_hz",
            "nominal_flowrates_m3_s",
            "clearance_m",
        ):
            setattr(self, name, getattr(reference, name))
        mu0 = require_positive("reference viscosity", reference_viscosity_pa_s, "Pa s")
        self.reference_viscosity_pa_s = mu0
        self._log_mu0 = math.log(mu0)
        r = self.recentring
        # one recentring scale for both bearings: the smaller nominal, which recentres no later for either
        nominal = self.nominal_flowrates_m3_s
        q_scale = (
            float(np.mean(self.bearing_flowrate_bounds_m3_s)) if nominal is None else float(np.min(nominal))
        )
        self._grid = reference.grid
        # the compiled transition's one struct (operating_kernels): built once, refilled in place
        self._pairs = tuple(tuple(pair) for pair in second_order)
        self._arrays = OperatingArrays.allocate(self._grid.kernel_arrays, self.n_states, self._pairs)
        self._kernel_arrays = self._arrays.as_tuple()
        held = self._held = self._arrays.held
        held[HELD_REFERENCE_SPEED] = self.speed_hz
        held[HELD_REFERENCE_LOG_MU] = self._log_mu0
        held[HELD_SCALES : HELD_SCALES + 3] = (
            r.speed_fraction * self.speed_hz,
            r.log_viscosity,
            r.flowrate_fraction * q_scale,
        )
        held[HELD_HARD_FACTOR] = r.hard_factor
        held[HELD_MIN_INTERVAL] = r.min_interval_steps
        self._centre: np.ndarray | None = None  # (q1, q2, speed, ln mu1, ln mu2)
        self._w = np.zeros(3)
        self._no_unbalance = np.zeros(0)
        self.recentre_count = 0
        self._kept: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}  # centre -> its correction's terms
        self._loaded: bytes | None = None  # the centre whose terms the kernel arrays hold
        self.reset_operating_state()

    # ------------------------------------------------------------------ operating point
    def set_operating_point(
        self, speed_hz: float, oil_temperature_c: float | None = None, rotor_angle_rad: float | None = None
    ) -> None:
        """The measured speed [Hz] and oil supply temperature [degC] (None: the reference viscosity), held
        over the next transition, and optionally the keyphasor's rotor angle [rad] at its step."""
        speed = float(speed_hz)
        if not (math.isfinite(speed) and speed > 0.0):
            raise InputError(f"speed_hz must be a finite speed > 0 Hz, got {speed_hz!r}")
        if oil_temperature_c is None or self.oil is None:
            log_viscosity = self._log_mu0
        else:
            temperature = float(oil_temperature_c)
            if not math.isfinite(temperature):
                raise InputError(f"oil_temperature_c must be finite, got {oil_temperature_c!r}")
            log_viscosity = math.log(self.oil.dynamic_viscosity_pa_s(temperature))
            if abs(log_viscosity - self._log_mu0) < SAME_VISCOSITY:
                log_viscosity = self._log_mu0  # the nominal temperature: the grid model exactly
        if speed != self._speed and self._last_step is not None:
            # the phase goes on from where the previous speed took it
            following = self._last_step + 1
            self._anchor = (following, self._phase_at(following))
        self._hold(speed, log_viscosity)
        self._keyphasor = None if rotor_angle_rad is None else float(rotor_angle_rad)

    def _hold(self, speed_hz: float, log_viscosity: float) -> None:
        """The operating point of the next transitions, for the Python side and the compiled one."""
        self._speed = speed_hz
        self._log_oil_viscosity = log_viscosity
        self._held[HELD_SPEED] = speed_hz
        self._held[HELD_LOG_MU] = log_viscosity

    def reset_operating_state(self) -> None:
        """Back to the state of a model just built (the filter's reset): the reference operating point, the
        phase at zero at step 0 and no correction centre, so that what ran before leaves no trace (the next
        transition away from the reference re-centres at its own point)."""
        self._hold(float(self.speed_hz), self._log_mu0)
        self._anchor = (0, 0.0)  # (step, phase there): the phase is the integral of the speed
        self._last_step: int | None = None
        self._keyphasor: float | None = None
        self._held[HELD_CENTRE_STEP] = NEVER
        self._centre = None
        self._held[HELD_HAS_CENTRE] = 0.0

    def get_operating_state(self) -> dict[str, np.ndarray]:
        """What the next transitions depend on besides their arguments (for an FMU state): copies."""
        centre = np.zeros(0) if self._centre is None else self._centre.copy()
        last = -1 if self._last_step is None else self._last_step
        keyphasor = () if self._keyphasor is None else (self._keyphasor,)
        return {
            "operating": np.array([self._speed, self._log_oil_viscosity, *keyphasor]),
            "phase_anchor": np.array(
                [float(self._anchor[0]), self._anchor[1], float(last), self._held[HELD_CENTRE_STEP]]
            ),
            "centre": centre,
        }

    @staticmethod
    def with_centre_of(state: dict[str, np.ndarray], later: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The operating state ``state`` (:meth:`get_operating_state`) with the correction centre of
        ``later`` and the step it was placed at: restored, the next transition from ``state`` that takes
        exactly that centre's point finds it placed instead of re-centring there (the estimator FMU's
        initialization, which ran its first sample ahead and undid it)."""
        merged = dict(state)
        merged["centre"] = np.array(later["centre"], dtype=float)
        anchor = np.array(state["phase_anchor"], dtype=float)
        anchor[3] = later["phase_anchor"][3]  # the centre's step (get_operating_state)
        merged["phase_anchor"] = anchor
        return merged

    def set_operating_state(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`get_operating_state` (the corrections are recomputed at the saved centre)."""
        operating = [float(v) for v in state["operating"]]
        anchor_step, anchor_phase, last, centre_step = (float(v) for v in state["phase_anchor"])
        self._held[HELD_CENTRE_STEP] = int(centre_step)
        self._hold(operating[0], operating[1])
        self._keyphasor = operating[2] if len(operating) > 2 else None
        self._anchor = (int(anchor_step), anchor_phase)
        self._last_step = None if last < 0 else int(last)
        centre = np.asarray(state["centre"], dtype=float)
        if centre.size == 0:
            self._centre = None
            self._held[HELD_HAS_CENTRE] = 0.0
        elif self._centre is None or not np.array_equal(centre, self._centre):
            self._recentre(centre)

    @property
    def operating_point(self) -> tuple[float, float]:
        """(speed [Hz], oil viscosity at the measured temperature [Pa s]) of the next transition."""
        return self._speed, math.exp(self._log_oil_viscosity)

    def _phase_at(self, step: int) -> float:
        anchor_step, anchor_phase = self._anchor
        return anchor_phase + 2.0 * math.pi * self._speed * (step - anchor_step) * self.dt_s

    def rotor_angle_rad(self, step: int) -> float:
        """The rotor angle [rad] at ``step`` (t = step dt), the phase of the unbalance forcing: the integral
        of the measured speed, from a keyphasor angle given for the previous step when there is one."""
        if self._keyphasor is not None:
            return self._keyphasor + 2.0 * math.pi * self._speed * self.dt_s
        return self._phase_at(step)

    def exogenous(self, step: int) -> np.ndarray:
        """``w_k = [1, cos(phi_k), sin(phi_k)]``, phi_k the integral of the speed (or the keyphasor's)."""
        phase = self.transition_phase(step)
        return np.array([1.0, math.cos(phase), math.sin(phase)])

    def transition_phase(self, step: int) -> float:
        """phi_k of the transition from ``step``, which anchors a keyphasor angle given for it (the same
        value when asked again for the same step)."""
        if self._keyphasor is not None:
            self._anchor = (step, self._keyphasor)
            self._keyphasor = None
        self._last_step = step
        return self._phase_at(step)

    # ------------------------------------------------------------------ maps
    def physical_covariance(self, displacement_std_m: float, velocity_std_m_s: float) -> np.ndarray:
        """As the reference model's."""
        return self.reference.physical_covariance(displacement_std_m, velocity_std_m_s)

    def static_state(self, flowrate_m3_s: np.ndarray) -> np.ndarray:
        """The reference model's static state (at the nominal operating point)."""
        return self.reference.static_state(flowrate_m3_s)

    def transition(self, state, flowrate_m3_s, step):
        """``(s_next, df/ds, df/dq)`` at the current operating point, viscosity factors 1."""
        nxt, ad, jq, _, _ = self.transition_full(state, flowrate_m3_s, step)
        return nxt, ad, jq

    def transition_with_unbalance(self, state, flowrate_m3_s, step, unbalance):
        """``(s_next, df/ds, df/dq, df/du)``, viscosity factors 1 (see :meth:`transition_full`)."""
        nxt, ad, jq, _, ju = self.transition_full(state, flowrate_m3_s, step, unbalance=unbalance)
        return nxt, ad, jq, ju

    def transition_full(
        self, state, flowrate_m3_s, step, viscosity_factor=None, unbalance=None, exogenous=None
    ):
        """``(s_next, df/ds, df/dq, df/df (n, 2) or None, df/du (n, 2) or None)`` at the operating point.

        ``viscosity_factor`` (2,) or None (1, and no Jacobian): each bearing's film viscosity over the oil
        law's. ``unbalance`` (2,) or None: the complex unbalance relative to the machine file's (as
        ``GridAugmentedModel.transition_with_unbalance``). ``exogenous`` (3,): this ``w`` instead of the
        phase's (the phase is then left alone). The arrays are reused on the next call.
        """
        q1, q2 = float(flowrate_m3_s[0]), float(flowrate_m3_s[1])
        with_factors = viscosity_factor is not None
        if with_factors:
            f1, f2 = float(viscosity_factor[0]), float(viscosity_factor[1])
            if not (f1 > 0.0 and f2 > 0.0):
                raise InputError(f"viscosity factors must be > 0, got ({f1:g}, {f2:g})")
        else:
            f1 = f2 = 1.0
        w = self._w
        if exogenous is None:
            phase = self.transition_phase(step)  # w from it in the compiled call
        else:
            phase = math.nan
            w[:] = exogenous
        self._grid.check_flowrates(q1, q2)
        state = np.ascontiguousarray(state, dtype=np.float64)
        u = self._no_unbalance if unbalance is None else np.ascontiguousarray(unbalance, dtype=np.float64)
        arrays = self._kernel_arrays
        answer = operating_transition(arrays, state, w, phase, u, q1, q2, f1, f2, with_factors, step)
        if answer == RECENTRE:
            self.recentre_due(step)
            answer = operating_transition(arrays, state, w, phase, u, q1, q2, f1, f2, with_factors, step)
        a = self._arrays
        return (
            a.next_state,
            a.state_jacobian,
            a.flow_jacobian,
            a.viscosity_jacobian if answer != GRID_ONLY else None,
            None if unbalance is None else a.unbalance_jacobian,
        )

    def compiled_transition(self) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray]:
        """``(arrays, exogenous, limits)``: what a compiled caller needs to run :func:`operating_transition`
        itself, as :meth:`transition_full` does: the struct (refilled in place by a re-centring), the
        exogenous input's work array (3,) and the grid's flowrate range ``(q1_min, q1_max, q2_min, q2_max)``
        [m^3/s] outside which :meth:`transition_full` raises. The caller passes the phase of
        :meth:`transition_phase` and, on :data:`RECENTRE`, calls :meth:`recentre_due` and runs it again."""
        return self._kernel_arrays, self._w, np.array(self._grid.bounds_m3_s, dtype=float).ravel()

    def recentre_due(self, step: int) -> None:
        """Move the correction's centre to the point of the transition from ``step`` that answered
        :data:`RECENTRE` (the point it left in the struct)."""
        self._recentre(self._held[HELD_POINT : HELD_POINT + 5].copy())
        self._held[HELD_CENTRE_STEP] = step

    def _recentre(self, point: np.ndarray) -> None:
        """The correction's terms at the new centre ``(q_c, p_c)`` (:mod:`operating_correction`), or the kept
        ones of an earlier re-centring at exactly that centre (:data:`CENTRES_KEPT`)."""
        a = self._arrays
        key = point.tobytes()
        kept = self._kept.pop(key, None)
        if kept is None:
            fill_correction(
                self.maps, point, self.speed_hz, self.reference_viscosity_pa_s, self._pairs, a.corrections_a,
                a.corrections_g,
            )  # fmt: skip
            kept = (a.corrections_a.copy(), a.corrections_g.copy())
            if len(self._kept) >= CENTRES_KEPT:
                del self._kept[next(iter(self._kept))]  # the oldest
        elif key != self._loaded:  # else the arrays hold them already (a reset, then the same start)
            a.corrections_a[...], a.corrections_g[...] = kept
        self._kept[key] = kept
        self._loaded = key
        self._centre = point.copy()
        self._held[HELD_CENTRE : HELD_CENTRE + 5] = point
        self._held[HELD_HAS_CENTRE] = 1.0
        self.recentre_count += 1

    def place_centre(self, point) -> None:
        """Re-centre the correction at ``point = (q1, q2, speed, ln mu1, ln mu2)`` now (for tests)."""
        self._recentre(np.asarray(point, dtype=float))

    def discrete_map(self, flowrate_m3_s, viscosity_factor=(1.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
        """The model's ``(A_d, G)`` at the operating point (re-centring if due; the phase untouched)."""
        n = self.n_states
        zero = np.zeros(n)
        forcing = np.empty((n, 3))
        for column in range(3):
            w = np.zeros(3)
            w[column] = 1.0
            nxt, ad, _, _, _ = self.transition_full(zero, flowrate_m3_s, 0, viscosity_factor, exogenous=w)
            forcing[:, column] = nxt
        return ad.copy(), forcing

    def exact_map(self, flowrate_m3_s, viscosity_factor=(1.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
        """The exact ``(A_d, G)`` on the dimensionless table at the current operating point (for tests)."""
        mu = math.exp(self._log_oil_viscosity) * np.asarray(viscosity_factor, dtype=float)
        return self.maps.discrete_map(np.asarray(flowrate_m3_s, dtype=float), self._speed, mu)


CENTRES_KEPT = 8
"""Re-centrings whose terms a model keeps, by their exact centre: a filter reset and run again from the same
start (the estimator FMU's warm-up in initialization, then its first steps; every filter of a start bank)
takes them instead of computing them again (a re-centring is milliseconds of CPU)."""

REFERENCE_TABLES = ("flowrate", "dimensionless")
"""What the exact (q1, q2) grid at p0 is built on: the machine's flowrate table at the nominal speed (the
grid estimator's, the plant's ``bearing_table = 0``) or the dimensionless table (the plant's
``bearing_table = 1``), which the corrections use. With "flowrate" the two tables' difference near p0 is
carried into every operating point: mixing the grid's stiffness with the correction's equilibrium shift costs
static position at +10 degC, so follow large excursions on "dimensionless"."""


def build_operating_model(
    system: RotorBearingSystem,
    machine: Machine,
    dt_s: float = 1e-3,
    reference_table: str = "dimensionless",
    recentring: Recentring | None = None,
    progress=None,
    grid: FlowrateGrid | None = None,
    clearance_factors: tuple[float, ...] | None = None,
) -> OperatingAugmentedModel:
    """The operating model of ``system`` (reduced or full, from ``machine``) on the machine's dimensionless
    table (``oilwatch bearing-map``); ``reference_table`` in :data:`REFERENCE_TABLES`. InputError naming
    the command when the table is missing. ``grid``: the reference (q1, q2) grid built earlier for the same
    system and table (its :attr:`reference` ``.grid``; nodes checked), instead of building it.
    ``clearance_factors``: each bearing's radial clearance over the machine file's (measured from a
    coast-down: :mod:`oilwatch.models.bearing.centreline`; None: the file's), with the dimensionless
    reference table."""
    if reference_table not in REFERENCE_TABLES:
        raise InputError(f"reference_table must be one of {REFERENCE_TABLES}, got {reference_table!r}")
    factors = (1.0,) * len(system.static_loads_n) if clearance_factors is None else tuple(clearance_factors)
    if len(factors) != len(system.static_loads_n):
        raise InputError(f"clearance_factors: need one per bearing, got {factors}")
    for factor in factors:
        require_in_range("clearance factor", factor, *CLEARANCE_FACTOR_RANGE)
    if reference_table != "dimensionless" and any(f != 1.0 for f in factors):
        raise InputError("a measured clearance needs the dimensionless reference table")
    synchronous_kind = machine.dynamic_coefficients != QUASI_STATIC
    for kind in (QUASI_STATIC, machine.dynamic_coefficients) if synchronous_kind else (QUASI_STATIC,):
        for index in machine.distinct_geometries:
            path = operating_table_path(machine.source_path, kind, geometry_number(machine, index))
            if not path.exists():
                raise InputError(
                    f"following speed and oil temperature needs the dimensionless bearing table {path}: "
                    f"compute it with `{map_command(machine, kind, index)}`"
                )

    def per_bearing(tables):
        return tuple(
            table.with_clearance(bearing.clearance_m * f) if f != 1.0 else table
            for table, bearing, f in zip(tables, machine.bearings, factors, strict=True)
        )

    tables = per_bearing(operating_tables_of(machine, QUASI_STATIC))
    synchronous = per_bearing(operating_tables_of(machine)) if synchronous_kind else None
    mu0 = system.tables[0].metadata["bearing"]["viscosity_pa_s"]
    if reference_table == "dimensionless":
        speed, loads = system.speed_hz, system.static_loads_n
        system = RotorBearingSystem(
            system.rotor,
            [ConditionedTable(t, w, speed, mu0) for t, w in zip(tables, loads, strict=True)],
            speed,
            system.basis,
            system.unbalance_moment_kg_m,
            system.unbalance_phase_rad,
            system.nominal_flowrates_m3_s,
            None
            if synchronous is None
            else [ConditionedTable(t, w, speed, mu0) for t, w in zip(synchronous, loads, strict=True)],
        )
    # the dimensionless table is C1 Catmull-Rom between its nodes: 3 grid intervals per table interval
    subdivisions = 3 if reference_table == "dimensionless" else 5
    reference = GridAugmentedModel(system, dt_s, subdivisions=subdivisions, progress=progress, grid=grid)
    maps = OperatingMaps(system, tables, dt_s, synchronous)
    return OperatingAugmentedModel(reference, maps, machine.oil, mu0, recentring)


def map_response(
    model, a_d: np.ndarray, forcing: np.ndarray, speed_hz: float
) -> tuple[np.ndarray, np.ndarray]:
    """The measured static positions (4,) and 1x orbit amplitudes (4,) [um] of a map ``(A_d, G)`` at a speed:
    the steady response of ``s+ = A_d s + G [1, cos phi, sin phi]`` with phi advancing ``2 pi f dt``."""
    n = a_d.shape[0]
    h = model.output_matrix
    static = np.linalg.solve(np.eye(n) - a_d, forcing[:, 0])
    turn = np.exp(2j * np.pi * speed_hz * model.dt_s)
    orbit = np.linalg.solve(turn * np.eye(n) - a_d, forcing[:, 1] - 1j * forcing[:, 2])
    return h @ static * 1e6, np.abs(h @ orbit) * 1e6
