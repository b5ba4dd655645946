"""What a mission tells the world, as typed models: the team's robots (options, sensor settings) and disturbances.

The mission loader validates these sections of a mission file with the
models below (unknown keys refused, booleans and strings are not numbers,
numbers finite and within their documented ranges), so every mistake is
reported at its file:line before a world is built; the world then works from
the validated models (:func:`marsupial.world.disturbances.apply_disturbances`,
:meth:`RobotConfig.constructor_options`). Names that only a built world knows
(links, sensors, walls, aperture shapes) are resolved there.

Units are SI (m, s, Hz, rad) unless a key says otherwise (``_deg``, ``_mAh``);
poses and positions are in the world frame.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Annotated, Any, Literal, TypeAlias, TypeVar

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    model_validator,
)
from pydantic_core import PydanticCustomError

T = TypeVar("T")


class ConfigModel(BaseModel):
    """Base of every configuration model: unknown keys refused, no coercion (``true`` is not a number, ``"2"``
    is not a number), finite numbers only; frozen once validated."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)

    def given(self) -> dict[str, Any]:
        """The keys the mission wrote (nested models as plain mappings), without the defaults it left out."""
        return self.model_dump(exclude_unset=True)


def _invalid(message: str, expected: str, at: tuple[Any, ...] = ()) -> PydanticCustomError:
    """A validation error that the mission loader reports at key path ``at`` (relative to the model)."""
    return PydanticCustomError("config", message, {"expected": expected, "at": at})


# ------------------------------------------------------------------ value types
MAX_POSE_VALUE = 1000.0
"""Largest magnitude (m; rad for a yaw) of a start pose's entries and spreads: pybullet computes contacts in single
precision, whose step at 1 km is 0.06 mm and grows with the distance."""

PoseValue = Annotated[float, Field(ge=-MAX_POSE_VALUE, le=MAX_POSE_VALUE)]
"""One entry of a pose (m, or rad for a yaw), within ±:data:`MAX_POSE_VALUE`."""

NonNegative = Annotated[float, Field(ge=0)]
Probability = Annotated[float, Field(ge=0, le=1)]
Name = Annotated[str, Field(min_length=1, max_length=200, pattern=r"^[^\x00-\x1f\x7f]+$")]
"""A name (robot, link, wall, shape class): non-empty printable text."""


def _one_as_list(value: Any) -> Any:
    """A single mapping written where a list of mappings is expected, as a one-item list."""
    return [value] if isinstance(value, Mapping) else value


class OneOrListSchema:
    """JSON Schema of a list field that also accepts a single item (``{…}`` or ``[{…}, …]``)."""

    @classmethod
    def __get_pydantic_json_schema__(cls, core_schema: Any, handler: Callable[[Any], dict[str, Any]]) -> dict[str, Any]:
        as_list = handler(core_schema)
        return {"anyOf": [as_list["items"], as_list]}


OneOrList: TypeAlias = Annotated[list[T], BeforeValidator(_one_as_list), OneOrListSchema]
"""A list of mappings, or one mapping written alone."""


def yaml_kind(value: Any) -> str | None:
    """The YAML kind of ``value``: ``"text"``, ``"number"`` (not a boolean) or ``"list"``; ``None`` for others.

    The discriminator of the fields that take, e.g., a number or a ``[low, high]`` list.
    """
    if isinstance(value, str):
        return "text"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return "number"
    return "list" if isinstance(value, list) else None


def _increasing(values: list[float]) -> list[float]:
    if not values[0] < values[1]:
        raise _invalid(f"[low, high] = {values} is not increasing", "[low, high] with low < high")
    return values


def _sensor_path(path: str) -> str:
    robot, slash, sensor = path.partition("/")
    if not (robot and slash and sensor) or "/" in sensor:
        raise _invalid(f"'{path}' does not name a sensor", "'robot/sensor' (e.g. carrier/eye_in_hand)")
    return path


