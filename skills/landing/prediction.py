"""Prediction of the platform's position with a Kalman filter (Palafox et al. 2019, §3.3.2).

The platform's centroid, measured in the world frame (``P_world =
T_world_cam P_cam``; on the UAV, the navigation frame of its onboard
estimate), feeds a constant-velocity Kalman filter with state
``[x, y, v_x, v_y]`` (m, m/s, same frame). The paper's configuration: a
time step of 0.1 s, a path time of 0.1 s (so the path of predictions holds
the current position and the one 0.1 s ahead, and the controller takes the
latter), and diagonal covariances ``Q = 2·I₄`` and ``R = 2·I₂`` obtained
empirically.

:class:`PlatformPredictor` runs the filter at that step in simulated time:
a measurement is fused when at least one step has passed since the last
fused one (a 30 Hz camera is thus used every third frame), with the
transition over the time really elapsed and ``Q`` scaled by it, so the
estimate belongs to the measurement's time stamp. The prediction is the
estimate carried forward to the asking time plus the path time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from marsupial.geometry import Vector

_H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])  # observation model: position only


@dataclass(frozen=True)
class KalmanParams:
    """Kalman filter configuration, §3.3.2.

    Attributes:
        step_s: time step of the filter and of the predicted path (s).
        path_time_s: path time, how far ahead the position is predicted (s).
        process_noise: ``q`` in ``Q = q·I₄`` per step (m², (m/s)²).
        measurement_noise: ``r`` in ``R = r·I₂`` (m²).
    """

    step_s: float = 0.1  # time step, §3.3.2
    path_time_s: float = 0.1  # path time, §3.3.2
    process_noise: float = 2.0  # Q = 2·I4, §3.3.2
    measurement_noise: float = 2.0  # R = 2·I2, §3.3.2

    def __post_init__(self) -> None:
        if self.step_s <= 0.0 or self.path_time_s < 0.0:
            raise ValueError(f"step_s must be > 0 and path_time_s >= 0 (s), got {self.step_s}, {self.path_time_s}")
        if self.process_noise <= 0.0 or self.measurement_noise <= 0.0:
            raise ValueError(
                f"process_noise and measurement_noise must be > 0, got {self.process_noise}, {self.measurement_noise}"
            )


class ConstantVelocityKF:
    """Linear Kalman filter of a point moving at constant velocity in the plane.

    State ``x = [x, y, v_x, v_y]`` (m, m/s), covariance ``P`` (initially
    ``I₄``, velocity zero, as the authors' filter); measurements are
    positions ``[x, y]`` (m). ``Q`` is given per ``step_s`` and scaled by the
    elapsed time of each prediction.
    """

    def __init__(self, params: KalmanParams = KalmanParams()):
        self.params = params
        self.x = np.zeros(4)
        self.P = np.eye(4)
        self._R = params.measurement_noise * np.eye(2)

    def reset(self, position: Vector, velocity: Vector = (0.0, 0.0)) -> None:
        """Start at ``position`` (m) with ``velocity`` (m/s; zero by default) and ``P = I₄``."""
        self.x = np.array([position[0], position[1], velocity[0], velocity[1]], dtype=float)
        self.P = np.eye(4)

    def predict(self, dt: float) -> None:
        """Propagate the state ``dt`` seconds: ``x ← A x``, ``P ← A P Aᵀ + Q·dt/step``."""
        A = np.eye(4)
        A[0, 2] = A[1, 3] = dt
        self.x = A @ self.x
        self.P = A @ self.P @ A.T + (self.params.process_noise * dt / self.params.step_s) * np.eye(4)

    def update(self, position: np.ndarray) -> None:
        """Fuse a position measurement ``[x, y]`` (m)."""
        innovation = np.asarray(position, dtype=float)[:2] - _H @ self.x
        S = _H @ self.P @ _H.T + self._R
        gain = np.linalg.solve(S, _H @ self.P).T  # P Hᵀ S⁻¹ (S and P symmetric)
        self.x = self.x + gain @ innovation
        self.P = (np.eye(4) - gain @ _H) @ self.P

    @property
    def position(self) -> np.ndarray:
        """Estimated position ``[x, y]`` (m)."""
        return self.x[:2].copy()

    @property
    def velocity(self) -> np.ndarray:
        """Estimated velocity ``[v_x, v_y]`` (m/s)."""
        return self.x[2:].copy()


class PlatformPredictor:
    """Runs :class:`ConstantVelocityKF` at its step on time-stamped world-frame measurements.

    Call :meth:`observe` with every platform measurement; ask
    :meth:`predicted` for the target. Times are simulated seconds.
    """

    def __init__(self, params: KalmanParams = KalmanParams()):
        self.params = params
        self.filter = ConstantVelocityKF(params)
        self.stamp: float | None = None  # time of the last fused measurement (s)

    def reset(self) -> None:
        """Forget the platform (the next measurement starts the filter again)."""
        self.stamp = None

    def start(self, t: float, position_world: np.ndarray, velocity_world: np.ndarray) -> None:
        """Start the filter at ``t`` from a known platform state (world frame, m and m/s).

        E.g. at take-off from a moving platform: the UAV riding it knows the
        platform's velocity before its camera can see it.
        """
        self.filter.reset(position_world, velocity_world)
        self.stamp = t

    def shift_velocity(self, delta_world: np.ndarray) -> None:
        """Add ``delta_world`` (m/s, world frame) to the estimated velocity: the frame's own velocity changed.

        E.g. the UAV's navigation frame starts moving with the platform once
        its optical flow sees the platform (:mod:`.flowframe`); positions are
        kept. No effect before the first measurement.
        """
        if self.stamp is not None:
            self.filter.x[2:] += np.asarray(delta_world, dtype=float)[:2]

    def observe(self, t: float, position_world: np.ndarray) -> bool:
        """Offer the platform position measured at ``t`` (world frame, m); True if it was fused.

        The first measurement starts the filter; later ones are fused once at
        least ``step_s`` has passed since the last fused one (1 µs tolerance
        for camera periods that add up to the step).
        """
        if self.stamp is None:
            self.filter.reset(position_world)
            self.stamp = t
            return True
        dt = t - self.stamp
        if dt < self.params.step_s - 1e-6:
            return False
        self.filter.predict(dt)
        self.filter.update(position_world)
        self.stamp = t
        return True

    def predicted(self, t: float) -> np.ndarray | None:
        """Platform ``[x, y]`` (world, m) predicted for ``t + path_time_s``; ``None`` before any measurement."""
        if self.stamp is None:
            return None
        return self.filter.position + self.filter.velocity * (t - self.stamp + self.params.path_time_s)
