"""Quadrotors flown like their vendors' SDKs: velocity commands over an onboard position hold.

One :class:`Quadrotor` class serves every kind; a :class:`QuadrotorSpec`
holds what differs (URDF, limits, drag, battery, power model, sensors):

- ``bebop2``  Parrot Bebop 2, 0.50 kg (Narváez 2020, §V-B): front camera,
  AprilTag bundle (link ``tag_bundle``) and docking adapter (link ``part_b``).
- ``ardrone2`` Parrot AR.Drone 2.0, indoor hull, 0.42 kg (Palafox 2019):
  QVGA vertical camera (link ``camera_bottom``) and sonar.
- ``tello``   Ryze Tello micro-scout, 0.08 kg (Arora et al.): front camera.

Flight model (pybullet forces, every physics step, plain ``math``):

1. Sensing and estimation: IMU, barometer, sonar, downward optical flow
   (:mod:`..sensors.flow`) and the onboard
   :class:`~marsupial.world.estimation.flight.FlightEstimator` fusing them at
   the autopilot rate (120 Hz). The estimate starts at the spawn pose and
   drifts; ``estimator.reset`` restarts it (a carrier's hand-over). External
   vision fixes of the vehicle's pose that a team member sends on
   ``<name>/vision_fix`` (:mod:`~marsupial.world.estimation.external`) are
   fused as the radio delivers them.
2. Autopilot (:mod:`.autopilot`): velocity commands (``"body"``: heading
   frame at the estimated heading; ``"world"``: the estimate's navigation
   frame ``odom``), clipped to the kind's :class:`FlightLimits` (Bebop 2:
   4 m/s lateral, 1 m/s vertical, §V-B), a reference model, a position hold
   on the *estimate* and a physical attitude loop. The body really tilts and
   lags, and it drifts in truth as its estimate drifts.
3. Air drag ``-m (c1 v_air + c2 |v_air| v_air)`` on the true air-relative
   velocity ``v_air = v - world.wind.velocity(t, p)``, so wind pushes the
   vehicle and the integral action of the position hold leans into it.
4. Power: :class:`~marsupial.world.energy.RotorPowerModel` from the thrust,
   climb speed and drag power, drawn from the :class:`~marsupial.world.energy.Battery`
   every step. Motors off: no thrust, no power. An empty battery stops the motors.

While the motors are off or a docking device holds the vehicle the
estimator holds its estimate (zero-velocity update).

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

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import pybullet

from marsupial.api.errors import UnknownNameError
from marsupial.api.model import FlightLimits, Intrinsics
from marsupial.api.readings import vision_fix_topic
from marsupial.api.views import QuadrotorView

from ..energy import Battery, BatteryGauge, BatterySpec, RotorPowerModel, hover_endurance_s
from ..estimation.flight import FlightEstimator
from ..sensors.barometer import Barometer
from ..sensors.base import SensorConfig
from ..sensors.camera import OPTICAL_DOWN, OPTICAL_FORWARD, Camera
from ..sensors.flow import OpticalFlow
from ..sensors.imu import Imu, ImuErrors, Quat, Vec3
from ..sensors.sonar import Sonar
from ..world import GRAVITY
from .autopilot import FRAMES, Autopilot, AutopilotGains, Drag
from .base import Robot, pose_from_list, rotation_matrix, yaw_of

__all__ = [
    "FRAMES", "ArDrone2", "AutopilotGains", "Bebop2", "CameraMount", "Drag", "FlightLimits", "FlowMount",
    "Quadrotor", "QuadrotorSpec", "SonarMount", "Tello",
]

if TYPE_CHECKING:
    from ..world import World

ROTOR_SPIN_UP_S = 0.5  # s for the rotors of a vehicle armed on a dock to reach hover thrust (chosen)


@dataclass(frozen=True)
class SonarMount:
    """Downward range finder: cone half-angle (rad), range interval (m), origin in the base frame (m)."""

    half_angle: float
    max_range: float
    min_range: float
    offset: tuple[float, float, float]


@dataclass(frozen=True)
class FlowMount:
    """Downward optical flow at the sonar's origin (figures before ``noise_scale``; see docs/world.md).

    Noise growth with range ((m/s)/m), 1σ scale error, nearest valid range (m), slow bias (m/s, s).
    """

    noise_per_m: float = 0.02  # chosen, see docs/world.md (order of PX4Flow's errors, Honegger et al. 2013)
    scale_std: float = 0.03  # chosen: lens and range calibration
    min_range: float = 0.05  # m, the texture is out of focus nearer than this (chosen)
    bias_std: float = 0.003  # m/s, slowly varying bias (texture, lighting; chosen, see docs/world.md)
    bias_tau: float = 30.0  # s


@dataclass(frozen=True)
class CameraMount:
    """A camera on a URDF link: resolution, vertical FOV (deg), optical rotation in the link.

    ``depth_standin``: the frame's rendered depth reaches the onboard interface beside the RGB image of
    this monocular camera, as the input of a carrier's monocular-depth-network stand-in only
    (``marsupial.skills.scout.depth``); the camera measures no depth.
    """

    name: str
    link: str
    width: int
    height: int
    fov_v_deg: float
    R_link_optical: Any = field(default_factory=lambda: OPTICAL_FORWARD)
    depth_standin: bool = False


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
    imu_errors: ImuErrors = ImuErrors()
    flow: FlowMount = FlowMount()
    autopilot_hz: float = 120.0  # update rate of the onboard autopilot (forces are held in between)


def fov_v_from_diagonal(fov_diag_deg: float, width: int, height: int) -> float:
    """Vertical field of view (deg) of a pinhole camera given its diagonal FOV (deg) and resolution."""
    t = math.tan(math.radians(fov_diag_deg) / 2.0) * height / math.hypot(width, height)
    return math.degrees(2.0 * math.atan(t))


def _common_sensors(
    sonar_rate: float, camera_names: Sequence[str], camera_rate: float, camera_latency_s: float
) -> dict[str, SensorConfig]:
    """Nominal sensor figures shared by the kinds (sources in ``docs/world.md``)."""
    configs = {
        # MPU-6000-class accelerometer: 400 µg/√Hz over ≈100 Hz ≈ 0.04 m/s², plus rotor vibration
        "imu": SensorConfig(rate_hz=200.0, noise_std=0.05),  # m/s²
        "barometer": SensorConfig(rate_hz=25.0, noise_std=0.10),  # m (MS5607/MS5611 class)
        "sonar": SensorConfig(rate_hz=sonar_rate, noise_std=0.01, dropout=0.02),  # m; 2 % lost echoes (chosen)
        # vertical-camera flow at 60 Hz; 1σ noise 0.02 m/s + FlowMount.noise_per_m × range
        "flow": SensorConfig(rate_hz=60.0, noise_std=0.02),
        "battery": SensorConfig(rate_hz=1.0, noise_std=0.01),  # V
    }
    # Wi-Fi video: pixel noise (0-255), ≈2 % lost frames and the stream's latency
    configs.update(
        {
            name: SensorConfig(rate_hz=camera_rate, noise_std=3.0, dropout=0.02, latency_s=camera_latency_s)
            for name in camera_names
        }
    )
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
    sensors=_common_sensors(sonar_rate=25.0, camera_names=("front_camera",), camera_rate=30.0, camera_latency_s=0.1),
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
    # bottom camera: ≈0.1 s video latency (Palafox 2019; Engel et al. 2012 measured the same order)
    sensors=_common_sensors(sonar_rate=25.0, camera_names=("bottom_camera",), camera_rate=30.0, camera_latency_s=0.1),
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
    # 82.6° diagonal lens; the rendered depth of each frame is the scout's depth-network stand-in input (§IV-G)
    cameras=(
        CameraMount(
            "front_camera", "camera_front", 320, 240, fov_v_from_diagonal(82.6, 320, 240), OPTICAL_FORWARD,
            depth_standin=True,
        ),
    ),
    sensors=_common_sensors(sonar_rate=25.0, camera_names=("front_camera",), camera_rate=30.0, camera_latency_s=0.1),
    gains=AutopilotGains(attitude_omega=20.0),
)



class Quadrotor(Robot):
    """A quadrotor of kind :attr:`spec`, flown through velocity commands on its onboard estimate (module docstring).

    Args:
        world: the world it flies in.
        name: robot name.
        pose: ``[x, y, z, yaw]`` (m, rad) or ``[x, y, yaw]`` (standing on the floor); the
            onboard estimate starts there.
        sensors: per-sensor overrides of the nominal :class:`SensorConfig` fields (scaled
            by ``world.noise_scale`` afterwards), e.g. ``{"sonar": {"noise_std": 0.01}}``;
            names: ``imu``, ``barometer``, ``sonar``, ``flow``, ``battery`` and the kind's cameras.
        battery_soc: initial state of charge in [0, 1].
        motors_on: start with the motors running (hovering at ``pose``); default:
            on when spawned above its landed height, off when standing on the floor.
        battery_capacity_mAh: capacity of the pack (mAh) in place of the kind's
            (e.g. for long experiments that the paper ran without an energy model).

    Attributes:
        estimator: the onboard :class:`FlightEstimator` (frame ``"odom"``).
        autopilot: the :class:`Autopilot` flying on it.
    """

    spec: QuadrotorSpec
    view_class = QuadrotorView
    estimator: FlightEstimator

    @classmethod
    def declared_sensors(cls) -> frozenset[str] | None:
        """The kind's sensors (its spec's, cameras included); ``None`` on the generic class without a spec."""
        spec = getattr(cls, "spec", None)
        return None if spec is None else frozenset(spec.sensors)

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
        inertia = tuple(pybullet.getDynamicsInfo(body, -1, physicsClientId=cid)[2])

        pack = (
            spec.battery if battery_capacity_mAh is None else replace(spec.battery, capacity_mAh=battery_capacity_mAh)
        )
        self.battery = Battery(pack, battery_soc)
        self._clock = world.clock
        self._docked = False
        self._on_charger = False
        self._motors = False
        self.thrust = 0.0  # N, last applied
        self.power = 0.0  # W, last drawn
        self._v_sample: tuple[float, ...] = (0.0, 0.0, 0.0)
        self._v_sample_step = 0
        self._state_step = -1  # physics step of the cached base state
        self._power_model = spec.power
        self.autopilot = Autopilot(spec.limits, spec.gains, spec.drag, self.mass, inertia)
        self._period = max(1, world.clock.steps_for(1.0 / spec.autopilot_hz))  # physics steps per autopilot update
        self._phase = 0  # the next physics step runs the autopilot
        self._force_body = self._torque_world = (0.0, 0.0, 0.0)
        self._add_sensors(sensors or {})
        self.estimator = FlightEstimator(
            world,
            self.sensors[f"{name}/imu"],  # type: ignore[arg-type]
            self.sensors[f"{name}/flow"],  # type: ignore[arg-type]
            self.sensors[f"{name}/sonar"],  # type: ignore[arg-type]
            self.sensors[f"{name}/barometer"],  # type: ignore[arg-type]
            floor_height=floor,
            landed_height=spec.landed_height,
            sonar_offset_z=spec.sonar.offset[2],
            position=tuple(float(c) for c in position),  # type: ignore[arg-type]
            yaw=yaw_of(orientation),
            vision_fixes=functools.partial(world.team_link.latest_on, vision_fix_topic(name)),
        )
        self.autopilot.reset(self.estimator)
        if motors_on is None:
            motors_on = position[2] > floor + spec.landed_height + 0.02
        self.set_motors(motors_on)

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
        s, f = self.spec.sonar, self.spec.flow
        self.add_sensor(Imu(self, "imu", cfg["imu"], self.spec.imu_errors))
        self.add_sensor(Barometer(self, "barometer", cfg["barometer"]))
        self.add_sensor(Sonar(self, "sonar", cfg["sonar"], s.half_angle, s.max_range, s.min_range, offset=s.offset))
        self.add_sensor(
            OpticalFlow(
                self, "flow", cfg["flow"], f.noise_per_m, f.scale_std, f.min_range, s.max_range,
                offset=s.offset, bias_std=f.bias_std, bias_tau=f.bias_tau,
            )
        )
        self.add_sensor(BatteryGauge(self.world, f"{self.name}/battery", self.battery, cfg["battery"]))
        for cam in self.spec.cameras:
            intrinsics = Intrinsics(cam.width, cam.height, cam.fov_v_deg)
            camera = Camera(
                self, cam.name, intrinsics, cfg[cam.name], link=cam.link, R_link_optical=cam.R_link_optical,
                measures_depth=cam.depth_standin,  # monocular RGB cameras (see CameraMount.depth_standin)
            )
            self.add_sensor(camera)

    # ------------------------------------------------------------ commands
    def command_velocity(self, vx: float, vy: float, vz: float, yaw_rate: float = 0.0, frame: str = "body") -> None:
        """Fly at ``(vx, vy, vz)`` m/s turning at ``yaw_rate`` rad/s until the next command.

        ``frame="body"``: the heading frame at the *estimated* heading (x
        forward, y left, z up); ``"world"``: the estimator's navigation frame
        (``odom``). The horizontal speed is clipped to ``limits.max_speed_xy``
        (direction kept), the vertical to ``max_speed_z`` and the yaw rate to
        ``max_yaw_rate``.
        """
        self.autopilot.command(vx, vy, vz, yaw_rate, frame)

    def hover(self) -> None:
        """Stop (at the reference acceleration) and hold the estimated position where the reference stops."""
        self.autopilot.hover()
    def set_motors(self, on: bool) -> None:
        """Start or stop the motors. Starting holds the estimated pose; stopped motors give no thrust and draw nothing.

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
        """The autopilot's reference position (carrot, navigation frame ``odom``, m) and heading (rad)."""
        return np.array(self.autopilot.p_ref), self.autopilot.yaw_ref

    def acceleration(self) -> np.ndarray:
        """World-frame linear acceleration (m/s²) since the last autopilot update, from velocity differences."""
        return np.array(self._acceleration(pybullet.getBaseVelocity(self.body_id, physicsClientId=self.cid)[0]))

    def _acceleration(self, v: Sequence[float]) -> tuple[float, float, float]:
        elapsed = (self._clock.steps - self._v_sample_step) * self._clock.dt
        if elapsed <= 0.0:
            return (0.0, 0.0, 0.0)
        s = self._v_sample
        return ((v[0] - s[0]) / elapsed, (v[1] - s[1]) / elapsed, (v[2] - s[2]) / elapsed)

    def base_state(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """Base position, orientation, velocity, angular velocity (world) as tuples; read once per autopilot step."""
        if self._state_step != self._clock.steps:
            self._state = super().base_state()
            self._state_step = self._clock.steps
        return self._state

    def inertial_truth(self) -> tuple[Quat, Vec3, Vec3]:
        """True orientation, world angular velocity and acceleration as tuples (the IMU's input; world side)."""
        _, q, v, w = self.base_state()
        return cast(Quat, q), cast(Vec3, w), self._acceleration(v)

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
            command=list(self.autopilot.cmd) + [self.autopilot.cmd_frame],
        )
        return out

    # ------------------------------------------------------------ stepping
    def _reset_reference(self) -> None:
        """Hold the estimated pose: carrot at the estimate, zero velocity reference, integrators cleared."""
        self.autopilot.reset(self.estimator)
        self._phase = 0  # the next physics step runs the autopilot

    def pre_physics(self, dt: float) -> None:
        """Forces and battery for one physics step; estimator and autopilot update every ``autopilot_period`` steps."""
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
        period_dt = dt * self._period
        self._state_step = -1  # forces applied since: read the state anew
        self.estimator.update(period_dt, at_rest=not flying)  # reads the IMU (acceleration since the last update)
        p, q, v, w_world = self.base_state()
        self._v_sample, self._v_sample_step = v, self._clock.steps
        if self._motors and self._docked:
            self._spin_up(period_dt)
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
        wind = self.world.wind.velocity(self._clock.now, np.array(p))
        force, torque, thrust, drag_power = self.autopilot.update(
            self.estimator, q, v, w_world, (float(wind[0]), float(wind[1]), float(wind[2])), period_dt
        )
        self._force_body, self._torque_world, self.thrust = force, torque, thrust
        self.power = self._power_model.power(thrust, v[2], drag_power)
        if self.battery.empty:
            self.set_motors(False)
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
