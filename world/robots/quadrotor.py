"""Quadrotors flown like their vendors' SDKs: velocity commands over an onboard position hold.

One :class:`Quadrotor` class serves every kind; a :class:`QuadrotorSpec`
holds what differs (URDF, limits, drag, battery, power model, sensors):

- ``bebop2``  Parrot Bebop 2, 0.50 kg (Narváez 2020, §V-B): front camera,
  AprilTag bundle (link ``tag_bundle``) and docking adapter (link ``part_b``).
- ``ardrone2`` Parrot AR.Drone 2.0, indoor hull, 0.42 kg (Palafox 2019):
  QVGA vertical camera (link ``camera_bottom``) and sonar.
- ``tello``   Ryze Tello micro-scout, 0.08 kg (Arora et al.): front camera.

Flight model (pybullet forces, every physics step, plain ``math``):

1. Command: ``command_velocity(vx, vy, vz, yaw_rate, frame)``; ``"body"``
   is the heading frame (yaw-only rotation, re-evaluated every step as the
   vehicle turns), ``"world"`` the world frame. Commands are clipped to the
   kind's :class:`FlightLimits` (Bebop 2: 4 m/s lateral, 1 m/s vertical, §V-B).
2. Reference model: the reference acceleration follows a target with the
   attitude lag ``tau = 2 / attitude_omega``; the target brings the predicted
   reference velocity ``v_ref + a_ref tau`` onto the command, clipped to
   ``accel_ref`` (and to what the tilt limit leaves after drag). The velocity
   reference thus reaches the command critically damped, without overshoot,
   and is integrated into a reference position (the carrot); the heading
   reference integrates the yaw rate. With a zero command the carrot stops
   and the vehicle holds it (position hold).
3. Position controller: PD on carrot position/velocity + small integral +
   acceleration and drag feed-forward gives a desired acceleration, whose
   direction sets the desired body z axis (tilt ≤ ``max_tilt``) and whose
   projection on the present body z axis sets the thrust.
4. Attitude controller: a critically damped loop of natural frequency
   ``attitude_omega`` on the tilt error (body z × desired z) and the heading
   error (≈ 0.14 s to 63 % of a tilt step at 15 rad/s); torques scaled by the
   base inertia and applied in the world frame. The body really tilts and lags.
5. Air drag ``-m (c1 v_air + c2 |v_air| v_air)`` on the air-relative velocity
   ``v_air = v - world.wind.velocity(t, p)``, so wind pushes the vehicle and
   the integral action of the position hold leans into it.
6. Power: :class:`~marsupial.world.energy.RotorPowerModel` from the thrust,
   climb speed and drag power, drawn from the :class:`~marsupial.world.energy.Battery`
   every step. Motors off: no thrust, no power. An empty battery stops the motors.

Docking: a docking device rigidly attaches the vehicle, then calls
:meth:`Quadrotor.on_docked` (motors off, charging if on a charger); while
docked the vehicle applies no force unless its motors are started (armed):
then the rotors spin up and their thrust rises to the vehicle's weight in
``ROTOR_SPIN_UP_S`` (the dock carries the rest, the battery pays for it and
does not charge), so a deploying carrier can release it once the thrust
holds. :meth:`Quadrotor.on_released` hands the vehicle back: if the motors
were switched on meanwhile it hovers where it was released, otherwise it falls.

Frames: world z-up; base frame x forward, y left, z up; positions m,
velocities m/s, angles rad.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from ..energy import Battery, BatteryGauge, BatterySpec, RotorPowerModel, hover_endurance_s
from ..errors import UnknownNameError
from ..sensors.barometer import Barometer
from ..sensors.base import SensorConfig
from ..sensors.camera import OPTICAL_DOWN, OPTICAL_FORWARD, Camera, Intrinsics
from ..sensors.imu import Imu
from ..sensors.sonar import Sonar
from ..world import GRAVITY
from ..onboard import QuadrotorOnboard, simulates_hardware
from .base import Robot, pose_from_list, rotation_matrix

if TYPE_CHECKING:
    from ..world import World

FRAMES = ("body", "world")
ROTOR_SPIN_UP_S = 0.5  # s for the rotors of a vehicle armed on a dock to reach hover thrust (chosen)
VERTICAL_REFERENCE_TAU = 0.1  # s, smoothing of the vertical velocity reference


@dataclass(frozen=True)
class FlightLimits:
    """What the autopilot allows (vendor SDK settings).

    Attributes:
        max_speed_xy: horizontal speed limit (m/s).
        max_speed_z: vertical speed limit (m/s).
        max_yaw_rate: yaw rate limit (rad/s).
        max_tilt: roll/pitch limit (rad).
        accel_ref: horizontal acceleration of the velocity reference (m/s²).
        accel_ref_z: vertical acceleration of the velocity reference (m/s²).
        thrust_to_weight: maximum thrust over weight.
    """

    max_speed_xy: float
    max_speed_z: float
    max_yaw_rate: float
    max_tilt: float
    accel_ref: float
    accel_ref_z: float = 2.0
    thrust_to_weight: float = 2.0


@dataclass(frozen=True)
class AutopilotGains:
    """Gains of the onboard position hold (per unit mass) and attitude loop.

    The position loop is ``a = a_ref + kp e + kd ė + ki ∫e`` per axis
    (1/s², 1/s, 1/s³); ``leash`` bounds how far the carrot may lead the
    vehicle (m) and the heading reference its heading (rad); the integral
    term is clipped to ``max_integral_accel`` (m/s²).
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


