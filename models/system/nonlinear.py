"""The rotor on its two transient p-theta films: nonlinear time integration (the high-fidelity reference).

The reduced rotor (Craig-Bampton, bearing dofs physical, see :mod:`oilwatch.models.system.reduction`) carries
its static load g (the weight and any external force its machine file gives a bearing), the unbalance of
Eqs. 5-6 and the film forces of both bearings, each computed by a
:class:`oilwatch.models.bearing.transient.TransientFilm` from the journal's position and the film content of
the previous steps (no linearization anywhere):

    M r'' + (C_s + Omega G) r' + K_s r = g + Re(F_u exp(i Omega t)) + sum_b P_b^T F_b(film_b, P_b r)

Time stepping: Newmark average acceleration (trapezoidal rule) for the rotor, the film's BDF step for
the film, solved together at every step: a quasi-Newton iteration on the rotor's step residual with the
iteration matrix ``S + P^T J P``, ``J = K_b + (beta_film / h) C_b`` the film's step tangent (held
stiffness plus the frozen-content damping: the instantaneous response of the film to a position step).
Each iteration re-solves both films (warm-started); the step is accepted when the position update is
below ``position_tolerance_m``. The coupling is therefore implicit: the step size is set by accuracy
(tens of steps per whirl period), not by the film's stiffness. The position tolerance sets the noise
floor of the film flows: 1e-10 m of jitter per step shows as ~1e-4 of the supply in the side leakage.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..bearing.equilibrium import coefficients_at, film_forces_at_equilibrium, static_equilibrium
from ..bearing.film import solve_film
from ..bearing.grid import Mesh
from ..bearing.supply import SupplyFlow
from ..bearing.transient import BDF, TransientFilm, TransientFilmState
from ..machine import Machine
from ..rotor.assembly import Rotor
from ..validation import InputError, require_positive
from .factory import rotor_reduction

BETA, GAMMA = 0.25, 0.5
LOOSE_TOLERANCE_M = 1e-9
"""A step whose iteration stalls (a volume flipping state) is accepted if its last updates are below this
(1e-5 of the clearance); ``loose_steps`` counts them."""


@dataclass(frozen=True, eq=False)
class ReducedRotor:
    """Rotor matrices at one speed in Craig-Bampton coordinates (SI); no bearings.

    mass, damping (C_s + Omega G), stiffness (n, n); static_force (n,) the weight and any external
    static force (:attr:`Rotor.static_force`); unbalance (n,) complex (load Re(F_u exp(i Omega t)));
    bearing_maps (n_bearings, 2, n); static_loads_n (n_bearings,); static_film_forces_n (n_bearings, 2) the
    film force f0 at each equilibrium;
    speed_hz; rotor the full finite-element rotor; transform (n_dof, n).
    """

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    static_force: np.ndarray
    unbalance: np.ndarray
    bearing_maps: np.ndarray
    static_loads_n: np.ndarray
    static_film_forces_n: np.ndarray
    speed_hz: float
    rotor: Rotor
    transform: np.ndarray


def reduced_rotor(machine: Machine, speed_hz: float) -> ReducedRotor:
    """The machine's rotor reduced as in :func:`oilwatch.models.system.factory.build_system`, at
    ``speed_hz``."""
    speed = require_positive("speed_hz", speed_hz, "Hz")
    rotor = Rotor.from_machine(machine)
    t = rotor_reduction(machine, rotor).basis
    omega = 2.0 * np.pi * speed
    moment = rotor.unbalance_moment_kg_m * omega**2 * np.exp(1j * rotor.unbalance_phase_rad)
    force = np.zeros(rotor.n_dof, dtype=complex)
    force[rotor.dof(rotor.unbalance_node, "x")] = moment
    force[rotor.dof(rotor.unbalance_node, "y")] = -1j * moment
    maps = np.array([[t[rotor.dof(node, "x")], t[rotor.dof(node, "y")]] for node in rotor.bearing_nodes])
    return ReducedRotor(
        mass=t.T @ rotor.mass_matrix @ t,
        damping=t.T @ (rotor.damping_matrix + omega * rotor.gyroscopic_matrix) @ t,
        stiffness=t.T @ rotor.stiffness_matrix @ t,
        static_force=t.T @ rotor.static_force,
        static_film_forces_n=film_forces_at_equilibrium(
            rotor.bearing_static_loads_n, rotor.bearing_load_angles_rad
        ),
        unbalance=t.T @ force,
        bearing_maps=maps,
        static_loads_n=np.asarray(rotor.bearing_static_loads_n, dtype=float),
        speed_hz=speed,
        rotor=rotor,
        transform=t,
    )


def block_diagonal(blocks) -> np.ndarray:
    """The block-diagonal matrix of the (2, 2) bearing blocks, in the order of the bearing dofs."""
    n = 2 * len(blocks)
    out = np.zeros((n, n), dtype=np.result_type(*blocks))
    for b, m in enumerate(blocks):
        out[2 * b : 2 * b + 2, 2 * b : 2 * b + 2] = m
    return out


@dataclass
class NonlinearState:
    """Rotor coordinates r, v, a (n,) and the films' states at ``time_s``."""

    time_s: float
    r: np.ndarray
    v: np.ndarray
    a: np.ndarray
    films: list[TransientFilmState]


