"""Oil-flow estimation: the augmented-state Extended Kalman Filter and the starvation alarm.

Usage::

    from oilwatch.estimator import EKFConfig, OilFlowEKF
    ekf = OilFlowEKF(model, EKFConfig.recommended(noise_std_m=1e-6))  # model: any AugmentedModel
    report = ekf.step(displacement_m)  # (x1, y1, x2, y2) [m] -> q estimates, stds, NIS, flags
"""

from .config import AlarmConfig, EKFConfig
from .ekf import EstimateTrace, OilFlowEKF, StepReport
from .model import AugmentedModel

__all__ = ["AlarmConfig", "AugmentedModel", "EKFConfig", "EstimateTrace", "OilFlowEKF", "StepReport"]