@dataclass(frozen=True)
class SonarMount:
    """Downward range finder: cone half-angle (rad), range interval (m), origin in the base frame (m)."""

    half_angle: float
    max_range: float
    min_range: float
    offset: tuple[float, float, float]


@dataclass(frozen=True)
class CameraMount:
    """A camera on a URDF link: resolution, vertical FOV (deg), optical rotation in the link."""

    name: str
    link: str
    width: int
    height: int
    fov_v_deg: float
    R_link_optical: Any = field(default_factory=lambda: OPTICAL_FORWARD)


@dataclass(frozen=True)
class QuadrotorSpec:
    """Everything that differs between quadrotor kinds.

    ``sensors`` maps each sensor's short name to its default
    :class:`SensorConfig` (cameras included); a robot's ``sensors=``
    argument overrides fields per name.
    """

    urdf: str
    landed_height: float  # m, base origin above the ground when standing on it
    limits: FlightLimits
    drag: Drag
    battery: BatterySpec
    power: RotorPowerModel
    sonar: SonarMount
    cameras: tuple[CameraMount, ...]
    sensors: dict[str, SensorConfig]
    gains: AutopilotGains = AutopilotGains()
    gyro_noise_std: float = 0.005  # rad/s
    autopilot_hz: float = 120.0  # update rate of the onboard autopilot (forces are held in between)


def fov_v_from_diagonal(fov_diag_deg: float, width: int, height: int) -> float:
    """Vertical field of view (deg) of a pinhole camera given its diagonal FOV (deg) and resolution."""
    t = math.tan(math.radians(fov_diag_deg) / 2.0) * height / math.hypot(width, height)
    return math.degrees(2.0 * math.atan(t))


def _common_sensors(sonar_rate: float, camera_names: Sequence[str], camera_rate: float) -> dict[str, SensorConfig]:
    configs = {
        "imu": SensorConfig(rate_hz=200.0, noise_std=0.05),  # m/s²
        "barometer": SensorConfig(rate_hz=25.0, noise_std=0.10),  # m
        "sonar": SensorConfig(rate_hz=sonar_rate, noise_std=0.01),  # m
        "battery": SensorConfig(rate_hz=1.0, noise_std=0.01),  # V
    }
    configs.update({name: SensorConfig(rate_hz=camera_rate) for name in camera_names})
    return configs


BEBOP2 = QuadrotorSpec(
    urdf="bebop2.urdf",
    landed_height=0.086,
    limits=FlightLimits(
        max_speed_xy=4.0,  # §V-B: 4 m/s lateral
        max_speed_z=1.0,  # §V-B: 1 m/s vertical
        max_yaw_rate=math.radians(100.0),
        max_tilt=math.radians(20.0),
        accel_ref=2.5,
    ),
    drag=Drag(linear=0.35, quadratic=0.05),
    battery=BatterySpec(capacity_mAh=2700.0, cells=3, charge_current_A=3.5, charge_voltage_V=12.6),  # §V-A
    # Calibration (Narváez §V-B: "autonomy of 20 min", 2700 mAh): the 3S pack
    # holds 31.0 Wh on the LIPO_CELL_V curve; 4 rotors of 0.15 m (A = 0.0707 m²)
    # lifting 0.50 kg need 26.1 W ideal induced power; FM 0.55 × η 0.60 gives
    # 79.1 W mechanical+electrical losses + 6 W avionics = 85.1 W -> 21.9 min hover.
    power=RotorPowerModel(
        rotor_area_m2=4 * math.pi * 0.075**2, figure_of_merit=0.55, drive_efficiency=0.60, avionics_W=6.0
    ),
    sonar=SonarMount(half_angle=math.radians(15.0), max_range=5.0, min_range=0.1, offset=(-0.005, 0.0, -0.036)),
    cameras=(CameraMount("front_camera", "camera_front", 320, 240, 60.0, OPTICAL_FORWARD),),
    sensors=_common_sensors(sonar_rate=25.0, camera_names=("front_camera",), camera_rate=30.0),
)

