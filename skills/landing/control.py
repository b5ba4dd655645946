"""Height-adaptive PI tracking of the platform, reactive or predictive (Palafox et al. 2019, §3.3).

The controller drives the horizontal distance between the UAV and the
platform's centroid to zero with a PI law per axis of the UAV's heading
frame (x forward, y left, yaw-only rotation), whose gains depend on the
height above the platform ``p_z`` (§3.3.1, eq. (4) without the derivative
action, which the authors found worse):

    u = K_p(p_z) e + K_i(p_z) ∫ e dt,    K(p_z) = Q · exp(-T · p_z).

The paper prints ``K_p = 0.7 e^(-0.002 p_z)``, ``K_i = 0.2 e^(-0.002 p_z)``
without the unit of ``p_z``. The gains are meant to rise towards the
platform ("a faster response the closer the UAV is", §3.3), and the authors'
public configuration lists ``K_p = 0.45``, ``K_i = 0.1`` "at 4 meters of
altitude" and ``0.7`` / ``0.2`` "at altitude 0". ``T = 0.002`` cannot give
that in either unit: per metre the gains barely change (0.694 / 0.198 at
4 m, Table 1), per millimetre they vanish (``e^(-8)``: 2·10⁻⁴ at 4 m). ``T``
is therefore fitted, per gain, to the two configured points with ``p_z`` in
metres:

    T_p = ln(0.7 / 0.45) / 4 m = 0.1105 m⁻¹,    T_i = ln(0.2 / 0.1) / 4 m = 0.1733 m⁻¹.

One ``T`` for both, 0.1105 m⁻¹, would give ``K_i(4 m) = 0.129`` instead of
0.1; the authors' node has a separate coefficient per gain. The printed
law read in metres, i.e. the nearly constant gains of Table 1, is
``PIGains(T_p=0.002, T_i=0.002)``: with ``K_i(4 m)`` = 0.198 instead of 0.1
it halves the lag on a circular track (see :class:`PlatformTracker`).

The landing skills default to that printed law (schedule ``table1`` of
:data:`~.tracking.GAIN_SCHEDULES`): with ``p_z`` in metres it reproduces
the paper's Table 1 (0.694 / 0.697 and 0.198 / 0.199), which the fitted
``T`` does not, and the 0.45 / 0.1 values are the manual trackbar defaults
of the authors' node, not a schedule it used. ``PIGains()`` (schedule
``manual_fit``) stays selectable.

:class:`PlatformTracker` feeds the PI either the last measured platform
position (``"reactive"``, §3.3.1) or the position predicted by the Kalman
filter one path time ahead (``"predictive"``, §3.3.2); both take the
platform in the world frame and return the velocity command in the heading
frame. Positions m, velocities m/s, angles rad, times simulated s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marsupial.api.errors import UnknownNameError

from .prediction import KalmanParams, PlatformPredictor

MODES = ("reactive", "predictive")
#: default horizontal speed limit (m/s): the AR.Drone 2 model's; the skills pass their UAV's ``limits.max_speed_xy``
MAX_SPEED_XY = 3.0
#: the Kalman filter configuration a controller uses unless given one (§3.3.2)
DEFAULT_KALMAN = KalmanParams()


@dataclass(frozen=True)
class PIGains:
    """Height-adaptive PI gains ``K(p_z) = Q·exp(-T·p_z)`` (§3.3.1), ``p_z`` in m (``T``: module docstring).

    Attributes:
        Q_p: proportional gain at the platform (1/s).
        Q_i: integral gain at the platform (1/s²).
        T_p: decay of the proportional gain with height (1/m).
        T_i: decay of the integral gain with height (1/m).
    """

    Q_p: float = 0.7  # Q_p, §3.3.1
    Q_i: float = 0.2  # Q_i, §3.3.1
    T_p: float = math.log(0.7 / 0.45) / 4.0  # fitted: K_p(4 m) = 0.45
    T_i: float = math.log(0.2 / 0.1) / 4.0  # fitted: K_i(4 m) = 0.1

    def __post_init__(self) -> None:
        if self.Q_p <= 0.0 or self.Q_i < 0.0:
            raise ValueError(f"Q_p must be > 0 and Q_i >= 0, got {self.Q_p}, {self.Q_i}")

    def at(self, height: float) -> tuple[float, float]:
        """``(K_p, K_i)`` at ``height`` (m above the platform; negative heights count as 0)."""
        p_z = max(0.0, float(height))
        return self.Q_p * math.exp(-self.T_p * p_z), self.Q_i * math.exp(-self.T_i * p_z)


class HeightAdaptivePI:
    """Two-axis PI with height-adaptive gains, speed limit and anti-windup.

    ``step(error, height, dt)`` integrates ``error·dt`` and returns
    ``K_p e + K_i ∫e`` (m/s), as the authors' node does, plus an optional
    feed-forward velocity, with two guards the paper leaves out: the
    command's norm is clipped to ``max_speed`` (the vehicle's SDK limit), and
    the integral is frozen while the command is clipped and bounded so that
    ``K_i |∫e|`` alone never exceeds ``max_speed``. With ``integral_band``
    (m; not in the paper) the error is integrated only while its norm is
    within the band (conditional integration): when a feed-forward supplies
    the platform's velocity, the integral only has to trim a small bias, and
    integrating a large transient error would wind it up into an overshoot.
    """

    def __init__(
        self,
        gains: PIGains = PIGains(),
        max_speed: float = MAX_SPEED_XY,
        integral_band: float | None = None,
    ):
        if max_speed <= 0.0:
            raise ValueError(f"max_speed must be > 0 m/s, got {max_speed}")
        if integral_band is not None and integral_band <= 0.0:
            raise ValueError(f"integral_band must be > 0 m or None, got {integral_band}")
        self.gains = gains
        self.max_speed = max_speed
        self.integral_band = integral_band
        self.integral = np.zeros(2)  # ∫e dt (m·s)

    def reset(self) -> None:
        """Clear the integral (the authors reset it on take-off, landing and re-localisation)."""
        self.integral = np.zeros(2)

    def step(self, error: np.ndarray, height: float, dt: float, feedforward: np.ndarray | None = None) -> np.ndarray:
        """Velocity command (m/s) for the horizontal ``error`` (m) at ``height`` (m) after ``dt`` (s).

        ``feedforward`` (m/s, same frame as ``error``) is added to the PI output before the speed limit.
        """
        error = np.asarray(error, dtype=float)[:2]
        base = np.zeros(2) if feedforward is None else np.asarray(feedforward, dtype=float)[:2]
        kp, ki = self.gains.at(height)
        integrate = self.integral_band is None or float(np.hypot(*error)) <= self.integral_band
        integral = self.integral + error * max(dt, 0.0) if integrate else self.integral.copy()
        if ki > 0.0:
            norm = float(np.hypot(*integral))
            bound = self.max_speed / ki
            if norm > bound:
                integral *= bound / norm
        command = base + kp * error + ki * integral
        speed = float(np.hypot(*command))
        if speed > self.max_speed:
            command = base + kp * error + ki * self.integral  # anti-windup: keep the previous integral
            speed = float(np.hypot(*command))
            if speed > self.max_speed:
                command *= self.max_speed / speed
        else:
            self.integral = integral
        return command


class PlatformTracker:
    """Height-adaptive PI on the measured (``"reactive"``) or predicted (``"predictive"``) platform position.

    Call :meth:`observe` with every platform measurement (in the UAV's
    navigation frame, e.g. ``Detection.position_in(R_nav_camera, p_nav_camera)``
    with the camera pose from the UAV's estimate at the frame's stamp) and
    :meth:`command` at the control rate. The reactive target is the last
    measurement; the predictive one the Kalman prediction one path time
    ahead (§3.3.2). The error is the target minus the UAV position, turned
    into the heading frame; for the reactive mode this is the measured
    offset ``P_body`` of §3.3.1 levelled by the vehicle's attitude.

    ``velocity_feedforward`` (predictive mode only; not in the paper) adds
    the filter's platform velocity to the PI output. The PI alone follows a
    constant-velocity platform with no steady error (its integral supplies
    the speed), but on a circle it trails by the centripetal acceleration
    over ``K_i``: ``v·ω / K_i`` = 0.25 m at v = 0.5 m/s, ω = 0.05 rad/s and
    ``K_i(4 m)`` = 0.1. The feed-forward removes most of that lag; use it
    with ``path_time_s = 0``, since a path time then only adds a lead of
    ``v · path_time``. ``integral_band`` is the PI's conditional integration
    (:class:`HeightAdaptivePI`), meant for the feed-forward.
    """

    def __init__(
        self,
        mode: str = "reactive",
        gains: PIGains = PIGains(),
        kalman: KalmanParams = DEFAULT_KALMAN,
        max_speed: float = MAX_SPEED_XY,
        velocity_feedforward: bool = False,
        integral_band: float | None = None,
    ):
        if mode not in MODES:
            raise UnknownNameError("tracking mode", mode, MODES)
        if velocity_feedforward and mode != "predictive":
            raise ValueError("velocity_feedforward needs the Kalman filter's velocity: use mode='predictive'")
        self.mode = mode
        self.velocity_feedforward = velocity_feedforward
        self.pi = HeightAdaptivePI(gains, max_speed, integral_band)
        self.predictor = PlatformPredictor(kalman)
        self._measured: np.ndarray | None = None
        self._last_command_t: float | None = None

    def reset(self) -> None:
        """Forget the platform and clear the PI (take-off, re-localisation)."""
        self.pi.reset()
        self.predictor.reset()
        self._measured = None
        self._last_command_t = None

    def observe(self, t: float, position_world: np.ndarray) -> None:
        """A platform measurement taken at ``t`` (world frame, m; x and y are used)."""
        self._measured = np.asarray(position_world, dtype=float)[:2].copy()
        if self.mode == "predictive":
            self.predictor.observe(t, self._measured)

    def target(self, t: float) -> np.ndarray | None:
        """World ``[x, y]`` (m) the UAV is driven to at ``t``; ``None`` before any measurement."""
        if self.mode == "predictive":
            return self.predictor.predicted(t)
        return None if self._measured is None else self._measured.copy()

    def command(self, t: float, p_uav_world: np.ndarray, yaw: float, height: float) -> np.ndarray:
        """Velocity command ``[v_x, v_y]`` (m/s, heading frame) at ``t`` for the UAV at ``p_uav_world``.

        ``yaw`` is the UAV heading (rad), ``height`` its height above the
        platform (m) for the gains. Zero until the platform has been measured.
        """
        target = self.target(t)
        dt = 0.0 if self._last_command_t is None else t - self._last_command_t
        self._last_command_t = t
        if target is None:
            return np.zeros(2)
        c, s = math.cos(yaw), math.sin(yaw)
        R_heading_world = np.array([[c, s], [-s, c]])
        error = R_heading_world @ (target - np.asarray(p_uav_world, dtype=float)[:2])
        feedforward = R_heading_world @ self.predictor.filter.velocity if self.velocity_feedforward else None
        return self.pi.step(error, height, dt, feedforward)
