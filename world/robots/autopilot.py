"""The quadrotors' onboard autopilot: velocity commands over a position hold on the *estimate*.

The vendors' SDKs (Parrot, Ryze) take velocity commands and hold position
on the drone's own estimate; so does :class:`Autopilot`. It reads the
navigation state of the onboard :class:`~marsupial.world.estimation.flight.FlightEstimator`
(position, velocity, heading, attitude) for everything above the attitude
loop, so when the estimate drifts the vehicle drifts with it in truth.
The attitude loop itself and the airframe drag stay physical (the inner
loop is fast and runs on the gyro; drag acts on the true air velocity).

1. Command: ``command(vx, vy, vz, yaw_rate, frame)``; ``"body"`` is the
   heading frame (yaw-only rotation at the *estimated* heading, re-evaluated
   every update), ``"world"`` the estimator's navigation frame (``odom``).
   Commands are clipped to :class:`FlightLimits`.
2. Reference model: the reference acceleration follows a target with the
   attitude lag ``tau = 2 / attitude_omega``; the target brings the predicted
   reference velocity ``v_ref + a_ref tau`` onto the command, clipped to
   ``accel_ref`` (and to what the tilt limit leaves after drag). The velocity
   reference reaches the command critically damped and is integrated into a
   reference position (the carrot); the heading reference integrates the yaw
   rate. With a zero command the carrot stops and the vehicle holds it.
   When the estimator shifts its navigation frame under the vehicle (the
   corrections of external vision fixes, ``nav.shift``), the carrot and the
   heading reference move by as much: a correction of the estimate is not
   a command to move (PX4 shifts its set-points by the estimator's resets).
3. Position controller: PD on carrot minus *estimated* position / velocity
   + small integral + acceleration and drag feed-forward gives a desired
   acceleration in the navigation frame, whose direction sets the desired
   body z axis (tilt ≤ ``max_tilt``) and whose projection on the body z axis
   sets the thrust. The desired axis is mapped into the world through the
   estimate's attitude (``R_world_body R_nav_body^T``): the attitude loop
   drives the *estimated* attitude to the desired one, so roll, pitch and
   heading errors of the estimate tilt the true vehicle.
4. Attitude controller: a critically damped loop of natural frequency
   ``attitude_omega`` on the tilt error (body z × desired z) and the heading
   error, torques scaled by the base inertia, applied in the world frame.
5. Air drag ``-m (c1 v_air + c2 |v_air| v_air)`` on the true air-relative
   velocity ``v_air = v - wind``.

Frames: world z-up; base x forward, y left, z up; m, m/s, rad.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from marsupial.api.model import FlightLimits

from ..world import GRAVITY

FRAMES = ("body", "world")
VERTICAL_REFERENCE_TAU = 0.1  # s, smoothing of the vertical velocity reference


@dataclass(frozen=True)
class AutopilotGains:
    """Gains of the onboard position hold (per unit mass) and attitude loop.

    The position loop is ``a = a_ref + kp e + kd ė + ki ∫e`` per axis
    (1/s², 1/s, 1/s³); ``leash`` bounds how far the carrot may lead the
    estimated position (m) and the heading reference the estimated heading
    (rad); the integral term is clipped to ``max_integral_accel`` (m/s²).
    """

    kp_xy: float = 6.0
    kd_xy: float = 4.5
    ki_xy: float = 2.0
    kp_z: float = 8.0
    kd_z: float = 5.0
    ki_z: float = 3.0
    leash: float = 0.5
    max_integral_accel: float = 3.0
    attitude_omega: float = 15.0  # rad/s
    attitude_zeta: float = 1.0


@dataclass(frozen=True)
class Drag:
    """Airframe drag per unit mass: ``a_drag = -(linear v_air + quadratic |v_air| v_air)`` (1/s, 1/m)."""

    linear: float
    quadratic: float


class NavState(Protocol):
    """What the autopilot reads of the onboard estimate (plain floats, navigation frame)."""

    p: list[float]
    v: list[float]
    yaw: float
    R: tuple[float, ...]  # row-major R_nav_body
    resets: int
    shift: list[float]  # cumulated frame corrections [x, y, z (m), yaw (rad)]


class Autopilot:
    """Position hold and attitude loop of one quadrotor (see the module docstring).

    Args:
        limits, gains, drag: the kind's figures.
        mass: take-off mass (kg); inertia: base principal inertia ``(ixx, iyy, izz)`` (kg m²).
    """

    def __init__(self, limits: FlightLimits, gains: AutopilotGains, drag: Drag, mass: float, inertia: Sequence[float]):
        self.limits = limits
        g, lim = gains, limits
        self._ctl = (  # constants of the update, unpacked in one go
            g.kp_xy, g.kd_xy, g.ki_xy, g.kp_z, g.kd_z, g.ki_z, g.leash, g.max_integral_accel,
            g.attitude_omega**2, 2.0 * g.attitude_zeta * g.attitude_omega, lim.accel_ref, lim.accel_ref_z,
            math.tan(lim.max_tilt), lim.thrust_to_weight * mass * GRAVITY, drag.linear, drag.quadratic,
            # tau: lag of the critically damped attitude loop
            mass, 2.0 / g.attitude_omega, VERTICAL_REFERENCE_TAU,
            *inertia,
        )
        self.cmd = (0.0, 0.0, 0.0, 0.0)
        self.cmd_frame = "body"
        self._resets_seen = -1
        self.p_ref = [0.0, 0.0, 0.0]
        self.yaw_ref = 0.0
        self._shift_seen = [0.0, 0.0, 0.0, 0.0]

    # ------------------------------------------------------------ commands
    def command(self, vx: float, vy: float, vz: float, yaw_rate: float = 0.0, frame: str = "body") -> None:
        """Track ``(vx, vy, vz)`` m/s and ``yaw_rate`` rad/s in ``frame`` until the next command.

        The command is clipped to the limits.
        """
        if frame not in FRAMES:
            raise ValueError(f"frame must be one of {FRAMES}, got '{frame}'")
        values = [float(v) for v in (vx, vy, vz, yaw_rate)]
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"velocity command must be finite, got {values}")
        vx, vy, vz, yaw_rate = values
        lim = self.limits
        speed = math.hypot(vx, vy)
        if speed > lim.max_speed_xy:
            vx, vy = vx * lim.max_speed_xy / speed, vy * lim.max_speed_xy / speed
        vz = max(-lim.max_speed_z, min(lim.max_speed_z, vz))
        yaw_rate = max(-lim.max_yaw_rate, min(lim.max_yaw_rate, yaw_rate))
        self.cmd = (vx, vy, vz, yaw_rate)
        self.cmd_frame = frame

    def hover(self) -> None:
        """Zero command: the reference stops and the vehicle holds where it stops."""
        self.cmd = (0.0, 0.0, 0.0, 0.0)

    def reset(self, nav: NavState) -> None:
        """Hold the estimated pose: carrot at the estimate, zero velocity reference, integrators cleared."""
        self.p_ref = list(nav.p)
        self.v_ref = [0.0, 0.0, 0.0]
        self.a_ref = [0.0, 0.0, 0.0]
        self.yaw_ref = nav.yaw
        self.integral = [0.0, 0.0, 0.0]
        self._resets_seen = nav.resets
        self._shift_seen = list(nav.shift)

    # ------------------------------------------------------------ update
    def update(
        self,
        nav: NavState,
        q: Sequence[float],
        v: Sequence[float],
        w_world: Sequence[float],
        wind: Sequence[float],
        dt: float,
    ) -> tuple[tuple[float, float, float], tuple[float, float, float], float, float]:
        """One update over ``dt`` s from the estimate ``nav`` and the true state.

        The true state: attitude ``q``, velocity ``v``, angular velocity ``w_world`` (rad/s, world frame).

        Returns ``(force_body (N, rotor thrust + drag, at the centre of mass),
        torque_world (N m), thrust (N), drag power (W, ≤ 0))``.
        """
        if nav.resets != self._resets_seen:  # the estimate restarted (hand-over): hold the new estimate
            self.reset(nav)
        shift, seen = nav.shift, self._shift_seen
        if shift != seen:  # the navigation frame moved under the vehicle: so do the references
            pr = self.p_ref
            pr[0] += shift[0] - seen[0]
            pr[1] += shift[1] - seen[1]
            pr[2] += shift[2] - seen[2]
            self.yaw_ref += shift[3] - seen[3]
            seen[:] = shift
        (kp_xy, kd_xy, ki_xy, kp_z, kd_z, ki_z, leash, imax, kp_att, kd_att, acc_ref, acc_ref_z,
         tan_tilt, max_thrust, c1, c2, m, tau, tau_z, ixx, iyy, izz) = self._ctl
        x, y, z, w = q
        # true rotation R_world_body (the attitude loop is physical)
        r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
        r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        p_est, v_est, yaw = nav.p, nav.v, nav.yaw

        # --- reference model (navigation frame)
        cvx, cvy, cvz, cyaw = self.cmd
        if self.cmd_frame == "body":
            c, s = math.cos(yaw), math.sin(yaw)
            cvx, cvy = c * cvx - s * cvy, s * cvx + c * cvy
        vr, pr, ar = self.v_ref, self.p_ref, self.a_ref
        vr_norm = math.sqrt(vr[0] * vr[0] + vr[1] * vr[1] + vr[2] * vr[2])
        kff = c1 + c2 * vr_norm  # drag feed-forward per unit velocity (1/s)
        # the reference never asks for more than the tilt limit leaves after drag
        acc_max = min(acc_ref, max(0.3, 0.9 * GRAVITY * tan_tilt - kff * math.hypot(vr[0], vr[1])))
        tx, ty = (cvx - vr[0] - ar[0] * tau) / tau, (cvy - vr[1] - ar[1] * tau) / tau
        t_norm = math.hypot(tx, ty)
        if t_norm > acc_max:
            tx, ty = tx * acc_max / t_norm, ty * acc_max / t_norm
        tz = max(-acc_ref_z, min(acc_ref_z, (cvz - vr[2] - ar[2] * tau_z) / tau_z))
        ar[0] += (tx - ar[0]) * dt / tau
        ar[1] += (ty - ar[1]) * dt / tau
        ar[2] += (tz - ar[2]) * dt / tau_z
        vr[0] += ar[0] * dt
        vr[1] += ar[1] * dt
        vr[2] += ar[2] * dt
        pr[0] += vr[0] * dt
        pr[1] += vr[1] * dt
        pr[2] += vr[2] * dt
        # leash: the carrot never leads the estimate by more than `leash`
        ex, ey, ez = pr[0] - p_est[0], pr[1] - p_est[1], pr[2] - p_est[2]
        e_norm = math.sqrt(ex * ex + ey * ey + ez * ez)
        if e_norm > leash:
            k = leash / e_norm
            ex, ey, ez = ex * k, ey * k, ez * k
            pr[0], pr[1], pr[2] = p_est[0] + ex, p_est[1] + ey, p_est[2] + ez
        self.yaw_ref += cyaw * dt
        yaw_err = (self.yaw_ref - yaw + math.pi) % (2 * math.pi) - math.pi
        if abs(yaw_err) > leash:
            yaw_err = math.copysign(leash, yaw_err)
            self.yaw_ref = yaw + yaw_err

        # --- air drag on the true air-relative velocity
        vax, vay, vaz = v[0] - wind[0], v[1] - wind[1], v[2] - wind[2]
        kdrag = m * (c1 + c2 * math.sqrt(vax * vax + vay * vay + vaz * vaz))
        fdx, fdy, fdz = -kdrag * vax, -kdrag * vay, -kdrag * vaz

        # --- position hold on the estimate: feed-forward (horizontal: the target, the attitude loop
        # adds the lag; vertical: the reference) + drag feed-forward + PD + integral
        integ = self.integral
        ax = tx + kff * vr[0] + kp_xy * ex + kd_xy * (vr[0] - v_est[0]) + max(-imax, min(imax, ki_xy * integ[0]))
        ay = ty + kff * vr[1] + kp_xy * ey + kd_xy * (vr[1] - v_est[1]) + max(-imax, min(imax, ki_xy * integ[1]))
        az = ar[2] + kff * vr[2] + kp_z * ez + kd_z * (vr[2] - v_est[2]) + max(-imax, min(imax, ki_z * integ[2]))
        Az = GRAVITY + max(-0.8 * GRAVITY, min(max_thrust / m - GRAVITY, az))
        a_xy, a_xy_max = math.hypot(ax, ay), Az * tan_tilt
        if a_xy > a_xy_max:  # tilt limit; no integration while saturated (anti-windup)
            ax, ay = ax * a_xy_max / a_xy, ay * a_xy_max / a_xy
        else:
            integ[0] += ex * dt
            integ[1] += ey * dt
        integ[2] += ez * dt

        # --- desired acceleration into the world through the estimate's attitude: a_w = R_wb R_nb^T a_nav
        n00, n01, n02, n10, n11, n12, n20, n21, n22 = nav.R
        bx = n00 * ax + n10 * ay + n20 * Az
        by = n01 * ax + n11 * ay + n21 * Az
        bz = n02 * ax + n12 * ay + n22 * Az
        ax, ay, Az = r00 * bx + r01 * by + r02 * bz, r10 * bx + r11 * by + r12 * bz, r20 * bx + r21 * by + r22 * bz

        # --- thrust along the present body z; attitude error: tilt (z_body x z_desired) and heading
        thrust = max(0.0, min(max_thrust, m * (ax * r02 + ay * r12 + Az * r22)))
        inv = 1.0 / math.sqrt(ax * ax + ay * ay + Az * Az)
        zdx, zdy, zdz = ax * inv, ay * inv, Az * inv
        ewx, ewy, ewz = r12 * zdz - r22 * zdy, r22 * zdx - r02 * zdz, r02 * zdy - r12 * zdx
        ebx = r00 * ewx + r10 * ewy + r20 * ewz
        eby = r01 * ewx + r11 * ewy + r21 * ewz
        wx, wy, wz = w_world
        wbx = r00 * wx + r10 * wy + r20 * wz
        wby = r01 * wx + r11 * wy + r21 * wz
        wbz = r02 * wx + r12 * wy + r22 * wz
        tbx = ixx * (kp_att * ebx - kd_att * wbx)
        tby = iyy * (kp_att * eby - kd_att * wby)
        tbz = izz * (kp_att * yaw_err + kd_att * (cyaw - wbz))
        torque = (
            r00 * tbx + r01 * tby + r02 * tbz,
            r10 * tbx + r11 * tby + r12 * tbz,
            r20 * tbx + r21 * tby + r22 * tbz,
        )
        # rotor thrust along body z plus drag, in the body frame
        force_body = (
            r00 * fdx + r10 * fdy + r20 * fdz,
            r01 * fdx + r11 * fdy + r21 * fdz,
            thrust + r02 * fdx + r12 * fdy + r22 * fdz,
        )
        return force_body, torque, thrust, fdx * vax + fdy * vay + fdz * vaz