ARDRONE2 = QuadrotorSpec(
    urdf="ardrone2.urdf",
    landed_height=0.061,
    limits=FlightLimits(
        max_speed_xy=3.0,
        max_speed_z=1.0,  # Palafox §3.1: take-off and re-localisation climb at 1 m/s
        max_yaw_rate=math.radians(100.0),
        max_tilt=math.radians(20.0),
        accel_ref=2.0,
    ),
    drag=Drag(linear=0.45, quadratic=0.08),
    # 1000 mAh 3S pack: 11.5 Wh; rotors 0.20 m (A = 0.126 m²) lifting 0.42 kg: 15.1 W ideal;
    # FM 0.50 × η 0.58 -> 52.0 W + 5 W avionics = 57 W -> 12.1 min hover (vendor: ≈12 min).
    battery=BatterySpec(capacity_mAh=1000.0, cells=3, charge_current_A=1.0, charge_voltage_V=12.6),
    power=RotorPowerModel(
        rotor_area_m2=4 * math.pi * 0.10**2, figure_of_merit=0.50, drive_efficiency=0.58, avionics_W=5.0
    ),
    sonar=SonarMount(half_angle=math.radians(15.0), max_range=6.0, min_range=0.2, offset=(-0.03, 0.0, -0.032)),
    # vertical camera: QVGA, 64° diagonal lens
    cameras=(
        CameraMount("bottom_camera", "camera_bottom", 320, 240, fov_v_from_diagonal(64.0, 320, 240), OPTICAL_DOWN),
    ),
    sensors=_common_sensors(sonar_rate=25.0, camera_names=("bottom_camera",), camera_rate=30.0),
)

TELLO = QuadrotorSpec(
    urdf="tello.urdf",
    landed_height=0.0215,
    limits=FlightLimits(
        max_speed_xy=1.0,  # SDK "speed" setting: 10-100 cm/s
        max_speed_z=1.0,
        max_yaw_rate=math.radians(100.0),
        max_tilt=math.radians(25.0),
        accel_ref=2.0,
    ),
    drag=Drag(linear=0.5, quadratic=0.1),
    # 1100 mAh 1S pack: 4.2 Wh; rotors 0.038 m (A = 0.0045 m²) lifting 0.08 kg: 6.6 W ideal;
    # FM 0.55 × η 0.70 -> 17.1 W + 2 W avionics = 19.1 W -> 13.2 min hover (vendor: 13 min).
    battery=BatterySpec(capacity_mAh=1100.0, cells=1, charge_current_A=1.0, charge_voltage_V=4.2),
    power=RotorPowerModel(
        rotor_area_m2=4 * math.pi * 0.019**2, figure_of_merit=0.55, drive_efficiency=0.70, avionics_W=2.0
    ),
    # downward infrared time-of-flight sensor of the vision positioning system
    sonar=SonarMount(half_angle=math.radians(6.0), max_range=6.0, min_range=0.1, offset=(0.0, 0.0, -0.0215)),
    # 82.6° diagonal lens
    cameras=(
        CameraMount("front_camera", "camera_front", 320, 240, fov_v_from_diagonal(82.6, 320, 240), OPTICAL_FORWARD),
    ),
    sensors=_common_sensors(sonar_rate=25.0, camera_names=("front_camera",), camera_rate=30.0),
    gains=AutopilotGains(attitude_omega=20.0),
)


