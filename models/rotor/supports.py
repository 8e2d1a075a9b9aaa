"""Linear bearing supports: 8 coefficients per bearing, added to the rotor's K and C.

Lund's convention (the team contract): the film force on the journal, linearized about its
equilibrium, is f = f0 - K (r - r0) - C r', with K_ij = -dF_i/dx_j and C_ij = -dF_i/dxdot_j,
i, j in (x, y). Only the translational dofs of the bearing node are coupled.
Reference: Friswell et al., "Dynamics of Rotating Machines" (2010), ch. 5 (bearings and seals).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..validation import InputError, require_non_negative

BearingSupplier = Callable[[float], Sequence["LinearBearing"]]


@dataclass(frozen=True, eq=False)
class LinearBearing:
    """A linear bearing at ``node`` (from 1): stiffness (2, 2) [N/m], damping (2, 2) [N s/m].

    Rows and columns are (x, y): [[kxx, kxy], [kyx, kyy]] and [[cxx, cxy], [cyx, cyy]].
    """

    node: int
    stiffness: np.ndarray
    damping: np.ndarray

    def __post_init__(self) -> None:
        if isinstance(self.node, bool) or not isinstance(self.node, int | np.integer) or self.node < 1:
            raise InputError(f"bearing node must be an integer node number >= 1, got {self.node!r}")
        for name in ("stiffness", "damping"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (2, 2):
                raise InputError(f"bearing {name} must be a 2x2 matrix, got shape {value.shape}")
            if not np.all(np.isfinite(value)):
                raise InputError(f"bearing {name} at node {self.node} must be finite")
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @classmethod
    def isotropic(cls, node: int, stiffness_n_m: float, damping_n_s_m: float) -> LinearBearing:
        """kxx = kyy = k, cxx = cyy = c, no cross-coupling; k, c >= 0."""
        k = require_non_negative("bearing stiffness", stiffness_n_m, "N/m")
        c = require_non_negative("bearing damping", damping_n_s_m, "N s/m")
        return cls(node, k * np.eye(2), c * np.eye(2))


def isotropic_bearings(
    nodes: Sequence[int], stiffness_n_m: float, damping_n_s_m: float
) -> list[LinearBearing]:
    """The same isotropic linear bearing at every node of ``nodes``."""
    return [LinearBearing.isotropic(n, stiffness_n_m, damping_n_s_m) for n in nodes]


def bearing_matrices(n_dof: int, bearings: Sequence[LinearBearing]) -> tuple[np.ndarray, np.ndarray]:
    """Global bearing stiffness K_b and damping C_b (n_dof, n_dof) to add to the rotor's K, C."""
    k_b = np.zeros((n_dof, n_dof))
    c_b = np.zeros((n_dof, n_dof))
    for bearing in bearings:
        first = 4 * (bearing.node - 1)
        if not 0 <= first < n_dof:
            raise InputError(
                f"bearing node {bearing.node} is not a node of this rotor (nodes 1..{n_dof // 4})"
            )
        block = slice(first, first + 2)
        k_b[block, block] += bearing.stiffness
        c_b[block, block] += bearing.damping
    return k_b, c_b


def resolve_bearings(
    bearings: Sequence[LinearBearing] | BearingSupplier, speed_hz: float
) -> Sequence[LinearBearing]:
    """The bearings at ``speed_hz``: a fixed list, or a callable speed_hz -> list of bearings."""
    return bearings(speed_hz) if callable(bearings) else bearings
