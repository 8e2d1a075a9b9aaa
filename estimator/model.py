"""The contract between the estimator and a rotor-bearing system model (paper Eqs. 14-16).

The estimator never builds physics itself: it drives any object that satisfies :class:`AugmentedModel`.
``oilwatch.models.system`` implements it (full 168-state or reduced order); the tests use the toy
oscillator of ``tests/fixtures/toy_model.py``.

State convention: the dynamic state ``s`` is absolute, i.e. the measured displacements ``H @ s`` are measured
from the bearing centre with the static eccentricity included, because gravity and the ``K(q) e0(q)`` term are
inputs of the model. The flowrates ``q = [q1, q2]`` (m^3/s) are the augmented states; the filter rescales them
internally (see :mod:`oilwatch.estimator.ekf`), the model always sees SI units.

Beyond the four members requested at the start (``n_states``, ``dt_s``, ``output_matrix``,
``bearing_flowrate_bounds_m3_s``, ``transition``) the estimator needs two more, because the state may be a
set of reduced (modal or Craig-Bampton) coordinates whose meaning only the model knows:

* ``velocity_output_matrix`` maps the state to the measured points' velocities, for the paper's differentiated
  velocity channels;
* ``physical_covariance`` expresses "independent errors of std a on every displacement and b on every
  velocity" in the model's own coordinates; the filter builds the process noise Q and the initial covariance
  P0 with it.

An optional third, ``static_state(flowrate)``, gives the static equilibrium for the ``initial_state="static"``
option of :class:`oilwatch.estimator.ekf_config.EKFConfig`; models without it support only the paper's zero
initial state. Two optional attributes carry the machine facts a configuration may leave open
(``EKFConfig.for_model``): ``nominal_flowrates_m3_s`` ((2,), each bearing's nominal supply flowrate) and
``speed_hz`` (the model's speed). An optional attribute ``clearance_m`` (the bearings' radial clearance [m])
sets the probes' physical range (it plus ``ekf_config.PROBE_RANGE_MARGIN_M``); without it there is no range
check.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class AugmentedModel(Protocol):
    """A discrete-time rotor-bearing model ``s_{k+1} = f(s_k, q, k)`` whose inputs depend on the flowrates.

    Attributes
    ----------
    n_states : number of dynamic states ``n`` (displacements and velocities, or reduced coordinates).
    dt_s : sampling period [s].
    output_matrix : (4, n) measured displacements [m] ``= H @ s`` in the order (x1, y1, x2, y2).
    velocity_output_matrix : (4, n) velocities [m/s] of the same four measured coordinates ``= H_v @ s``.
    bearing_flowrate_bounds_m3_s : (2, 2) each bearing's flowrate range [m^3/s], row b (low, high) of
        bearing b + 1's own coefficient tables; ``transition`` is only called with each flowrate inside its
        bearing's range.
    """

    n_states: int
    dt_s: float
    output_matrix: np.ndarray
    velocity_output_matrix: np.ndarray
    bearing_flowrate_bounds_m3_s: np.ndarray

    def transition(
        self, state: np.ndarray, flowrate_m3_s: np.ndarray, step: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``s_{k+1} = f(s_k, q, k)`` (Eq. 16) and the Jacobians ``df/ds`` (n, n) and ``df/dq`` (n, 2).

        ``state`` is (n,) [SI], ``flowrate_m3_s`` is (2,) [m^3/s]; ``step`` k gives the unbalance phase
        through ``t_k = k dt_s``. The returned arrays may be reused by the model on the next call: the
        estimator copies what it keeps.
        """
        ...

    def physical_covariance(self, displacement_std_m: float, velocity_std_m_s: float) -> np.ndarray:
        """Return the (n, n) covariance, in the model's coordinates, of independent zero-mean errors with std
        ``displacement_std_m`` on every displacement dof and ``velocity_std_m_s`` on every velocity dof.

        For physical coordinates this is diagonal; for a reduced basis ``T`` (physical = T @ reduced) it is
        the projection ``T^+ diag(...) T^+^T``. It must be symmetric positive definite.
        """
        ...


def has_static_state(model: AugmentedModel) -> bool:
    """True if ``model`` offers ``static_state(flowrate_m3_s) -> (n,)``, the static equilibrium state [SI]."""
    return callable(getattr(model, "static_state", None))