Range = Annotated[list[PoseValue], Field(min_length=2, max_length=2), AfterValidator(_increasing)]
"""``[low, high]`` with low < high (m, world frame)."""
SizeRange = Annotated[list[Annotated[float, Field(gt=0, le=10)]], Field(min_length=2, max_length=2),
                      AfterValidator(_increasing)]
"""``[low, high]`` sizes with 0 < low < high <= 10 (m)."""
SensorPath = Annotated[Name, AfterValidator(_sensor_path)]
"""A sensor named ``"robot/sensor"`` (``"carrier/eye_in_hand"``)."""


# ------------------------------------------------------------------ sensors
class SensorSettings(ConfigModel):
    """Overrides of a sensor's sampling figures (the robot's datasheet values where left out; docs/world.md §4).

    The figures given are the unscaled ones: ``world.sensing.noise_scale`` multiplies noise, dropout and latency.
    """

    rate_hz: float | None = Field(None, gt=0, le=1000, description="Samples per simulated second (Hz).")
    noise_std: NonNegative | None = Field(
        None, description="Standard deviation of the additive noise, in the sensor's unit (m, m/s², 0-255 intensity)."
    )
    dropout: Probability | None = Field(None, description="Probability that a due sample is lost.")
    latency_s: float | None = Field(None, ge=0, le=10, description="Delay before a sample becomes readable (s).")


Pixels = Annotated[int, Field(ge=8, le=4096)]
"""An image size (px): a frame larger than 4096 px a side would take minutes to render."""


class CameraSettings(SensorSettings):
    """Overrides of a camera of the mobile manipulator: sampling, image size, field of view and clipping."""

    width: Pixels | None = Field(None, description="Image width (px).")
    height: Pixels | None = Field(None, description="Image height (px).")
    fov_v_deg: float | None = Field(None, gt=0, lt=180, description="Vertical field of view (deg).")
    near: float | None = Field(None, gt=0, le=10, description="Nearest depth rendered (m).")
    far: float | None = Field(None, gt=0, le=1000, description="Farthest depth rendered (m).")
    segmentation: bool | None = Field(None, description="Whether frames carry a segmentation mask.")
    depth_noise_per_m: NonNegative | None = Field(
        None, description="Standard deviation of the depth error per metre of depth (m/m)."
    )


class LidarSettings(SensorSettings):
    """Overrides of the mobile manipulator's laser scanner (a Sick LMS111 by default): sampling and beam geometry."""

    fov_deg: float | None = Field(None, gt=0, le=360, description="Angular field of view (deg) about the sensor's x.")
    resolution_deg: float | None = Field(None, ge=0.05, le=90, description="Angle between beams (deg).")
    max_range: float | None = Field(None, gt=0, le=1000, description="Farthest echo (m).")
    start_range: NonNegative | None = Field(None, description="Distance from the sensor where beams start (m).")
    beam_dropout: Probability | None = Field(None, description="Probability that one beam returns no echo.")


class QuadrotorSensors(ConfigModel):
    """Sensor overrides of a quadrotor by sensor name (its camera is added by its kind)."""

    imu: SensorSettings | None = Field(None, description="Accelerometer and gyro (noise in m/s²).")
    barometer: SensorSettings | None = Field(None, description="Barometric altitude (noise in m).")
    sonar: SensorSettings | None = Field(None, description="Downward range (noise in m).")
    flow: SensorSettings | None = Field(None, description="Optical-flow velocity (noise in m/s).")
    battery: SensorSettings | None = Field(None, description="Battery voltage gauge (noise in V).")


class FrontCameraQuadrotorSensors(QuadrotorSensors):
    """Sensor overrides of a quadrotor with a forward camera (``bebop2``, ``tello``)."""

    front_camera: SensorSettings | None = Field(None, description="Forward camera (noise in 0-255 intensity).")


class BottomCameraQuadrotorSensors(QuadrotorSensors):
    """Sensor overrides of a quadrotor with a downward camera (``ardrone2``)."""

    bottom_camera: SensorSettings | None = Field(None, description="Downward camera (noise in 0-255 intensity).")


