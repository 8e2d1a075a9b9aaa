"""Global finite-element rotor: shaft elements plus rigid discs, M r'' + (C + Omega G) r' + K r = u.

Reference: Friswell et al., "Dynamics of Rotating Machines" (2010), ch. 5 and 6. Nodes are
numbered from 1 as in the paper; node k sits at the left end of element k. The global dof of
(node, direction) is 4 (node - 1) + j with j = 0 (V, x), 1 (W, y), 2 (B, about x),
3 (Gamma, about y). x is horizontal, y vertical up, gravity along -y, spin about +z.

Structural damping (a documented choice, the paper gives none): stationary-frame viscous damping
proportional to the shaft stiffness, C = beta K, beta from the machine file
(``[rotor_damping] stiffness_proportional_s``). It gives each free shaft mode the damping ratio
beta omega / 2 and leaves rigid-body motion undamped. The rotating-frame internal-damping
(circulatory) term is deliberately left out, as in the paper's Eq. 4.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..bearing.geometry import load_polar
from ..machine import Machine
from ..machine_sections import Material, StaticForce
from ..validation import InputError, require_non_negative, require_positive
from .disc import RigidDisc
from .timoshenko import (
    element_gravity_load,
    element_gyroscopic,
    element_mass,
    element_stiffness,
)

DIRECTIONS = {"x": 0, "y": 1, "rx": 2, "ry": 3}
DOF_PER_NODE = 4


def _assemble(element_matrices: np.ndarray, n_dof: int) -> np.ndarray:
    """Sum (n_el, 8, 8) element matrices into an (n_dof, n_dof) matrix (elements share 4 dofs)."""
    n_el = element_matrices.shape[0]
    index = (np.arange(n_el) * DOF_PER_NODE)[:, None] + np.arange(8)[None, :]
    out = np.zeros((n_dof, n_dof))
    np.add.at(out, (index[:, :, None], index[:, None, :]), element_matrices)
    return out


@dataclass(frozen=True, eq=False, repr=False)
class Rotor:
    """Assembled rotor model; matrices (n_dof, n_dof) in SI units, vectors (n_dof,).

    Attributes
    ----------
    node_positions_m : (n_nodes,) axial node positions from the left end [m].
    mass_matrix, stiffness_matrix, damping_matrix : M, K, C (structural, C = beta K).
    gyroscopic_matrix : G per unit spin speed [kg m^2]; the spin term is Omega G r'.
    gravity_force : static weight load (shaft consistent loads + disc weights) [N, N m].
    discs : ((node, RigidDisc), ...).
    total_mass_kg, shaft_mass_kg : rotor and shaft mass [kg].
    gravity_m_s2 : g [m/s^2].
    unbalance_node, unbalance_moment_kg_m, unbalance_phase_rad : m_e and phi of Eqs. 5-6.
    bearing_nodes : nodes carrying a bearing.
    bearing_static_loads_n : (n_bearings,) magnitude of the static load each bearing carries [N]: its
        share of the weight by the machine's load split, or the load its machine file gives.
    bearing_load_angles_rad : (n_bearings,) bearing angle each static load points along [rad] (from the
        top, with the rotation; pi, -y, for the weight).
    static_force : the constant load (n_dof,) [N, N m]: ``gravity_force`` plus, at each bearing whose static
        load is not its share of the weight, the external force (a gear mesh, a belt, a process force) that
        makes it so: the load vector minus the weight share's.
    """

    node_positions_m: np.ndarray
    mass_matrix: np.ndarray
    stiffness_matrix: np.ndarray
    damping_matrix: np.ndarray
    gyroscopic_matrix: np.ndarray
    gravity_force: np.ndarray
    discs: tuple[tuple[int, RigidDisc], ...]
    total_mass_kg: float
    shaft_mass_kg: float
    gravity_m_s2: float
    unbalance_node: int
    unbalance_moment_kg_m: float
    unbalance_phase_rad: float
    bearing_nodes: tuple[int, ...]
    bearing_static_loads_n: np.ndarray
    bearing_load_angles_rad: np.ndarray
    static_force: np.ndarray

    @classmethod
    def build(
        cls,
        element_lengths_m: Sequence[float],
        element_diameters_m: Sequence[float],
        material: Material,
        discs: Sequence[tuple[int, RigidDisc]] = (),
        *,
        gravity_m_s2: float = 9.81,
        structural_damping_s: float = 0.0,
        unbalance_node: int = 1,
        unbalance_moment_kg_m: float = 0.0,
        unbalance_phase_rad: float = 0.0,
        bearing_nodes: Sequence[int] = (),
        load_split: str = "equal",
        static_loads_given_n: Sequence[float | None] = (),
        load_angles_rad: Sequence[float] = (),
        static_forces: Sequence[StaticForce] = (),
    ) -> Rotor:
        """Assemble a rotor from element lengths/diameters (n_el,) [m], material and discs.

        ``load_split`` "equal" gives each bearing W / n_bearings (the paper); "reactions" gives the
        support reactions of the rotor on rigid supports at ``bearing_nodes``. ``static_loads_given_n``
        (one per bearing, None: its share) and ``load_angles_rad`` (one per bearing; empty: every load
        along -y) give a bearing a static load other than its share of the weight; the rotor then carries
        the external force that makes up the difference at that bearing's node (``static_force``).
        ``static_forces`` (not with the two before) are steady forces at rotor nodes; each bearing's load is
        then its weight share plus its reaction to them on rigid point supports at ``bearing_nodes``, in
        magnitude and direction (statically determinate on two bearings).
        """
        lengths = np.asarray(element_lengths_m, dtype=float)
        diameters = np.asarray(element_diameters_m, dtype=float)
        if lengths.ndim != 1 or lengths.shape != diameters.shape or lengths.size == 0:
            raise InputError("element lengths and diameters must be two 1-D arrays of equal size")
        if np.any(~np.isfinite(lengths)) or np.any(lengths <= 0.0):
            raise InputError("element lengths must be finite and > 0 m")
        if np.any(~np.isfinite(diameters)) or np.any(diameters <= 0.0):
            raise InputError("element diameters must be finite and > 0 m")
        beta = require_non_negative("structural_damping_s", structural_damping_s, "s")
        n_nodes = lengths.size + 1
        n_dof = DOF_PER_NODE * n_nodes
        for label, node in [("unbalance_node", unbalance_node)] + [
            (f"disc node {i}", n) for i, (n, _) in enumerate(discs)
        ]:
            _check_node(label, node, n_nodes)
        for node in bearing_nodes:
            _check_node("bearing node", node, n_nodes)

        mass = _assemble(element_mass(lengths, diameters, material), n_dof)
        stiffness = _assemble(element_stiffness(lengths, diameters, material), n_dof)
        gyro = _assemble(element_gyroscopic(lengths, diameters, material), n_dof)
        gravity = np.zeros(n_dof)
        loads = element_gravity_load(lengths, diameters, material, gravity_m_s2)
        np.add.at(gravity, (np.arange(lengths.size) * DOF_PER_NODE)[:, None] + np.arange(8), loads)
        for node, disc in discs:
            block = slice(DOF_PER_NODE * (node - 1), DOF_PER_NODE * node)
            mass[block, block] += disc.mass_matrix()
            gyro[block, block] += disc.gyroscopic_matrix()
            gravity[DOF_PER_NODE * (node - 1) + 1] -= disc.mass_kg * gravity_m_s2

        shaft_mass = float(np.sum(material.density_kg_m3 * np.pi * diameters**2 / 4.0 * lengths))
        total_mass = shaft_mass + sum(d.mass_kg for _, d in discs)
        positions = np.concatenate([[0.0], np.cumsum(lengths)])
        weight = total_mass * gravity_m_s2
        shares = _bearing_loads(stiffness, gravity, tuple(bearing_nodes), weight, load_split)
        static_force = gravity.copy()
        if static_forces:
            if any(g is not None for g in static_loads_given_n) or len(load_angles_rad):
                raise InputError("static forces give the bearings' loads: give no bearing load with them")
            applied = np.zeros(n_dof)
            for force in static_forces:
                _check_node("static force node", force.node, n_nodes)
                applied[DOF_PER_NODE * (force.node - 1) : DOF_PER_NODE * (force.node - 1) + 2] += (
                    force.vector_n()
                )
            static_force += applied
            static_loads, angles = _statics_loads(stiffness, applied, tuple(bearing_nodes), shares)
        else:
            static_loads, angles, external = _given_loads(shares, static_loads_given_n, load_angles_rad)
            for node, force in zip(bearing_nodes, external, strict=True):
                static_force[DOF_PER_NODE * (node - 1) : DOF_PER_NODE * (node - 1) + 2] += force
        for array in (positions, mass, stiffness, gyro, gravity, static_loads, angles, static_force):
            array.setflags(write=False)
        damping = beta * stiffness
        damping.setflags(write=False)
        return cls(
            node_positions_m=positions,
            mass_matrix=mass,
            stiffness_matrix=stiffness,
            damping_matrix=damping,
            gyroscopic_matrix=gyro,
            gravity_force=gravity,
            discs=tuple((int(n), d) for n, d in discs),
            total_mass_kg=total_mass,
            shaft_mass_kg=shaft_mass,
            gravity_m_s2=float(gravity_m_s2),
            unbalance_node=int(unbalance_node),
            unbalance_moment_kg_m=float(unbalance_moment_kg_m),
            unbalance_phase_rad=float(unbalance_phase_rad),
            bearing_nodes=tuple(int(n) for n in bearing_nodes),
            bearing_static_loads_n=static_loads,
            bearing_load_angles_rad=angles,
            static_force=static_force,
        )

    @classmethod
    def from_machine(cls, machine: Machine) -> Rotor:
        """Assemble the rotor of a machine file (discs as annuli, ISO-grade unbalance moment).

        The unbalance moment is m_e = total mass * grade / Omega_nominal (ISO 1940).
        """
        rho = machine.material.density_kg_m3
        discs = [
            (d.node, RigidDisc.annulus(rho, d.width_m, d.outer_diameter_m, d.bore_diameter_m))
            for d in machine.discs
        ]
        shaft_mass = float(
            np.sum(rho * np.pi * machine.element_diameters_m**2 / 4.0 * machine.element_lengths_m)
        )
        total_mass = shaft_mass + sum(d.mass_kg for _, d in discs)
        eccentricity = machine.unbalance.iso_grade_m_s / machine.nominal_speed_rad_s
        return cls.build(
            machine.element_lengths_m,
            machine.element_diameters_m,
            machine.material,
            discs,
            gravity_m_s2=machine.gravity_m_s2,
            structural_damping_s=machine.structural_damping_s,
            unbalance_node=machine.unbalance.node,
            unbalance_moment_kg_m=total_mass * eccentricity,
            unbalance_phase_rad=machine.unbalance.phase_rad,
            bearing_nodes=machine.bearing_nodes,
            load_split=machine.load_split,
            static_loads_given_n=() if machine.static_forces else machine.static_loads_given_n,
            # with static forces the directions are the statics' (and the bearings hold them already)
            load_angles_rad=() if machine.static_forces else [b.load_angle_rad for b in machine.bearings],
            static_forces=machine.static_forces,
        )

    def __repr__(self) -> str:
        return (
            f"Rotor(n_nodes={self.n_nodes}, n_dof={self.n_dof}, total_mass_kg={self.total_mass_kg:.2f}, "
            f"discs at {[n for n, _ in self.discs]}, bearings at {list(self.bearing_nodes)})"
        )

    @property
    def n_nodes(self) -> int:
        """Number of nodes."""
        return int(self.node_positions_m.size)

    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom, 4 n_nodes."""
        return DOF_PER_NODE * self.n_nodes

    @property
    def weight_n(self) -> float:
        """Rotor weight m g [N]."""
        return self.total_mass_kg * self.gravity_m_s2

    def dof(self, node: int, direction: str) -> int:
        """Global dof index of ``direction`` ("x", "y", "rx", "ry") at ``node`` (from 1)."""
        _check_node("node", node, self.n_nodes)
        if direction not in DIRECTIONS:
            raise InputError(f"direction must be one of {tuple(DIRECTIONS)}, got {direction!r}")
        return DOF_PER_NODE * (node - 1) + DIRECTIONS[direction]

    def unbalance_amplitude(self, omega_rad_s: float) -> np.ndarray:
        """Complex unbalance load F (n_dof,) [N] such that the force is Re(F exp(i Omega t)).

        Eqs. 5-6: F_x = m_e Omega^2 cos(Omega t + phi), F_y = m_e Omega^2 sin(Omega t + phi),
        hence F_x = m_e Omega^2 e^{i phi} and F_y = -i m_e Omega^2 e^{i phi}.
        """
        amplitude = self.unbalance_moment_kg_m * omega_rad_s**2 * np.exp(1j * self.unbalance_phase_rad)
        force = np.zeros(self.n_dof, dtype=complex)
        force[self.dof(self.unbalance_node, "x")] = amplitude
        force[self.dof(self.unbalance_node, "y")] = -1j * amplitude
        return force

    def unbalance_force(self, omega_rad_s: float, time_s: float) -> np.ndarray:
        """Real unbalance load (n_dof,) [N] at time t, Eqs. 5-6 with Omega = omega_rad_s."""
        return np.real(self.unbalance_amplitude(omega_rad_s) * np.exp(1j * omega_rad_s * time_s))


