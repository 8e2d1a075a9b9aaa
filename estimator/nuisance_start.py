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

from .ekf_config import (
    INITIAL_FLOWRATE_STD_FRACTION,
    UNBALANCE_RANDOM_WALK_SQRT_S,
    VISCOSITY_FACTOR_RANDOM_WALK_SQRT_S,
)
from .measurement import probe_rotation


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
    parameter columns and advances the shadow. The filter's compiled step on the operating model advances
    ``state`` in place instead (:func:`oilwatch.estimator.step_kernel.operating_step`).
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


UPDATE_S = 2.0
"""How often the floor takes in the record's information [s]; the bound moves little within 2 s."""
POINTS = 9
"""The exact-map responses of one update
(:func:`oilwatch.models.system.trajectory_bound.sensitivity_points`)."""
STAGES = 2 * POINTS
"""The steps of one update: each point's continuous block, then its exponential and response (0.1-0.3 ms
each, where the whole update in one step was 4-8 ms, a latency spike every 2 s)."""


class InformationFloor:
    """A floor for the flowrates' std: the posterior Cramer-Rao bound of the filter's own configuration.

    With the viscosity factors free the filter's covariance claims more information about q than the record
    holds (README bound section: its std 1.4-2.3 times below the posterior bound under the ramps, equal to
    it within 5 % in every configuration with the factors known). The bound is the information recursion of
    :func:`oilwatch.models.system.trajectory_bound.tracking_bound_pct`: the parameters (flowrates, factors,
    unbalance, offsets) random-walk as the filter models them, and every ``update_s`` the record adds the
    information of the steady static position and 1x orbit at the model's operating point, evaluated at the
    current estimates (the truth is unknown). It is a lower bound on any estimator's mean-square error under
    the filter's own model, so a filter std below it is a claim the data cannot back: the reported std of
    each flowrate is the larger of the filter's and the bound's. The filter's covariance itself, and so its
    gain and estimates, is left alone: widening it to the bound (a congruence on the flowrates' rows and
    columns) moved the temperature-ramp rows from +1.59 / +1.01 and -10.95 / -7.60 % to -3.76 / +0.22 and
    -0.34 / +13.63 %: along the nearly unobservable direction any change of the gain moves the end point
    by several %, and none of it towards the truth.

    Slow-roll compensation (``config.runout``) subtracts 1x vectors known only to the fit's std s per
    component. That residual turns with the rotor like the 1x orbit, so it does not average out with the
    samples as white noise does: the filter reads it as flow, unbalance and offsets. The floor carries the
    bias it causes as a "consider" covariance (Schmidt; Crassidis & Junkins 2012, *Optimal Estimation of
    Dynamic Systems*, sec. 2.6): the response of an estimate to a constant error delta in the 1x
    observations, ``b = S delta``, follows each update as the information filter's mean does
    (``S+ = P+ (P-^-1 S + I_k)``, ``I_k`` the update's information per unit observation), and its
    covariance ``S diag(s^2) S^T`` adds to the bound's. The estimator it follows is the bound's with the
    viscosity factors held: the filter's shadow Jacobian keeps the factors off the nearly unobservable
    direction, and with them free the term claimed 4-5 times the spread the filter shows
    (``tests/test_slow_roll_consider.py``, by direct simulation). Each 0.01 um of s is worth about 0.4 % of
    flow on the bundled turbine; without slow-roll vectors that part is absent.

    The probes' scale factors (``config.probe_scale_factor_std``: API 670 allows +-5 % per probe, cable and
    driver set) are a second considered error: probe i reads its displacement times ``1 + delta_i``, an
    error ``delta_i`` times the static position and the 1x orbit it reads (along the probe's axis), which
    the filter reads as flow, unbalance and offsets like any other 1x error. Its columns of ``S`` follow
    the same recursion with the observation error per unit ``delta`` (:func:`scale_columns`) at each
    update's point. A commissioning baseline taken with the same probes learnt its offsets and unbalance
    from readings scaled the same way: the record's estimator starts with their bias, the least-squares
    projection of the baseline point's scale error on those nuisances, so that only what changed since
    the baseline is read as flow. At 2.9 % per probe (API 670's tolerance as a uniform error) the term is
    3.1 / 2.3 % of flow on the bundled turbine at 80 / 90 % of nominal after 30 s, against a spread of
    2.2 / 1.8 % over random draws (``tests/test_probe_scale_consider.py``, by direct simulation).

    Where a commissioning baseline primed the nuisances there is no bound to floor (``bound`` False: the
    filter's std is the record's), and the floor is the consider term alone, from the baseline's prior,
    added to the filter's std in quadrature (:meth:`published_std`). On the model on the flowrate grid
    (the paper's, at one speed) the exact maps are the grid's own (``GridAugmentedModel.maps``) and the floor
    is the consider term alone too: that model has no viscosity factors, so no bound.

    The work of an update is spread over :data:`STAGES` steps, so that no step pays for all of it: at the
    step an update is due (:meth:`due`) the estimates and the operating point are taken (:meth:`begin`),
    and that step and the next ones each evaluate half of one response (:meth:`work`); the last applies it,
    ``STAGES - 1`` samples after the estimates were taken. The bound is the same number as when all was
    done in the due step; it is reported from 17 samples later (the previous bound until then). The first
    update after a reset or the settling start's restart is done whole in its due step, as before: it takes
    the floor from the prior (25 % of nominal, which holds the alarm off) to the record's bound, so the
    alarm's timing stays the same (one 4-8 ms step, 2 s after the settling start).
    """

    def __init__(
        self,
        model,
        config,
        n: int,
        n_offsets: int,
        n_unbalance: int,
        update_s: float = UPDATE_S,
        bound: bool = True,
    ) -> None:
        from oilwatch.models.system.trajectory_bound import parameter_columns

        groups = ["viscosity"]
        if n_unbalance:
            groups.append("unbalance")
        if n_offsets:
            groups.append("offsets")
        self._columns = parameter_columns(tuple(groups))
        self._model = model
        self._n = n
        self._dt = float(model.dt_s)
        self._every = max(1, round(update_s / self._dt))
        self._noise = float(config.noise_std_m)
        q0 = np.asarray(config.q_initial_pair(), dtype=float)
        if config.initial_flowrate_std_m3_s is not None:
            initial_q = np.array(config.initial_flowrate_std_pair())
        elif config.q_nominal_m3_s is not None:
            initial_q = INITIAL_FLOWRATE_STD_FRACTION * np.array(config.q_nominal_pair())
        else:
            initial_q = np.full(2, INITIAL_FLOWRATE_STD_FRACTION * float(q0.mean()))
        prior = np.r_[
            initial_q,
            np.full(2, config.viscosity_factor_prior_std),
            np.full(2, config.unbalance_prior_std),
            np.full(4, config.offset_prior_std_m * 1e6),
        ]
        walk = np.r_[
            np.full(2, config.flowrate_process_std_m3_s / math.sqrt(self._dt)),
            np.full(2, VISCOSITY_FACTOR_RANDOM_WALK_SQRT_S),
            np.full(2, UNBALANCE_RANDOM_WALK_SQRT_S),
            np.full(4, config.offset_random_walk_m_sqrt_s * 1e6),
        ]
        c = self._columns
        self._prior = np.diag(prior[c] ** 2)
        self._walk = np.diag(walk[c] ** 2) * self._every * self._dt
        # the considered errors' variances (class docstring): the slow-roll fit's per observation row (static
        # rows 0:4, the 1x parts 4:12, the same std for a probe's real and imaginary parts), then each
        # probe's scale factor
        runout = config.runout
        once = np.zeros(4) if runout is None else np.asarray(runout.once_std_m, dtype=float) ** 2
        scale = np.full(4, float(config.probe_scale_factor_std) ** 2)
        self._consider_variance = np.r_[np.zeros(4), once, once, scale]
        self._considered = bool(self._consider_variance.any())
        self._rotation = probe_rotation(math.radians(config.probe_angle_deg))
        # the consider term's estimator: the bound's with the viscosity factors held (class docstring),
        # from the commissioning baseline's prior where one primed the nuisances
        self.bound = bool(bound)
        """Whether :attr:`std` holds the bound (else only the consider term: :meth:`published_std`)."""
        self._held = [i for i, column in enumerate(c) if column not in (2, 3)]
        held_prior = prior.copy()
        baseline = config.offset_baseline
        if baseline is not None:
            held_prior[6:10] = baseline.offset_prior_std_m() * 1e6
            if baseline.unbalance_std is not None:
                held_prior[4:6] = baseline.unbalance_std
        held_columns = [c[i] for i in self._held]
        self._held_prior = np.diag(held_prior[held_columns] ** 2)
        self._held_walk = self._walk[np.ix_(self._held, self._held)]
        self._held_covariance = self._held_prior.copy()
        # S: its bias per unit considered error, at the start the baseline's (class docstring)
        self._initial_bias_gain = self._baseline_bias_gain(config, held_columns, q0)
        self._bias_gain = self._initial_bias_gain.copy()
        # the update under way: stage (-1: none), then its inputs (flowrates, factors, unbalance, speed,
        # viscosity) and the responses evaluated so far
        self._pending = np.full(1 + _INPUTS + POINTS * 12, np.nan)
        size = model.n_states + 3  # the continuous block of the stage under way: (2n + 3) square
        self._block = np.zeros((size, size))
        self.reset()

    def reset(self) -> None:
        """Back to the prior (the filter's reset or the settling start's restart)."""
        self.covariance = self._prior.copy()
        self._held_covariance = self._held_prior.copy()
        self._bias_gain[:] = self._initial_bias_gain
        self.std = self.std_m3_s()
        self._since = 0
        self._pending[:] = np.nan
        self._pending[0] = -1.0

    def _baseline_bias_gain(self, config, held_columns: list[int], flowrate_m3_s) -> np.ndarray:
        """(held, :data:`CONSIDERED`) the bias gain of the held estimator's prior: zero, but for the scale
        factors' columns after a commissioning baseline, whose offsets and unbalance absorbed the
        least-squares projection of the scale error of the baseline point's readings (class docstring)."""
        gain = np.zeros((len(held_columns), CONSIDERED))
        baseline = config.offset_baseline
        if baseline is None or not self._consider_variance[12:].any():
            return gain
        from oilwatch.models.system.trajectory_bound import (
            ORBIT_WEIGHTS,
            OperatingSegment,
            map_response,
            nuisance_columns,
        )

        q = flowrate_m3_s if baseline.flowrates_m3_s is None else baseline.flowrates_m3_s
        factors = (1.0, 1.0) if baseline.viscosity_factor is None else baseline.viscosity_factor
        unbalance = 1.0 if baseline.unbalance is None else complex(*baseline.unbalance)
        model = self._model
        segment = OperatingSegment(*model.operating_point, self._dt)
        response = map_response(model.maps, model.output_matrix, self._dt, q, segment, factors, unbalance)
        # the held nuisances (unbalance, offsets) are the parameter columns from 4 on
        nuisances = [i for i, column in enumerate(held_columns) if column >= 4]
        root = np.sqrt(ORBIT_WEIGHTS)[:, None]
        design = root * nuisance_columns(response, unbalance)[:, [held_columns[i] - 4 for i in nuisances]]
        gain[nuisances, 12:] = np.linalg.lstsq(design, root * scale_columns(response, self._rotation))[0]
        return gain

    def due(self) -> bool:
        """Count one step; True every ``update_s`` (then call :meth:`begin`)."""
        self._since += 1
        if self._since < self._every:
            return False
        self._since = 0
        return True

    def get_state(self) -> np.ndarray:
        """The bound's covariance, step counter, the update under way and the considered errors' bias gain,
        flattened (a copy, for the filter's state)."""
        head = np.r_[self.covariance.ravel(), float(self._since), self._pending]
        return np.r_[head, self._block.ravel(), self._held_covariance.ravel(), self._bias_gain.ravel()]

    def set_state(self, state) -> None:
        """Restore :meth:`get_state`."""
        values = np.asarray(state, dtype=float)
        size = self.covariance.size
        self.covariance = values[:size].reshape(self.covariance.shape).copy()
        self._since = int(values[size])
        pending = self._pending.size
        self._pending[:] = values[size + 1 : size + 1 + pending]
        block = size + 1 + pending
        held = block + self._block.size
        self._block.ravel()[:] = values[block:held]
        gain = held + self._held_covariance.size
        self._held_covariance = values[held:gain].reshape(self._held_covariance.shape).copy()
        self._bias_gain.ravel()[:] = values[gain:]
        self.std = self.std_m3_s()

    def published_std(self, filter_std_m3_s: np.ndarray) -> np.ndarray:
        """(2,) the std to publish beside the filter's own ``filter_std_m3_s`` [m^3/s]: the larger of the two
        with the bound; the filter's and the consider term in quadrature without it."""
        if self.bound:
            return np.maximum(filter_std_m3_s, self.std)
        return np.hypot(filter_std_m3_s, self.std)

    def std_m3_s(self) -> np.ndarray:
        """(2,) the bound on the flowrates' std now [m^3/s] (without :attr:`bound`: zero), with the considered
        errors' bias (the slow-roll fit's and the probes' scale factors: class docstring)."""
        variance = np.diag(self.covariance)[:2] if self.bound else np.zeros(2)
        if self._considered:
            gain = self._bias_gain[:2]
            variance = variance + np.einsum("ij,j,ij->i", gain, self._consider_variance, gain)
        return np.sqrt(variance)

    def begin(self, flowrate_m3_s, factors, unbalance) -> None:
        """Start an update at these estimates and the model's operating point now (:meth:`work` does it; the
        first update from the prior is done here, whole: class docstring)."""
        speed, viscosity = self._model.operating_point
        low, high = self._model.bearing_flowrate_bounds_m3_s.T
        # an estimate at its table's edge: the update's differences step either way, inside the table
        q = np.clip(flowrate_m3_s, low * (1.0 + _EDGE), high / (1.0 + _EDGE))
        self._pending[: 1 + _INPUTS] = np.r_[0.0, q, factors, unbalance, speed, viscosity]
        if np.array_equal(self.covariance, self._prior):
            while self._pending[0] >= 0.0:
                self.work()

    def work(self) -> None:
        """One stage of the update under way, if any: half of one exact-map response; the last stage adds
        the information of the last ``update_s`` at the estimates :meth:`begin` took (``std`` follows)."""
        pending = self._pending
        stage = int(pending[0])
        if stage < 0:
            return
        from oilwatch.models.system.trajectory_bound import (
            ORBIT_WEIGHTS,
            OperatingSegment,
            block_response,
            map_block,
            sensitivity_columns,
            sensitivity_points,
        )

        q, factors, unbalance = pending[1:3], pending[3:5], complex(*pending[5:7])
        segment = OperatingSegment(float(pending[7]), float(pending[8]), self._every * self._dt)
        responses = pending[1 + _INPUTS :].reshape(POINTS, 12)
        point, half = divmod(stage, 2)
        model = self._model
        if half == 0:
            flows, f = sensitivity_points(q, factors, unbalance)[point]
            self._block[:] = map_block(model.maps, flows, segment, f)
        else:
            responses[point] = block_response(
                model.maps, model.output_matrix, self._dt, self._block, segment, unbalance
            )
        pending[0] = stage + 1
        if stage + 1 < STAGES:
            return
        pending[0] = -1.0
        jacobian = sensitivity_columns(list(responses), unbalance)[:, self._columns]
        jacobian[:, :2] /= q  # per m^3/s
        information = self._every * (jacobian.T * ORBIT_WEIGHTS) @ jacobian / self._noise**2
        predicted = np.linalg.inv(self.covariance + self._walk)
        self.covariance = np.linalg.inv(predicted + information)
        if self._considered:
            held = jacobian[:, self._held]
            per_observation = self._every * (held.T * ORBIT_WEIGHTS) / self._noise**2
            held_predicted = np.linalg.inv(self._held_covariance + self._held_walk)
            self._held_covariance = np.linalg.inv(held_predicted + per_observation @ held)
            errors = np.hstack([np.eye(12), scale_columns(responses[0], self._rotation)])
            self._bias_gain = self._held_covariance @ (
                held_predicted @ self._bias_gain + per_observation @ errors
            )
        self.std = self.std_m3_s()


def scale_columns(response: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """(12, 4) the observation error per unit scale-factor error of each probe: probe i reads its displacement
    (the ``rotation``'s row i of the bearing's x, y) times ``1 + delta_i``, in the static position and the
    1x orbit's parts of ``response`` (12,), expressed back in the model's axes."""
    columns = np.zeros((12, 4))
    for rows in (slice(0, 4), slice(4, 8), slice(8, 12)):
        columns[rows] = rotation.T * (rotation @ response[rows])[None, :]
    return columns


CONSIDERED = 16
"""The considered errors of :class:`InformationFloor`: one per observation row (the slow-roll fit's), one
per probe's scale factor."""
_EDGE = 2e-3
"""How far inside the model's flowrate range an update is evaluated (twice the differences' relative step)."""
_INPUTS = 8
"""The inputs an update takes (:meth:`InformationFloor.begin`): two flowrates, two factors, the unbalance's
two parts, the speed and the oil viscosity."""
