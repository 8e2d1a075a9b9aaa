"""The model side of :class:`oilwatch.estimator.ekf.OilFlowEKF`'s prediction: the transition with the nuisance
columns.

The filter's model either transitions the dynamic states alone (``transition``), or also returns the
Jacobian columns of the unbalance (``transition_with_unbalance``) or of the viscosity factors and the
unbalance (``transition_full``); :meth:`ModelPrediction._predict_with_model` calls the one the filter's
nuisance states need and puts those columns in place. The measured operating point (speed, oil
temperature, keyphasor angle) goes to a model that follows it before the prediction to the sample
(:meth:`ModelPrediction._set_operating_point`); a model at one speed accepts only that speed.
"""

from __future__ import annotations

import math

import numpy as np

from oilwatch.models.validation import InputError

from .step_kernel import REPORT_FILTER_FLOWRATE

MIN_VISCOSITY_FACTOR = 0.2
"""The model never sees a viscosity factor below this (a random walk kept physical)."""


class ModelPrediction:
    """The model half of :class:`oilwatch.estimator.ekf.OilFlowEKF`'s step (which sets up the attributes used
    here)."""

    def _predict_with_model(
        self, model_step: int, state: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The model's transition from the current estimate (or from ``state`` at the current flowrates and
        nuisances) to the next sample: ``(s_next, df/ds, df/dq)``, with the nuisance columns of the Jacobian
        (viscosity factors, unbalance) put into place."""
        n = self._n
        s = self._x[:n] if state is None else state
        flowrate = self._report[REPORT_FILTER_FLOWRATE : REPORT_FILTER_FLOWRATE + 2]
        trailing = self._trailing_jacobian
        if self._n_viscosity:
            factors = np.maximum(self._x[self._viscosity], MIN_VISCOSITY_FACTOR)
            unbalance = self._x[self._unbalance] if self._n_unbalance else None
            next_state, state_jac, flow_jac, viscosity_jac, unbalance_jac = self.model.transition_full(
                s, flowrate, model_step, factors, unbalance
            )
            trailing[:, :2] = viscosity_jac
            if self._n_unbalance:
                trailing[:, 2:] = unbalance_jac
            return next_state, state_jac, flow_jac
        if self._n_unbalance:
            next_state, state_jac, flow_jac, unbalance_jac = self.model.transition_with_unbalance(
                s, flowrate, model_step, self._x[self._unbalance]
            )
            trailing[:, :] = unbalance_jac
            return next_state, state_jac, flow_jac
        return self.model.transition(s, flowrate, model_step)

    def _set_operating_point(
        self, speed_hz: float | None, oil_temperature_c: float | None, rotor_angle_rad: float | None
    ) -> None:
        """Hand the measured operating point to the model (InputError for one it cannot follow)."""
        model = self.model
        if self._follows:
            speed, temperature = self._operating
            speed = speed if speed_hz is None else speed_hz
            temperature = temperature if oil_temperature_c is None else oil_temperature_c
            model.set_operating_point(speed, temperature, rotor_angle_rad)
            self._operating = (speed, temperature)
            return
        own = getattr(model, "speed_hz", None)
        if speed_hz is not None and own is not None and not math.isclose(speed_hz, own, rel_tol=1e-9):
            raise InputError(
                f"speed_hz = {speed_hz:g} Hz: this estimator's model holds one speed ({own:g} Hz); build "
                "it on the operating-point model to follow speed and oil temperature"
            )
        if rotor_angle_rad is not None:
            raise InputError("rotor_angle_rad needs a model that follows the operating point")