class NonlinearRotorBearing:
    """Rotor + transient films integrated in time (see the module docstring).

    Parameters: ``machine``; ``speed_hz`` [Hz]; ``mesh`` of both films; ``dt_s`` the step [s];
    ``unbalance`` False drops the unbalance load (free whirl about the equilibrium);
    ``reference_flowrate_m3_s`` where the iteration matrix's film coefficients are taken (both bearings;
    None: each bearing's nominal flowrate);
    ``position_tolerance_m`` the coupling's acceptance of a step; ``film_options`` keyword arguments of
    both :class:`TransientFilm` (e.g. the sweeps' ``residual_tolerance`` and ``mass_tolerance``).
    """

    def __init__(
        self,
        machine: Machine,
        speed_hz: float,
        mesh: Mesh,
        dt_s: float,
        *,
        unbalance: bool = True,
        reference_flowrate_m3_s: float | None = None,
        position_tolerance_m: float = 1e-10,
        max_corrections: int = 20,
        film_options: dict | None = None,
    ):
        self.machine = machine
        self.rotor = reduced_rotor(machine, speed_hz)
        self.speed_hz = self.rotor.speed_hz
        self.omega = 2.0 * np.pi * self.speed_hz
        self.mesh = mesh
        self.h = require_positive("dt_s", dt_s, "s")
        self.unbalance = bool(unbalance)
        self.bearings = machine.bearings
        self.films = [
            TransientFilm(bearing, self.speed_hz, mesh, **(film_options or {})) for bearing in self.bearings
        ]
        self.tolerance = position_tolerance_m
        self.max_corrections = max_corrections
        self.loose_steps = 0
        q_ref = (
            machine.lubrication.nominal_flowrates_m3_s
            if reference_flowrate_m3_s is None
            else np.full(len(self.bearings), reference_flowrate_m3_s)
        )
        self.equilibria = []
        tangent = []
        for bearing, load, q in zip(self.bearings, self.rotor.static_loads_n, q_ref, strict=True):
            supply = SupplyFlow(float(q))
            eq = static_equilibrium(bearing, load, self.speed_hz, supply, mesh)
            k, c = coefficients_at(bearing, eq, self.speed_hz, supply, mesh)
            self.equilibria.append(eq)
            tangent.append((k, c))
        self.film_coefficients = tangent
        r = self.rotor
        #: (2 n_bearings, n) bearing (x, y) displacements from the coordinates.
        self.selector = r.bearing_maps.reshape(-1, r.mass.shape[0])
        self._newmark = r.mass / (BETA * self.h**2) + r.damping * GAMMA / (BETA * self.h) + r.stiffness
        self._iteration = {}

    def _iteration_inverse(self, beta_film: float) -> np.ndarray:
        """(S + P^T J P)^-1 for the film's BDF weight ``beta_film``."""
        if beta_film not in self._iteration:
            j = block_diagonal([k + beta_film / self.h * c for k, c in self.film_coefficients])
            self._iteration[beta_film] = np.linalg.inv(self._newmark + self.selector.T @ j @ self.selector)
        return self._iteration[beta_film]

    def static_state(self, flowrates_m3_s: Sequence[float], time_s: float = 0.0) -> NonlinearState:
        """Static equilibrium under the static load with steady films at the flowrates (no unbalance)."""
        r = self.rotor
        inverse = np.linalg.inv(
            r.stiffness
            + self.selector.T @ block_diagonal([k for k, _ in self.film_coefficients]) @ self.selector
        )
        guess = np.concatenate([eq.eccentricity_m for eq in self.equilibria])
        coords = inverse @ (
            r.static_force
            + self.selector.T
            @ (
                r.static_film_forces_n.reshape(-1)
                + block_diagonal([k for k, _ in self.film_coefficients]) @ guess
            )
        )
        films = [None] * len(self.films)
        for _ in range(50):
            positions = (self.selector @ coords).reshape(-1, 2)
            films = [
                solve_film(
                    bearing,
                    self.speed_hz,
                    tuple(e),
                    SupplyFlow(q),
                    mesh=self.mesh,
                    warm_start=f if f is not None else eq.film,
                )
                for bearing, e, q, f, eq in zip(
                    self.bearings, positions, flowrates_m3_s, films, self.equilibria, strict=True
                )
            ]
            force = np.concatenate([f.force_n for f in films])
            residual = r.static_force + self.selector.T @ force - r.stiffness @ coords
            step = inverse @ residual
            coords = coords + step
            if np.abs(self.selector @ step).max() < 1e-13:
                break
        else:
            raise RuntimeError("nonlinear static equilibrium did not converge in 50 iterations")
        positions = (self.selector @ coords).reshape(-1, 2)
        states = [tf.from_steady(f, e, time_s) for tf, f, e in zip(self.films, films, positions, strict=True)]
        n = coords.size
        return NonlinearState(time_s, coords, np.zeros(n), np.zeros(n), states)

    def orbit_start(self, static: NonlinearState, coefficients, flowrates_m3_s) -> NonlinearState:
        """``static`` moved onto the linear 1x orbit of the films ``[(K, C)]`` at its time, with films
        steady at the displaced journal positions (a start close to the periodic orbit)."""
        rot = self.rotor
        w = self.omega
        p = self.selector
        kb = block_diagonal([k for k, _ in coefficients])
        cb = block_diagonal([c for _, c in coefficients])
        dynamic = rot.stiffness + p.T @ kb @ p - w * w * rot.mass + 1j * w * (rot.damping + p.T @ cb @ p)
        x = np.linalg.solve(dynamic, rot.unbalance) * np.exp(1j * w * static.time_s)
        r = static.r + x.real
        positions = (p @ r).reshape(-1, 2)
        films = [
            tf.from_steady(
                solve_film(bearing, self.speed_hz, tuple(e), SupplyFlow(q), mesh=self.mesh), e, static.time_s
            )
            for bearing, tf, e, q in zip(self.bearings, self.films, positions, flowrates_m3_s, strict=True)
        ]
        return NonlinearState(static.time_s, r, (1j * w * x).real, (-w * w * x).real, films)

    def external_load(self, time_s: float) -> np.ndarray:
        """Gravity plus the unbalance load at ``time_s`` (n,) [N]."""
        load = self.rotor.static_force.copy()
        if self.unbalance:
            load += (self.rotor.unbalance * np.exp(1j * self.omega * time_s)).real
        return load

    def step(self, state: NonlinearState, flowrates_m3_s: Sequence[float]) -> NonlinearState:
        """One implicit step of ``self.h`` with the supply flowrates held over it."""
        h = self.h
        rot = self.rotor
        r, v, a = state.r, state.v, state.a
        t1 = state.time_s + h
        history = rot.mass @ (r / (BETA * h * h) + v / (BETA * h) + (0.5 / BETA - 1.0) * a) + rot.damping @ (
            GAMMA / (BETA * h) * r + (GAMMA / BETA - 1.0) * v
        )
        load = self.external_load(t1) + history
        order = min(self.films[0].order, 1 if state.films[0].previous_content_m3 is None else 2)
        inverse = self._iteration_inverse(BDF[order][0])
        r1 = r + h * v + 0.5 * h * h * a
        guesses = [None] * len(self.films)  # the first iterate starts from the films' extrapolation
        updates = []
        for iteration in range(self.max_corrections):
            positions = (self.selector @ r1).reshape(-1, 2)
            films = [
                tf.step(s, e, q, h, guess=g)
                for tf, s, e, q, g in zip(
                    self.films, state.films, positions, flowrates_m3_s, guesses, strict=True
                )
            ]
            force = np.concatenate([f.force_n for f in films])
            residual = load + self.selector.T @ force - self._newmark @ r1
            delta = inverse @ residual
            size = float(np.abs(self.selector @ delta).max())
            updates.append(size)
            # A volume that flips between full and cavitated from one iterate to the next makes the
            # force a step function of the position: damped updates then settle on the switch point.
            r1 = r1 + (delta if iteration < self.max_corrections // 2 else 0.5 * delta)
            guesses = films
            if size < self.tolerance:
                break
        else:
            if min(updates[-3:]) > LOOSE_TOLERANCE_M:
                raise RuntimeError(
                    f"rotor-film coupling did not converge in {self.max_corrections} iterations at "
                    f"t = {t1:.6g} s (position updates {', '.join(f'{u:.2g}' for u in updates)} m)"
                )
            self.loose_steps += 1
        a1 = (r1 - r) / (BETA * h * h) - v / (BETA * h) - (0.5 / BETA - 1.0) * a
        v1 = v + h * ((1.0 - GAMMA) * a + GAMMA * a1)
        return NonlinearState(t1, r1, v1, a1, films)

    def run(
        self,
        state: NonlinearState,
        n_steps: int,
        flowrates: Callable[[float], Sequence[float]],
        progress: Callable[[int], None] | None = None,
    ) -> tuple[NonlinearState, dict]:
        """``n_steps`` steps; ``flowrates(t)`` gives (q1, q2) [m^3/s]. Returns the final state and the
        record: time_s (m,), bearing_positions_m (m, nb, 2), film_forces_n (m, nb, 2), side_leakage_m3_s
        (m, nb), content_m3 (m, nb)."""
        if n_steps < 1:
            raise InputError(f"n_steps must be >= 1, got {n_steps}")
        nb = len(self.films)
        record = {
            "time_s": np.empty(n_steps),
            "bearing_positions_m": np.empty((n_steps, nb, 2)),
            "film_forces_n": np.empty((n_steps, nb, 2)),
            "side_leakage_m3_s": np.empty((n_steps, nb)),
            "content_m3": np.empty((n_steps, nb)),
        }
        for k in range(n_steps):
            state = self.step(state, flowrates(state.time_s + self.h))
            record["time_s"][k] = state.time_s
            record["bearing_positions_m"][k] = (self.selector @ state.r).reshape(-1, 2)
            record["film_forces_n"][k] = [f.force_n for f in state.films]
            record["side_leakage_m3_s"][k] = [f.side_leakage_m3_s for f in state.films]
            record["content_m3"][k] = [f.total_content_m3 for f in state.films]
            if progress is not None:
                progress(k + 1)
        return state, record