class MobileManipulatorSensors(ConfigModel):
    """Sensor overrides of the mobile manipulator by sensor name."""

    eye_in_hand: CameraSettings | None = Field(None, description="PS Eye RGB camera on the end effector.")
    front_rgbd: CameraSettings | None = Field(None, description="RealSense D435 RGB-D camera on the base.")
    lidar: LidarSettings | None = Field(None, description="Sick LMS111 laser scanner on the base.")


# ------------------------------------------------------------------ robot options
class DriveLimits(ConfigModel):
    """Overrides of a ground robot's drive limits and slip (its kind's values where left out)."""

    max_speed: float | None = Field(None, gt=0, le=20, description="|v| limit (m/s).")
    max_omega: float | None = Field(None, gt=0, le=20, description="|omega| limit (rad/s).")
    max_accel: float | None = Field(None, gt=0, le=100, description="|dv/dt| limit (m/s²).")
    max_alpha: float | None = Field(None, gt=0, le=100, description="|domega/dt| limit (rad/s²).")
    slip: float | None = Field(None, ge=0, lt=1, description="Fraction of the commanded speed lost to wheel slip.")
    drift_per_rad: NonNegative | None = Field(None, description="Lateral drift per (m/s · rad/s) while turning (m/s).")
    noise_std: NonNegative | None = Field(None, description="Standard deviation of the speed noise (m/s, rad/s).")
    max_force: float | None = Field(None, gt=0, description="Force the drive may exert (N).")
    resync_m: float | None = Field(None, gt=0, description="Body-to-reference distance that resyncs the reference (m).")
    turn_slip: float | None = Field(None, ge=0, lt=1, description="Fraction of the commanded yaw rate lost to scrub.")


class QuadrotorOptions(ConfigModel):
    """Options of a quadrotor (``bebop2``, ``ardrone2``, ``tello``)."""

    battery_soc: Probability = Field(1.0, description="Initial state of charge (0-1).")
    motors_on: bool | None = Field(
        None, description="Whether the motors start on (hovering at the pose); none: on when it starts above its "
        "landed height."
    )
    battery_capacity_mAh: float | None = Field(
        None, gt=0, le=1e6, description="Capacity of the pack (mAh) in place of the kind's."
    )


class WheeledOptions(ConfigModel):
    """Options of a ground robot: drive limits and how it localises."""

    limits: DriveLimits | None = Field(None, description="Drive limits replacing the kind's, by field.")
    localization: Literal["odometry", "map"] = Field(
        "odometry",
        description="'odometry': wheel odometry, drifts with distance; 'map': localised against the building plan "
        "with a bounded error.",
    )


class DockingSettings(ConfigModel):
    """Overrides of the mobile manipulator's docking device (Part A, Narváez et al. §IV-C)."""

    capture_distance: float | None = Field(None, gt=0, le=1, description="Reach of the magnet's pull (m).")
    holding_force: float | None = Field(None, gt=0, description="Force of the electromagnet (N).")
    force_length: float | None = Field(None, gt=0, le=1, description="d_0 of the pull F(d) = F / (1 + d/d_0)² (m).")
    contact_distance: NonNegative | None = Field(None, le=1, description="Gap counted as contact (m).")
    lock_time: NonNegative | None = Field(None, le=60, description="Time the levers take to close (s).")
    lateral_tolerance: NonNegative | None = Field(None, le=1, description="Offset the cone still guides (m).")
    tilt_tolerance: NonNegative | None = Field(None, le=math.pi, description="Tilt the cone absorbs (rad).")
    charger: bool | None = Field(None, description="Whether Part A charges a docked UAV (12.6 V / 3.5 A).")

    @model_validator(mode="after")
    def _contact_within_capture(self) -> DockingSettings:
        contact, capture = self.contact_distance, self.capture_distance
        if contact is not None and capture is not None and contact > capture:
            raise _invalid("contact_distance exceeds capture_distance", "contact_distance <= capture_distance",
                           ("contact_distance",))
        return self