def _check_node(label: str, node: int, n_nodes: int) -> None:
    if isinstance(node, bool) or not isinstance(node, int | np.integer):
        raise InputError(f"{label} must be an integer node number, got {node!r}")
    if not 1 <= node <= n_nodes:
        raise InputError(f"{label} = {node} is not a node of this rotor (nodes 1..{n_nodes})")


def _given_loads(
    shares: np.ndarray, given_n: Sequence[float | None], angles_rad: Sequence[float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(load magnitudes (n_b,) [N], load angles (n_b,) [rad], external forces (n_b, 2) [N]) of bearings
    whose weight shares are ``shares``: the given magnitudes and angles where there are, the external
    force at each bearing the load vector minus the weight share's (0, -share)."""
    n = shares.size
    given = list(given_n) or [None] * n
    angles = np.array(angles_rad, dtype=float) if len(angles_rad) else np.full(n, math.pi)
    if len(given) != n or angles.shape != (n,):
        raise InputError(f"static loads and load angles: need one per bearing ({n})")
    loads = np.array([share if g is None else require_positive("static_load_n", g, "N")
                      for share, g in zip(shares, given, strict=True)], dtype=float)  # fmt: skip
    if np.any(~np.isfinite(angles)):
        raise InputError("load angles must be finite")
    # the load along bearing angle beta is L (-sin beta, cos beta) = L (sin t, -cos t) with t = beta - pi,
    # written with t so that a load along -y is exactly (0, -L) and its external force exactly zero
    turn = angles - math.pi
    external = np.column_stack([loads * np.sin(turn), shares - loads * np.cos(turn)])
    return loads, angles, external


def _statics_loads(
    stiffness: np.ndarray, applied: np.ndarray, bearing_nodes: tuple[int, ...], shares: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(load magnitudes (n_b,) [N], directions (n_b,) [rad]) of bearings carrying their weight ``shares`` and
    their reactions to the static forces ``applied`` (n_dof,) on rigid point supports at ``bearing_nodes``."""
    # the journal pushes on its film against the support's reaction
    loads = -_support_reactions(stiffness, applied, bearing_nodes, "static forces")
    loads[:, 1] -= shares
    magnitudes, angles = load_polar(loads)
    for b, magnitude in enumerate(magnitudes):
        if not magnitude > 1e-9 * max(shares.max(initial=0.0), 1.0):
            raise InputError(
                f"bearing {b + 1}: the static forces and the weight cancel on it ({magnitude:.3g} N): a film "
                "needs a static load"
            )
    return magnitudes, angles


def _support_reactions(
    stiffness: np.ndarray, load: np.ndarray, bearing_nodes: tuple[int, ...], what: str
) -> np.ndarray:
    """(n_b, 2) [N]: the (x, y) forces that rigid point supports at ``bearing_nodes`` exert on the rotor under
    ``load`` (n_dof,), K_bf r_f - F_b; ``what`` names the load in the error of a rotor they do not hold."""
    fixed = np.array([DOF_PER_NODE * (n - 1) + j for n in bearing_nodes for j in (0, 1)], dtype=int)
    free = np.setdiff1d(np.arange(stiffness.shape[0]), fixed)
    try:
        r_free = np.linalg.solve(stiffness[np.ix_(free, free)], load[free])
    except np.linalg.LinAlgError:
        raise InputError(
            f"{what}: the supports must hold the rotor statically (at least two bearing nodes)"
        ) from None
    return (stiffness[np.ix_(fixed, free)] @ r_free - load[fixed]).reshape(-1, 2)


def _bearing_loads(
    stiffness: np.ndarray,
    gravity: np.ndarray,
    bearing_nodes: tuple[int, ...],
    weight: float,
    load_split: str,
) -> np.ndarray:
    """Static load per bearing [N]: equal shares, or reactions on rigid point supports."""
    if not bearing_nodes:
        return np.zeros(0)
    if load_split == "equal":
        return np.full(len(bearing_nodes), weight / len(bearing_nodes))
    if load_split != "reactions":
        raise InputError(f"load_split must be 'equal' or 'reactions', got {load_split!r}")
    reactions = _support_reactions(stiffness, gravity, bearing_nodes, "load_split = 'reactions'")[:, 1]
    if not math.isclose(reactions.sum(), weight, rel_tol=1e-6):
        raise InputError("load_split = 'reactions': the supports do not carry the rotor weight")
    return reactions.copy()