class Quadrotor(Robot):
    """A quadrotor of kind :attr:`spec`, flown through velocity commands (see the module docstring).

    Args:
        world: the world it flies in.
        name: robot name.
        pose: ``[x, y, z, yaw]`` (m, rad) or ``[x, y, yaw]`` (standing on the floor).
        sensors: per-sensor overrides of :class:`SensorConfig` fields, e.g.
            ``{"sonar": {"noise_std": 0.01}}``; names: ``imu``, ``barometer``,
            ``sonar``, ``battery`` and the kind's cameras.
        battery_soc: initial state of charge in [0, 1].
        motors_on: start with the motors running (hovering at ``pose``); default:
            on when spawned above its landed height, off when standing on the floor.
        battery_capacity_mAh: capacity of the pack (mAh) in place of the kind's
            (e.g. for long experiments that the paper ran without an energy model).
    """

    spec: QuadrotorSpec
    onboard_class = QuadrotorOnboard

    def __init__(
        self,
        world: World,
        name: str,
        pose: Sequence[float] = (0.0, 0.0, 1.0, 0.0),
        sensors: dict[str, dict[str, Any]] | None = None,
        battery_soc: float = 1.0,
        motors_on: bool | None = None,
        battery_capacity_mAh: float | None = None,
    ):
        super().__init__(world, name)
        spec = self.spec
        floor = world.scene.floor.height if world.scene.floor is not None else 0.0
        position, orientation = pose_from_list(pose, default_z=floor + spec.landed_height)
        self.load_urdf(spec.urdf, position, orientation)
        cid, body = self.cid, self.body_id
        for link in self.links.values():
            pybullet.changeDynamics(body, link, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)

        # mass properties: composite mass and centre of mass (base frame), base inertia
        masses = [(pybullet.getDynamicsInfo(body, link, physicsClientId=cid)[0], link) for link in self.links.values()]
        self.mass = sum(m for m, _ in masses)
        com = np.zeros(3)
        for m, link in masses:
            com += m * (np.zeros(3) if link == -1 else self._link_com_in_base(link))
        self._com_base = tuple(float(c) for c in com / self.mass)
        self._inertia = tuple(pybullet.getDynamicsInfo(body, -1, physicsClientId=cid)[2])

        pack = spec.battery if battery_capacity_mAh is None else replace(spec.battery, capacity_mAh=battery_capacity_mAh)
        self.battery = Battery(pack, battery_soc)
        self._clock = world.clock
        self._cmd = (0.0, 0.0, 0.0, 0.0)
        self._cmd_frame = "body"
        self._docked = False
        self._on_charger = False
        self._motors = False
        self.thrust = 0.0  # N, last applied
        self.power = 0.0  # W, last drawn
        self._v_sample, self._v_sample_step = (0.0, 0.0, 0.0), 0
        self._power_model = spec.power
        g, lim = spec.gains, spec.limits
        self._ctl = (  # constants of the per-step controller, unpacked in one go
            g.kp_xy, g.kd_xy, g.ki_xy, g.kp_z, g.kd_z, g.ki_z, g.leash, g.max_integral_accel,
            g.attitude_omega**2, 2.0 * g.attitude_zeta * g.attitude_omega, lim.accel_ref, lim.accel_ref_z,
            math.tan(lim.max_tilt), lim.thrust_to_weight * self.mass * GRAVITY, spec.drag.linear, spec.drag.quadratic,
            # tau: lag of the critically damped attitude loop
            self.mass, 2.0 / g.attitude_omega, VERTICAL_REFERENCE_TAU,
            *self._inertia,
        )
        self._period = max(1, world.clock.steps_for(1.0 / spec.autopilot_hz))  # physics steps per autopilot update
        self._force_body = self._torque_world = (0.0, 0.0, 0.0)
        self._reset_reference()
        if motors_on is None:
            motors_on = position[2] > floor + spec.landed_height + 0.02
        self.set_motors(motors_on)
        self._add_sensors(sensors or {})

    def _link_com_in_base(self, link: int) -> np.ndarray:
        state = pybullet.getLinkState(self.body_id, link, computeForwardKinematics=True, physicsClientId=self.cid)
        p_base, q_base = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
        R = rotation_matrix(q_base)
        return R.T @ (np.array(state[0]) - np.array(p_base))

    def _add_sensors(self, overrides: dict[str, dict[str, Any]]) -> None:
        known = self.spec.sensors
        for key in overrides:
            if key not in known:
                raise UnknownNameError(f"sensor of {self.kind}", key, known)
        cfg = {key: default.with_overrides(overrides.get(key)) for key, default in known.items()}
        s = self.spec.sonar
        self.add_sensor(Imu(self, "imu", cfg["imu"], gyro_noise_std=self.spec.gyro_noise_std))
        self.add_sensor(Barometer(self, "barometer", cfg["barometer"]))
        self.add_sensor(Sonar(self, "sonar", cfg["sonar"], s.half_angle, s.max_range, s.min_range, offset=s.offset))
        self.add_sensor(BatteryGauge(self.world, f"{self.name}/battery", self.battery, cfg["battery"]))
        for cam in self.spec.cameras:
            intrinsics = Intrinsics(cam.width, cam.height, cam.fov_v_deg)
            camera = Camera(self, cam.name, intrinsics, cfg[cam.name], link=cam.link, R_link_optical=cam.R_link_optical)
            self.add_sensor(camera)

    # ------------------------------------------------------------ commands
    def command_velocity(self, vx: float, vy: float, vz: float, yaw_rate: float = 0.0, frame: str = "body") -> None:
        """Fly at ``(vx, vy, vz)`` m/s turning at ``yaw_rate`` rad/s until the next command.

        ``frame="body"``: the heading frame (x forward, y left, z up, yaw-only
        rotation of the vehicle); ``"world"``: world axes. The horizontal speed
        is clipped to ``limits.max_speed_xy`` (direction kept), the vertical to
        ``max_speed_z`` and the yaw rate to ``max_yaw_rate``.
        """
        if frame not in FRAMES:
            raise ValueError(f"frame must be one of {FRAMES}, got '{frame}'")
        values = [float(v) for v in (vx, vy, vz, yaw_rate)]
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"velocity command must be finite, got {values}")
        vx, vy, vz, yaw_rate = values
        lim = self.spec.limits
        speed = math.hypot(vx, vy)
        if speed > lim.max_speed_xy:
            vx, vy = vx * lim.max_speed_xy / speed, vy * lim.max_speed_xy / speed
        vz = max(-lim.max_speed_z, min(lim.max_speed_z, vz))
        yaw_rate = max(-lim.max_yaw_rate, min(lim.max_yaw_rate, yaw_rate))
        self._cmd = (vx, vy, vz, yaw_rate)
        self._cmd_frame = frame

    def hover(self) -> None:
        """Stop (at the reference acceleration) and hold the position where the reference stops."""
        self._cmd = (0.0, 0.0, 0.0, 0.0)

    @simulates_hardware
    def set_motors(self, on: bool) -> None:
        """Start or stop the motors. Starting holds the current pose; stopped motors give no thrust and draw nothing.

        While docked the motors may be started (armed): the rotors spin up to hover
        thrust (:attr:`thrust`) and the vehicle hovers when released.
        An empty battery cannot start them.
        """
        on = bool(on) and not self.battery.empty
        if on and not self._motors:
            self._reset_reference()
        self._motors = on
        if not on:
            self.hover()

    def safe_stop(self) -> None:
        """Hover in place if flying (motors on, not docked); otherwise nothing to do."""
        if self._motors and not self._docked:
            self.hover()

    # ------------------------------------------------------------- docking
    def on_docked(self, charger: bool) -> None:
        """Called by a docking device after rigidly attaching the vehicle: motors off, charge if ``charger``."""
        self._docked = True
        self._on_charger = bool(charger)
        self.set_motors(False)

    def on_released(self) -> None:
        """Called by a docking device after releasing the vehicle: it flies again (hovers if the motors are on)."""
        self._docked = False
        self._on_charger = False
        self.battery.rest()
        self._reset_reference()

    # --------------------------------------------------------------- state
    @property
    def motors_on(self) -> bool:
        """True while the motors run."""
        return self._motors

    @property
    def docked(self) -> bool:
        """True between :meth:`on_docked` and :meth:`on_released`."""
        return self._docked

    @property
    def charging(self) -> bool:
        """True while docked on a charger and the battery is not full."""
        return self._docked and self._on_charger and not self._motors and self.battery.soc < 1.0

    @property
    def limits(self) -> FlightLimits:
        """The kind's flight limits."""
        return self.spec.limits

    def reference(self) -> tuple[np.ndarray, float]:
        """The autopilot's reference position (carrot, world frame, m) and heading (rad)."""
        return np.array(self._p_ref), self._yaw_ref

    def acceleration(self) -> np.ndarray:
        """World-frame linear acceleration (m/s²) since the last autopilot update, from velocity differences."""
        v = pybullet.getBaseVelocity(self.body_id, physicsClientId=self.cid)[0]
        elapsed = (self._clock.steps - self._v_sample_step) * self._clock.dt
        if elapsed <= 0.0:
            return np.zeros(3)
        return np.array([(v[i] - self._v_sample[i]) / elapsed for i in range(3)])

    def hover_endurance_s(self) -> float:
        """Seconds of still hover the power model predicts from the present state of charge."""
        return hover_endurance_s(self.battery.spec, self.spec.power.hover_power(self.mass, GRAVITY), self.battery.soc)

    def state(self) -> dict[str, Any]:
        """JSON-ready state: pose and velocity (world frame), battery, motors, docking."""
        out = super().state()
        v, w = self.velocity()
        b = self.battery
        out.update(
            velocity=v.tolist(),
            angular_velocity=w.tolist(),
            battery_soc=b.soc,
            battery_voltage=b.voltage,
            battery_current=b.current_A,
            power=self.power,
            motors_on=self._motors,
            docked=self._docked,
            charging=self.charging,
            command=list(self._cmd) + [self._cmd_frame],
        )
        return out

    # ------------------------------------------------------------ stepping
    def _reset_reference(self) -> None:
        """Hold the present pose: carrot at the vehicle, zero velocity reference, integrators cleared."""
        p, q = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
        x, y, z, w = q
        self._p_ref = list(p)
        self._v_ref = [0.0, 0.0, 0.0]
        self._a_ref = [0.0, 0.0, 0.0]
        self._yaw_ref = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        self._integral = [0.0, 0.0, 0.0]
        self._phase = 0  # the next physics step runs the autopilot

    def pre_physics(self, dt: float) -> None:
        """Forces and battery for one physics step; the autopilot updates every ``autopilot_period`` steps."""
        flying = self._motors and not self._docked
        self._phase -= 1
        if self._phase > 0:  # between autopilot updates: the motors hold the last thrust and torque
            if self._motors:  # flying, or armed on a dock and spinning up
                self._apply(self._force_body, self._torque_world)
                self.battery.draw(self.power, dt)
            elif self._docked and self._on_charger:
                self.battery.charge(dt)
            return
        self._phase = self._period
        cid, body = self.cid, self.body_id
        v, w_world = pybullet.getBaseVelocity(body, physicsClientId=cid)
        self._v_sample, self._v_sample_step = v, self._clock.steps
        if self._motors and self._docked:
            self._spin_up(dt * self._period)
            self._apply(self._force_body, self._torque_world)
            self.battery.draw(self.power, dt)
            return
        if not flying:
            self.thrust = self.power = 0.0
            if self._docked and self._on_charger:
                self.battery.charge(dt)
            else:
                self.battery.rest()
            return
        self._autopilot(v, w_world, dt * self._period)
        self._apply(self._force_body, self._torque_world)
        self.battery.draw(self.power, dt)

    def _spin_up(self, dt: float) -> None:
        """Armed on a dock: the thrust (body z) rises towards the weight at weight / ``ROTOR_SPIN_UP_S`` (N/s)."""
        weight = self.mass * GRAVITY
        self.thrust = min(weight, self.thrust + weight * dt / ROTOR_SPIN_UP_S)
        self.power = self._power_model.power(self.thrust, 0.0, 0.0)
        self._force_body = (0.0, 0.0, self.thrust)
        self._torque_world = (0.0, 0.0, 0.0)
        if self.battery.empty:
            self.set_motors(False)

    def _apply(self, force_body: tuple[float, float, float], torque_world: tuple[float, float, float]) -> None:
        """Apply the rotor force (body frame, at the composite centre of mass) and the attitude torque (world frame)."""
        cid, body = self.cid, self.body_id
        pybullet.applyExternalForce(body, -1, force_body, self._com_base, pybullet.LINK_FRAME, physicsClientId=cid)
        pybullet.applyExternalTorque(body, -1, torque_world, pybullet.WORLD_FRAME, physicsClientId=cid)

    def _autopilot(self, v: Sequence[float], w_world: Sequence[float], dt: float) -> None:
        """One autopilot update over ``dt`` seconds: reference model, position hold, attitude loop, power."""
        p, q = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
        (kp_xy, kd_xy, ki_xy, kp_z, kd_z, ki_z, leash, imax, kp_att, kd_att, acc_ref, acc_ref_z,
         tan_tilt, max_thrust, c1, c2, m, tau, tau_z, ixx, iyy, izz) = self._ctl
        x, y, z, w = q
        # rotation matrix R_world_body
        r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
        r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        yaw = math.atan2(r10, r00)

        # --- reference model: target acceleration bringing the predicted reference velocity
        # (v_ref + a_ref tau) onto the command; a_ref follows it with the attitude lag tau
        cvx, cvy, cvz, cyaw = self._cmd
        if self._cmd_frame == "body":
            c, s = math.cos(yaw), math.sin(yaw)
            cvx, cvy = c * cvx - s * cvy, s * cvx + c * cvy
        vr, pr, ar = self._v_ref, self._p_ref, self._a_ref
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
        # leash: the carrot never leads the vehicle by more than `leash`
        ex, ey, ez = pr[0] - p[0], pr[1] - p[1], pr[2] - p[2]
        e_norm = math.sqrt(ex * ex + ey * ey + ez * ez)
        if e_norm > leash:
            k = leash / e_norm
            ex, ey, ez = ex * k, ey * k, ez * k
            pr[0], pr[1], pr[2] = p[0] + ex, p[1] + ey, p[2] + ez
        self._yaw_ref += cyaw * dt
        yaw_err = (self._yaw_ref - yaw + math.pi) % (2 * math.pi) - math.pi
        if abs(yaw_err) > leash:
            yaw_err = math.copysign(leash, yaw_err)
            self._yaw_ref = yaw + yaw_err

        # --- air drag on the air-relative velocity
        wind = self.world.wind.velocity(self._clock.now, np.array(p))
        vax, vay, vaz = v[0] - float(wind[0]), v[1] - float(wind[1]), v[2] - float(wind[2])
        kdrag = m * (c1 + c2 * math.sqrt(vax * vax + vay * vay + vaz * vaz))
        fdx, fdy, fdz = -kdrag * vax, -kdrag * vay, -kdrag * vaz

        # --- position hold: feed-forward (horizontal: the target, the attitude loop adds the lag;
        # vertical: the reference, thrust is immediate) + drag feed-forward + PD + integral
        integ = self._integral
        ax = tx + kff * vr[0] + kp_xy * ex + kd_xy * (vr[0] - v[0]) + max(-imax, min(imax, ki_xy * integ[0]))
        ay = ty + kff * vr[1] + kp_xy * ey + kd_xy * (vr[1] - v[1]) + max(-imax, min(imax, ki_xy * integ[1]))
        az = ar[2] + kff * vr[2] + kp_z * ez + kd_z * (vr[2] - v[2]) + max(-imax, min(imax, ki_z * integ[2]))
        Az = GRAVITY + max(-0.8 * GRAVITY, min(max_thrust / m - GRAVITY, az))
        a_xy, a_xy_max = math.hypot(ax, ay), Az * tan_tilt
        if a_xy > a_xy_max:  # tilt limit; no integration while saturated (anti-windup)
            ax, ay = ax * a_xy_max / a_xy, ay * a_xy_max / a_xy
        else:
            integ[0] += ex * dt
            integ[1] += ey * dt
        integ[2] += ez * dt

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
        # rotor thrust along body z plus drag, in the body frame (applied at the composite centre of mass)
        self._force_body = (
            r00 * fdx + r10 * fdy + r20 * fdz,
            r01 * fdx + r11 * fdy + r21 * fdz,
            thrust + r02 * fdx + r12 * fdy + r22 * fdz,
        )
        self._torque_world = torque

        # --- energy
        self.thrust = thrust
        self.power = self._power_model.power(thrust, v[2], fdx * vax + fdy * vay + fdz * vaz)
        if self.battery.empty:
            self.set_motors(False)


class Bebop2(Quadrotor):
    """Parrot Bebop 2 with the AprilTag bundle (link ``tag_bundle``) and docking adapter (link ``part_b``)."""

    kind = "bebop2"
    spec = BEBOP2


class ArDrone2(Quadrotor):
    """Parrot AR.Drone 2.0 (indoor hull) with its QVGA vertical camera (link ``camera_bottom``)."""

    kind = "ardrone2"
    spec = ARDRONE2


class Tello(Quadrotor):
    """Ryze Tello micro-scout with its front camera (link ``camera_front``)."""

    kind = "tello"
    spec = TELLO