JointAngle = Annotated[float, Field(ge=-2 * math.pi, le=2 * math.pi)]
ArmAngles = Annotated[list[JointAngle], Field(min_length=6, max_length=6)]
"""Six joint angles (rad), each within ±2π."""


class MobileManipulatorOptions(WheeledOptions):
    """Options of the mobile manipulator (Pioneer 3-DX base, 6-DoF arm, docking device)."""

    arm_pose: Annotated[
        Annotated[Literal["upright", "stowed", "docking_ready", "storage"], Tag("text")]
        | Annotated[ArmAngles, Tag("list")],
        Discriminator(yaml_kind),
    ] = Field("stowed", description="Initial arm configuration: a named pose or six joint angles (rad).")
    docking: DockingSettings | None = Field(None, description="Docking device settings replacing the defaults.")


class MMSOptions(WheeledOptions):
    """Options of the micro-scout carrier (Arora & Papachristos): its launching apparatuses, arm and camera."""

    mavs: bool = Field(True, description="Whether it spawns its own two Tellos (false: the team's stored ones).")
    arm_q: ArmAngles | None = Field(None, description="Initial arm joint angles (rad); none: the ready pose.")
    camera: SensorSettings | None = Field(None, description="Eye-in-hand RGB-D camera overrides.")


class ChildUGVOptions(WheeledOptions):
    """Options of the child UGV (Zhao et al.): camera and battery."""

    camera_resolution: Annotated[list[Pixels], Field(min_length=2, max_length=2)] | None = Field(
        None, description="[width, height] of the camera image (px); none: 640×480."
    )
    camera: SensorSettings | None = Field(None, description="Camera overrides (rate_hz, noise_std, …).")
    battery_soc: Probability = Field(1.0, description="Initial state of charge (0-1).")
    battery_capacity_mAh: float | None = Field(
        None, gt=0, le=1e6, description="Capacity of the pack (mAh) in place of the kind's."
    )


# ------------------------------------------------------------------ team members
class RobotConfig(ConfigModel):
    """A robot of the team: its kind, start pose, carrier, and its kind's options and sensor settings."""

    robot: str = Field(description="Robot kind (the world's robot registry).")
    pose: list[PoseValue] | None = Field(
        None,
        description="Start pose [x, y], [x, y, yaw] (ground robots) or [x, y, z, yaw] (m, rad, world frame), each "
        "within ±1000.",
    )
    pose_spread: list[PoseValue] | None = Field(
        None,
        description="[dx, dy, dyaw] >= 0 (m, m, rad): the start pose is `pose` plus a uniform offset within ± each "
        "on x, y and yaw, drawn from the world seed (the robot's estimate starts there too).",
    )
    stored_on: str | None = Field(None, description="Team member that carries this robot at the start.")

    def constructor_options(self) -> dict[str, Any]:
        """The robot constructor's keyword options the mission gives: ``options`` and, as ``sensors``, the sensor
        settings (only the keys written)."""
        given = self.model_dump(include={"options", "sensors"}, exclude_unset=True)
        options: dict[str, Any] = given.get("options", {})
        return {**options, "sensors": given["sensors"]} if given.get("sensors") else options


class Bebop2Config(RobotConfig):
    """A Parrot Bebop 2 (Narváez et al.): AprilTag bundle and docking adapter, forward camera."""

    robot: Literal["bebop2"]
    sensors: FrontCameraQuadrotorSensors = Field(default_factory=FrontCameraQuadrotorSensors)
    options: QuadrotorOptions = Field(default_factory=QuadrotorOptions)


class ArDrone2Config(RobotConfig):
    """A Parrot AR.Drone 2 (Palafox et al.): downward camera."""

    robot: Literal["ardrone2"]
    sensors: BottomCameraQuadrotorSensors = Field(default_factory=BottomCameraQuadrotorSensors)
    options: QuadrotorOptions = Field(default_factory=QuadrotorOptions)


