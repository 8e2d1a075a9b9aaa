"""Oil-flow estimation: the augmented-state Extended Kalman Filter and the starvation alarm.

Usage::

    from oilwatch.estimator import EKFConfig, OilFlowEKF
    ekf = OilFlowEKF(model, EKFConfig.recommended(noise_std_m=1e-6))  # model: any AugmentedModel
    report = ekf.step(displacement_m)  # (x1, y1, x2, y2) [m] -> q estimates, stds, NIS, flags
"""

from .alarm_config import AlarmConfig
from .ekf import OilFlowEKF
from .ekf_config import EKFConfig
from .model import AugmentedModel
from .reports import EstimateTrace, StepReport

__all__ = ["AlarmConfig", "AugmentedModel", "EKFConfig", "EstimateTrace", "OilFlowEKF", "StepReport"]
