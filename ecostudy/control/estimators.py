"""The mass estimators a closed-loop study can choose (``estimator:`` of a controller), registered
by name: ``mass`` (``true`` in a study file): Yazhemsky 2017's scalar Kalman filter of the mass
(§10.3, eqs. 10.5-10.8); ``state``: the extended Kalman filter of position, speed, mass and the
acceleration disturbance (``control.ekf``). Each builder takes the loop's ``core.plant.Noise``.
"""
from ecostudy.control.ekf import StateEstimator
from ecostudy.control.estimator import MassEstimator
from ecostudy.core.registry import Registry

ESTIMATORS: Registry = Registry("estimator")
ESTIMATORS.register("mass", lambda noise: MassEstimator(),
                    doc="Scalar Kalman filter of the mass (Yazhemsky 2017 eqs. 10.5-10.8).")
ESTIMATORS.register("state", StateEstimator.for_noise,
                    doc="EKF of position, speed, mass and the acceleration disturbance.")


def make_estimator(choice, noise):
    """The estimator of a study's ``estimator`` option (False/None: none; True: ``mass``)."""
    if choice is None or choice is False:
        return None
    return ESTIMATORS.get("mass" if choice is True else choice)(noise)