class TelloConfig(RobotConfig):
    """A DJI Tello micro-scout (Arora & Papachristos): forward camera."""

    robot: Literal["tello"]
    sensors: FrontCameraQuadrotorSensors = Field(default_factory=FrontCameraQuadrotorSensors)
    options: QuadrotorOptions = Field(default_factory=QuadrotorOptions)


class SummitXLConfig(RobotConfig):
    """A Robotnik Summit XL (Palafox et al.'s landing platform)."""

    robot: Literal["summit_xl"]
    options: WheeledOptions = Field(default_factory=WheeledOptions)


class MobileManipulatorConfig(RobotConfig):
    """The mobile manipulator of Narváez et al.: Pioneer 3-DX, 6-DoF arm, docking device, cameras and LiDAR."""

    robot: Literal["mobile_manipulator"]
    sensors: MobileManipulatorSensors = Field(default_factory=MobileManipulatorSensors)
    options: MobileManipulatorOptions = Field(default_factory=MobileManipulatorOptions)


class ChildUGVConfig(RobotConfig):
    """Zhao et al.'s child UGV with its up-tilted camera."""

    robot: Literal["child_ugv"]
    options: ChildUGVOptions = Field(default_factory=ChildUGVOptions)


class MotherUGVConfig(RobotConfig):
    """Zhao et al.'s mother UGV with its lifting docking station."""

    robot: Literal["mother_ugv"]
    options: WheeledOptions = Field(default_factory=WheeledOptions)


class MMSConfig(RobotConfig):
    """Arora & Papachristos's mobile manipulation system carrying micro-scouts in launching apparatuses."""

    robot: Literal["mms"]
    options: MMSOptions = Field(default_factory=MMSOptions)


TeamMember: TypeAlias = Annotated[
    Annotated[Bebop2Config, Tag("bebop2")]
    | Annotated[ArDrone2Config, Tag("ardrone2")]
    | Annotated[TelloConfig, Tag("tello")]
    | Annotated[SummitXLConfig, Tag("summit_xl")]
    | Annotated[MobileManipulatorConfig, Tag("mobile_manipulator")]
    | Annotated[ChildUGVConfig, Tag("child_ugv")]
    | Annotated[MotherUGVConfig, Tag("mother_ugv")]
    | Annotated[MMSConfig, Tag("mms")],
    Discriminator("robot"),
]
"""A team member: the configuration model of its robot kind, told by its ``robot`` key."""


# ------------------------------------------------------------------ disturbances
class Window(ConfigModel):
    """When a disturbance is on (simulated s): one window from ``start`` for ``duration`` (default: for ever), or,
    with ``rate_hz``, windows of ``duration`` starting at seeded Poisson times from ``start`` until ``stop``."""

    start: NonNegative = Field(0.0, description="Start of the window, or of the random windows (s).")
    duration: float | None = Field(None, gt=0, description="Length of each window (s); none: for ever (one window).")
    rate_hz: float | None = Field(
        None, gt=0, le=100, description="Rate of random windows (Hz, counted while off); none: one window."
    )
    stop: NonNegative | None = Field(None, description="End of the random windows (s); none: never.")

    @model_validator(mode="after")
    def _consistent(self) -> Window:
        if self.rate_hz is None and self.stop is not None:
            raise _invalid("only random windows (with rate_hz) have a stop time", "duration instead", ("stop",))
        if self.rate_hz is not None and self.duration is None:
            raise _invalid("random windows (rate_hz) need a duration", "duration (s) beside rate_hz", ("rate_hz",))
        if self.stop is not None and self.stop < self.start:
            raise _invalid(f"stop {self.stop} s comes before start {self.start} s", "stop >= start", ("stop",))
        return self


class OcclusionEntry(Window):
    """A robot's link (or whole body) hidden from every camera while on — e.g. the tag bundle covered."""

    robot: Name = Field(description="Team member whose visuals are hidden.")
    link: Name | None = Field(None, description="Link to hide (e.g. tag_bundle); none: the whole robot.")


