"""Consistent estimation of the flowrates beside unknown nuisances: shadow Jacobian and settling start.

With the probe offsets, the complex unbalance and the viscosity factors unknown, the flowrates and the
nuisances theta have a nearly unobservable direction: a lower flow, a thicker film, a larger unbalance and
shifted offsets give almost the same static position and 1x orbit (``models/system/nuisance_bound.py``; on
the turbine's operating model the exact maps give a bound of 3.2 / 2.9 % of q for 60 s at nominal with all
of them unknown, 7.9 / 7.0 % for 10 s). The EKF's Jacobian of the prediction with respect to theta,
``dA/dtheta s + dG/dtheta w``, is evaluated at the estimated dynamic state ``s``. On the true motion its
two terms nearly cancel along that direction; the estimate's error (the start from zero, then the
measurement noise the state estimate follows) does not cancel, and the update takes it for information: on
the turbine the filter's q std fell to 1.2 % in 0.1 s with the nuisances at their true values (5-6 % with
the Jacobians at the true states), and the estimates settled 5-11 % off with the viscosity factors at
1.05-1.2. This is the errors-in-variables bias of a regression on noisy regressors (Soderstrom & Stoica,
"Instrumental variable methods for system identification", 1983; Ljung, "System Identification", 2nd ed.
1999, sec. 7.6), in an EKF the information gained along unobservable directions from Jacobians at the wrong
estimates (Huang, Mourikis & Roumeliotis, Int. J. Robotics Research 29, 2010).

Two remedies, on while the viscosity factors are estimated without a baseline's prior for them: the factor
is what makes the direction nearly unobservable (the bound at 60 s with offsets and unbalance unknown is
0.26 % of q, 3.2 % with the factors as well, 0.07 % with a baseline), and with the factors known or primed by
a baseline the filter is unchanged (its figures there are within 2 std: README robustness table).

* The shadow Jacobian (:class:`ShadowJacobian`): the Jacobian with respect to the flowrates and the
  nuisances is evaluated at a noise-free shadow of the dynamic state, the model run at the current
  estimates (``s~+ = f(s~, theta^)``): the instrument of the instrumental-variable method, correlated with
  the motion and not with the noise. The state Jacobian and the prediction stay the EKF's own.
* The settling start (:func:`settling_steps`, :func:`restart_parameters`): for a few time constants of the
  model's least damped mode the flowrates and the nuisances stay out of the Jacobian while the dynamic
  states (and the shadow) settle on the motion, and then start from their prior, uncorrelated with them.
"""

from __future__ import annotations

import math

import numpy as np


def settling_steps(model, flowrate_m3_s, time_constants: float) -> int:
    """Steps of ``time_constants`` time constants of the least damped mode of ``model``'s transition at
    ``flowrate_m3_s`` (0 when ``time_constants`` is 0 or no mode decays: no settling start)."""
    if time_constants <= 0.0:
        return 0
    state_jacobian = np.asarray(model.transition(np.zeros(model.n_states), flowrate_m3_s, 0)[1])
    slowest = float(np.max(np.abs(np.linalg.eigvals(state_jacobian))))
    if not 0.0 < slowest < 1.0:
        return 0
    return math.ceil(time_constants / -math.log(slowest))


def restart_parameters(x: np.ndarray, covariance: np.ndarray, prior_x, prior_covariance, n: int) -> None:
    """Put the flowrates and nuisances (entries from ``n`` on) back to their prior, uncorrelated with the
    dynamic states (in place)."""
    x[n:] = prior_x[n:]
    covariance[n:, :n] = 0.0
    covariance[:n, n:] = 0.0
    covariance[n:, n:] = prior_covariance[n:, n:]


class ShadowJacobian:
    """The flowrate and nuisance Jacobian of a prediction at the noise-free shadow state (module docstring).

    ``predict(model_step, state)`` is the filter's own prediction (``(s_next, df/ds, df/dq)``, with the
    nuisance columns written to ``trailing``); :meth:`jacobians` runs it from the shadow, keeps its
    parameter columns and advances the shadow.
    """

    def __init__(self, n: int, n_trailing: int) -> None:
        self.state = None
        self.flow_jacobian = np.zeros((n, 2))
        self.trailing = np.zeros((n, n_trailing))

    def reset(self) -> None:
        """Start again from the filter's estimate at the next prediction."""
        self.state = None

    def jacobians(self, predict, estimate: np.ndarray, trailing: np.ndarray, model_step: int):
        """``(df/dq, d f/d nuisances)`` at the shadow (copies); the shadow moves one step on."""
        if self.state is None:
            self.state = estimate.copy()
        next_shadow, _, flow_jacobian = predict(model_step, self.state)
        self.state = np.array(next_shadow, dtype=float)
        self.flow_jacobian[:] = flow_jacobian
        self.trailing[:] = trailing
        return self.flow_jacobian, self.trailing