class FrameDropsEntry(Window):
    """A sensor loses each due sample with ``probability`` while on (1: a black-out)."""

    camera: SensorPath = Field(description="The sensor, 'robot/sensor' (any sensor, not only cameras).")
    probability: Probability = Field(description="Probability that a due sample is lost.")


class VideoLatencyEntry(Window):
    """A sensor's samples arrive ``seconds`` late while on (relayed video)."""

    camera: SensorPath = Field(description="The sensor, 'robot/sensor' (any sensor, not only cameras).")
    seconds: float = Field(ge=0, le=10, description="Latency while on (s).")


class KidnapEntry(ConfigModel):
    """A robot moved by hand at one instant (Zhao et al. §4.2, Experiment II); its estimate is not told."""

    robot: Name = Field(description="Team member moved.")
    at: NonNegative = Field(description="When (simulated s).")
    pose: Annotated[list[PoseValue], Field(min_length=3, max_length=4)] = Field(
        description="Where: [x, y, yaw] or [x, y, z, yaw] (m, rad, world frame)."
    )
    spread: Annotated[list[Annotated[float, Field(ge=0, le=MAX_POSE_VALUE)]], Field(min_length=3, max_length=3)] = (
        Field(default_factory=lambda: [0.0, 0.0, 0.0],
              description="[dx, dy, dyaw] (m, m, rad): a seeded uniform offset within ± each.")
    )


class WindConfig(ConfigModel):
    """Steady wind plus a seeded train of discrete "1 − cosine" gusts (MIL-F-8785C), uniform in space."""

    steady: Annotated[list[Annotated[float, Field(ge=-50, le=50)]], Field(min_length=3, max_length=3)] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0], description="Steady air velocity [vx, vy, vz] (m/s, world frame)."
    )
    gust: float = Field(0.0, ge=0, le=50, description="Peak speed A of each gust (m/s); 0: no gusts.")
    gust_period_s: float = Field(2.0, ge=0.1, le=3600, description="Duration T of each gust (s).")
    gust_gap_s: float | None = Field(
        None, ge=0.1, le=3600, description="Mean calm spell between gusts (s, exponential); none: T."
    )
    gust_elevation_deg: float = Field(
        10.0, ge=0, le=90, description="Gust directions lie within ± this elevation (deg); azimuth uniform."
    )


RECESS_WIDTH_M = (0.15, 0.32)
"""Width range of a recess (m)."""
RECESS_HEIGHT_M = (0.10, 0.24)
"""Height range of a recess (m)."""
RECESS_DEPTH_M = (0.01, 0.04)
"""Depth of a recess's back behind the face (m): below the aperture detection's d_C = 0.05 m."""
HOLE_SIDE_M = (0.03, 0.09)
"""Width and height of a hole (m), each drawn from this range: below the 0.0945 m square the Tello fits through."""
GAP_M = 0.06
"""Least wall (m) between two decoys and between a decoy and the ends of its range (chosen)."""


class DecoyEntry(ConfigModel):
    """Seeded decoy openings cut into a wall box of the scene: shallow recesses and holes too small for the MAV
    (Arora & Papachristos §IV-B; world/decoys.py)."""

    wall: Name = Field(description="A box object of the scene, unrotated, its face toward −y.")
    x: Range = Field(description="[low, high] along the wall the decoys lie in (m, world frame).")
    z: Range = Field(description="[low, high] height range the decoys lie in (m, world frame).")
    recesses: int = Field(0, ge=0, le=100, description="Number of recesses (openings closed behind).")
    holes: int = Field(0, ge=0, le=100, description="Number of holes through the wall.")
    recess_width: SizeRange = Field(default_factory=lambda: list(RECESS_WIDTH_M), description="Recess widths (m).")
    recess_height: SizeRange = Field(default_factory=lambda: list(RECESS_HEIGHT_M), description="Recess heights (m).")
    recess_depth: SizeRange = Field(default_factory=lambda: list(RECESS_DEPTH_M), description="Recess depths (m).")
    hole_size: SizeRange = Field(default_factory=lambda: list(HOLE_SIDE_M), description="Hole sides, each (m).")
    gap: float = Field(GAP_M, ge=0, le=10, description="Least wall between decoys and to the range's ends (m).")


CLEARANCE_MAX_M = 0.1
"""Largest clearance (m) an ``aperture_fit`` entry may ask for (chosen: a roomy opening is no test of a tight fit)."""

Clearance = Annotated[float, Field(gt=0, le=CLEARANCE_MAX_M)]


def _ordered(values: list[float]) -> list[float]:
    if not values[0] <= values[1]:
        raise _invalid(f"[low, high] = {values} is decreasing", "[low, high] with low <= high")
    return values


class ApertureFitEntry(ConfigModel):
    """One tight aperture for the insertion trials, the wall's other openings closed (world/aperture_fit.py)."""

    shape: Annotated[
        Annotated[Name, Tag("text")] | Annotated[list[Name], Field(min_length=1, max_length=50), Tag("list")],
        Discriminator(yaml_kind),
    ] = Field(description="A shape class (zone aperture_<shape> of the scene), or a list to draw one from uniformly.")
    clearance: Annotated[
        Annotated[Clearance, Tag("number")]
        | Annotated[list[Clearance], Field(min_length=2, max_length=2), AfterValidator(_ordered), Tag("list")],
        Discriminator(yaml_kind),
    ] = Field(description=f"The MAV's clearance in the opening (m, at most {CLEARANCE_MAX_M}), or [low, high] to "
                          "draw it from uniformly.")

    @property
    def shapes(self) -> tuple[str, ...]:
        """The shape classes to draw from."""
        return (self.shape,) if isinstance(self.shape, str) else tuple(self.shape)

    @property
    def clearance_range(self) -> tuple[float, float]:
        """``(low, high)`` (m) the clearance is drawn from (``low == high``: that clearance)."""
        if isinstance(self.clearance, list):
            return self.clearance[0], self.clearance[1]
        return self.clearance, self.clearance


class Disturbances(ConfigModel):
    """The disturbances of a run (docs/world.md §7): wind, windowed sensor faults and occlusions, kidnaps, and
    scene changes made at the start (decoys, a tight aperture)."""

    wind: WindConfig | None = Field(None, description="Gusty wind acting on the quadrotors.")
    occlusion: OneOrList[OcclusionEntry] = Field(default_factory=list, description="Links hidden from cameras.")
    frame_drops: OneOrList[FrameDropsEntry] = Field(default_factory=list, description="Samples lost.")
    video_latency: OneOrList[VideoLatencyEntry] = Field(default_factory=list, description="Samples delayed.")
    kidnap: OneOrList[KidnapEntry] = Field(default_factory=list, description="Robots moved by hand.")
    decoys: OneOrList[DecoyEntry] = Field(default_factory=list, description="Decoy openings cut into walls.")
    aperture_fit: ApertureFitEntry | None = Field(None, description="One tight aperture (not with decoys).")

    @model_validator(mode="after")
    def _one_wall_change(self) -> Disturbances:
        if self.aperture_fit is not None and self.decoys:
            raise _invalid("aperture_fit rebuilds the whole aperture wall, decoys cut into one of its boxes",
                           "aperture_fit or decoys, not both", ("aperture_fit",))
        return self

    def robots(self) -> list[tuple[tuple[Any, ...], str]]:
        """(key path, robot name) of every robot the entries name (occlusions, kidnaps, the robot of a sensor)."""
        named: list[tuple[tuple[Any, ...], str]] = []
        for key in ("occlusion", "kidnap"):
            named += [((key, i, "robot"), entry.robot) for i, entry in enumerate(getattr(self, key))]
        for key in ("frame_drops", "video_latency"):
            entries = enumerate(getattr(self, key))
            named += [((key, i, "camera"), entry.camera.partition("/")[0]) for i, entry in entries]
        return named
