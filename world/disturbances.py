"""Disturbances of a run: gusty wind, marker occlusion, camera frame drops, video latency and kidnapping.

A mission's ``world.disturbances`` section lists them (validated when the
mission loads as :class:`marsupial.api.config.Disturbances`, whose fields
document every key and unit) and :func:`apply_disturbances` installs them::

    wind: {steady: [1, 0, 0], gust: 3.0, gust_period_s: 2.0}
    occlusion:
      - {robot: uav, link: tag_bundle, start: 10, duration: 2}
      - {robot: uav, link: tag_bundle, rate_hz: 0.05, duration: 1.5}   # random windows
    frame_drops: {camera: carrier/eye_in_hand, probability: 0.1}
    video_latency: {camera: uav/front_camera, seconds: 0.2}
    kidnap: [{robot: child, at: 12.0, pose: [-1.0, 0.5, 3.14]}]          # moved by hand (Zhao, Exp. II)
    decoys: [{wall: mockup_wall_1, x: [-2.2, -1.1], z: [0.5, 1.2], recesses: 1, holes: 2}]   # :mod:`.decoys`
    aperture_fit: {shape: [orthogonal, u], clearance: [0.01, 0.03]}     # :mod:`.aperture_fit`

Every entry except ``wind``, ``kidnap`` (an instant, not a window), ``decoys`` and ``aperture_fit`` (scene
geometry, there from the start) is on during time windows (simulated seconds,
:class:`When`): one window ``start`` .. ``start + duration`` (default: from 0
for ever) or, with ``rate_hz``, a seeded random train of windows of
``duration`` s. The wind is :mod:`.wind`'s, the decoys :mod:`.decoys`' and the
tight aperture :mod:`.aperture_fit`'s; this module schedules the windows and
kidnaps. Every random draw comes from ``world.rng_for("disturbance/…")``,
so a run is reproducible for its seed and adding one disturbance does not
change what another draws.
"""

from __future__ import annotations

import contextlib
import math
import sys
import weakref
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from marsupial.api.config import Disturbances, Window
from marsupial.api.errors import UnknownNameError, WorldError

from .aperture_fit import ApertureFit, check_shapes, fit_aperture
from .decoys import cut_decoys
from .kidnap import Kidnap, spread_pose, teleport
from .wind import GustyWind

if TYPE_CHECKING:
    from .robots.base import Robot
    from .sensors.base import Sensor
    from .world import World

_NEVER = sys.maxsize  # physics step of a change that never comes


# ---------------------------------------------------------------- windows
@dataclass(frozen=True)
class When:
    """When a disturbance is on, in simulated seconds.

    Without ``rate_hz``: one window from ``start`` for ``duration`` (default
    for ever). With ``rate_hz``: windows of ``duration`` whose starts follow a
    Poisson process of ``rate_hz`` (counted while off) from ``start`` until
    ``stop`` — e.g. a marker hidden ≈ every 1 / rate_hz seconds.
    """

    start: float = 0.0
    duration: float = math.inf
    rate_hz: float | None = None
    stop: float = math.inf

    @classmethod
    def of(cls, window: Window) -> When:
        """The windows a validated entry asks for (its ``start``, ``duration``, ``rate_hz`` and ``stop``, s)."""
        duration = math.inf if window.duration is None else window.duration
        return cls(window.start, duration, window.rate_hz, math.inf if window.stop is None else window.stop)

    def __post_init__(self) -> None:
        if self.start < 0 or not self.duration > 0:
            raise ValueError(
                f"start must be >= 0 s and duration > 0 s, got start={self.start}, duration={self.duration}"
            )
        if self.rate_hz is not None and (not self.rate_hz > 0 or math.isinf(self.duration)):
            raise ValueError("random windows need rate_hz > 0 and a finite duration")

    def windows(self, rng: np.random.Generator) -> Iterator[tuple[float, float]]:
        """The windows ``(begin, end)`` in time order (s); random ones draw from ``rng``."""
        if self.rate_hz is None:
            yield self.start, self.start + self.duration
            return
        t = self.start
        while True:
            t += rng.exponential(1.0 / self.rate_hz)
            if t >= self.stop:
                return
            yield t, t + self.duration
            t += self.duration


# ---------------------------------------------------------------- targets
class _HiddenVisuals:
    """The visual shapes of one robot body, hidden link by link while occlusions are on.

    Hiding sets a shape's alpha to 0, which TinyRenderer skips altogether (no
    colour, depth or segmentation); showing restores the shape's colour (a
    texture stays attached throughout).
    """

    def __init__(self, robot: Robot):
        self._cid = robot.cid
        self._body = robot.body_id
        self._shapes: list[tuple[int, int, tuple[float, ...]]] = []  # (link, shape index in link, rgba)
        per_link: dict[int, int] = {}
        for shape in pybullet.getVisualShapeData(self._body, physicsClientId=self._cid):
            link_index, rgba = shape[1], shape[7]
            index = per_link.get(link_index, 0)
            per_link[link_index] = index + 1
            self._shapes.append((link_index, index, tuple(rgba)))
        self._hidden = [False] * len(self._shapes)

    def has_visuals(self, link_index: int | None) -> bool:
        """Whether the link (any link if ``None``) has a visual shape to hide."""
        return any(link_index is None or link == link_index for link, _, _ in self._shapes)

    def apply(self, values: list[Any]) -> None:
        """Hide the shapes of the links in ``values`` (all of them if it holds ``None``); show the rest."""
        links = set(values)
        for k, (link_index, index, rgba) in enumerate(self._shapes):
            hidden = None in links or link_index in links
            if hidden != self._hidden[k]:
                colour = (*rgba[:3], 0.0) if hidden else rgba
                pybullet.changeVisualShape(
                    self._body, link_index, shapeIndex=index, rgbaColor=colour, physicsClientId=self._cid
                )
                self._hidden[k] = hidden


class _SensorSetting:
    """One field of a sensor's :class:`SensorConfig` (``dropout``, ``latency_s``) changed while a disturbance is on."""

    def __init__(self, sensor: Sensor, field: str):
        self._sensor = sensor
        self._field = field
        self._baseline: Any = getattr(sensor.config, field)

    def apply(self, values: list[Any]) -> None:
        """Set the largest value of the disturbances on (the sensor's own value when none is)."""
        value = max(values) if values else self._baseline
        self._sensor.config = self._sensor.config.with_overrides({self._field: value})


@dataclass
class _Effect:
    label: str  # e.g. "occlusion uav/tag_bundle"
    target: _HiddenVisuals | _SensorSetting
    value: Any
    windows: Iterator[tuple[float, float]]
    begin_step: int = 0
    end_step: int = 0  # the current window is [begin_step, end_step); 0: none drawn yet


# --------------------------------------------------------------- schedule
class DisturbanceSchedule:
    """Switches a world's windowed disturbances on and off as simulated time passes.

    One per world (:meth:`of`), advanced by the world as an actor. Windows are
    rounded to whole physics steps and take effect after the physics step
    that reaches them, so whatever reads the world at ``world.now`` sees the
    disturbances of that instant. Several disturbances on one target combine:
    a link is hidden while any occlusion is on; a sensor takes the largest
    drop probability or latency that is on. Kidnaps happen once each, at the
    step their time rounds to; :attr:`kidnapped` lists those done.
    """

    _of_world: weakref.WeakKeyDictionary[World, DisturbanceSchedule] = weakref.WeakKeyDictionary()

    def __init__(self, world: World):
        self._world = weakref.ref(world)  # the world owns its schedule (as an actor), not the reverse
        self._clock = world.clock
        self._effects: list[_Effect] = []
        self._targets: dict[tuple[Any, ...], _HiddenVisuals | _SensorSetting] = {}
        self._applied: dict[int, list[Any]] = {}  # id(target) -> values last applied
        self._kidnaps: list[Kidnap] = []  # pending, in time order
        self._kidnaps_of: dict[str, int] = {}  # robot -> kidnaps added (each draws its own seeded stream)
        self.kidnapped: list[tuple[float, str, tuple[float, ...]]] = []  # (time s, robot, pose) of those done
        self.aperture_fit: ApertureFit | None = None  # the tight aperture of an ``aperture_fit`` entry (truth)
        self._next_step = _NEVER
        world.add_actor(self)

    @classmethod
    def of(cls, world: World) -> DisturbanceSchedule:
        """The schedule of ``world`` (created and registered as an actor on first use)."""
        schedule = cls._of_world.get(world)
        if schedule is None:
            schedule = cls._of_world[world] = cls(world)
        return schedule

    # ------------------------------------------------------------ adding
    def occlude(self, robot: Robot, link: str | None = None, when: When = When()) -> None:
        """Hide ``robot``'s ``link`` (its whole body if ``None``) from every camera during ``when``."""
        key = ("occlusion", robot.body_id)
        visuals = self._targets.get(key)
        if not isinstance(visuals, _HiddenVisuals):
            visuals = self._targets[key] = _HiddenVisuals(robot)
        link_index = None if link is None else robot.link_index(link)
        label = f"occlusion {robot.name}" + (f"/{link}" if link else "")
        if not visuals.has_visuals(link_index):
            raise WorldError(f"{label}: nothing to hide, {robot.name} has no visual shape there")
        self._add(label, key, link_index, when)

    def drop_frames(self, sensor: Sensor, probability: float, when: When = When()) -> None:
        """Drop each due sample of ``sensor`` with ``probability`` in [0, 1] during ``when``.

        The draws come from the sensor's own seeded stream; ``probability=1``
        is a black-out (readers keep getting the last sample delivered).
        """
        if not 0.0 <= probability <= 1.0:
            raise ValueError(f"probability must be within [0, 1], got {probability}")
        self._add_sensor_effect(sensor, "dropout", "frame_drops", probability, when)

    def delay(self, sensor: Sensor, seconds: float, when: When = When()) -> None:
        """Deliver ``sensor``'s samples ``seconds`` late (relayed video) during ``when``."""
        if seconds < 0:
            raise ValueError(f"latency must be >= 0 s, got {seconds}")
        self._add_sensor_effect(sensor, "latency_s", "video_latency", seconds, when)

    def kidnap(
        self, robot: Robot, at: float, pose: Sequence[float], spread: Sequence[float] = (0.0, 0.0, 0.0)
    ) -> tuple[float, ...]:
        """Move ``robot`` to ``pose`` (``[x, y, yaw]`` or ``[x, y, z, yaw]``, m, rad) at time ``at`` (s).

        ``spread`` ``[dx, dy, dyaw]`` (m, m, rad) adds a seeded uniform offset
        within ± each to x, y and yaw. Returns the pose that will be applied.
        """
        if len(pose) not in (3, 4) or len(spread) != 3:
            raise ValueError(f"pose is [x, y, yaw] or [x, y, z, yaw] and spread [dx, dy, dyaw]; got {pose}, {spread}")
        if not at >= 0 or min(spread) < 0:
            raise ValueError(f"kidnap time must be >= 0 s and spread >= 0, got at={at}, spread={spread}")
        world = self._world()
        assert world is not None, "the world owns this schedule: it outlives it"
        label = f"kidnap {robot.name}"
        index = self._kidnaps_of[robot.name] = self._kidnaps_of.get(robot.name, -1) + 1
        target = spread_pose(pose, spread, world.rng_for(f"disturbance/{label}/{index}"))
        self._kidnaps.append(Kidnap(robot, self._clock.steps_for(at), target))
        self._kidnaps.sort(key=lambda k: k.step)
        self.update()
        return target

    def _add_sensor_effect(self, sensor: Sensor, field: str, what: str, value: float, when: When) -> None:
        key = (what, id(sensor))
        if key not in self._targets:
            self._targets[key] = _SensorSetting(sensor, field)
        self._add(f"{what} {sensor.name}", key, value, when)

    def _add(self, label: str, key: tuple[Any, ...], value: Any, when: When) -> None:
        world = self._world()
        assert world is not None, "the world owns this schedule: it outlives it"
        rng = world.rng_for(f"disturbance/{label}/{sum(e.label == label for e in self._effects)}")
        self._effects.append(_Effect(label, self._targets[key], value, when.windows(rng)))
        self.update()

    # ----------------------------------------------------------- queries
    def active(self) -> list[str]:
        """Labels of the disturbances on now, e.g. ``["occlusion uav/tag_bundle"]`` (for logs)."""
        steps = self._clock.steps
        return sorted({e.label for e in self._effects if e.begin_step <= steps < e.end_step})

    # ---------------------------------------------------------- stepping
    def pre_physics(self, dt: float) -> None:
        """Nothing before the physics step: changes apply once the clock has advanced."""

    def post_physics(self, dt: float) -> None:
        """Apply the changes due at the step just reached (one integer comparison otherwise)."""
        if self._clock.steps >= self._next_step:
            self.update()

    def update(self) -> None:
        """Advance every window to the current step and apply the targets whose state changed."""
        steps = self._clock.steps
        while self._kidnaps and self._kidnaps[0].step <= steps:
            kidnap = self._kidnaps.pop(0)
            teleport(kidnap.robot, kidnap.pose)
            self.kidnapped.append((self._clock.now, kidnap.robot.name, kidnap.pose))
        values: dict[int, list[Any]] = {id(t): [] for t in self._targets.values()}
        next_step = self._kidnaps[0].step if self._kidnaps else _NEVER
        for effect in self._effects:
            while steps >= effect.end_step:
                window = next(effect.windows, None)
                if window is None:
                    effect.begin_step = effect.end_step = _NEVER
                    break
                effect.begin_step, effect.end_step = self._step_of(window[0]), self._step_of(window[1])
            if effect.begin_step <= steps:
                values[id(effect.target)].append(effect.value)
                next_step = min(next_step, effect.end_step)
            else:
                next_step = min(next_step, effect.begin_step)
        for target in self._targets.values():
            on = values[id(target)]
            if self._applied.get(id(target), []) != on:
                target.apply(on)
                self._applied[id(target)] = on
        self._next_step = next_step

    def _step_of(self, t: float) -> int:
        return _NEVER if math.isinf(t) else self._clock.steps_for(t)


# ------------------------------------------------------------ entry point
Installer = tuple[tuple[Any, ...], Callable[..., object], tuple[Any, ...]]
"""(key path of the entry, schedule method, its arguments after the schedule) of one windowed disturbance or kidnap."""


def apply_disturbances(world: World, disturbances: Disturbances | Mapping[str, Any]) -> DisturbanceSchedule:
    """Install a mission's ``world.disturbances`` (docs/world.md §7) in ``world``; returns its schedule.

    ``disturbances`` is the validated :class:`~marsupial.api.config.Disturbances`
    (a mapping is validated first: pydantic's ``ValidationError`` names the bad
    key). ``wind`` replaces ``world.wind`` with a :class:`GustyWind`; ``decoys``
    entries are cut into the scene's walls at once (entry ``i`` drawing from
    ``world.rng_for("disturbance/decoys/<i>")``); an ``aperture_fit`` entry
    rebuilds the aperture wall at once (drawing from
    ``world.rng_for("disturbance/aperture_fit")``; the schedule's
    ``aperture_fit`` holds what it made); the windowed entries and kidnaps go
    to the world's :class:`DisturbanceSchedule`. Names only a built world knows
    (robots, links, sensors, walls, aperture shapes) are resolved before
    anything changes, so a bad one leaves the world untouched: it raises
    :class:`UnknownNameError` (listing the known names) or :class:`WorldError`,
    whose ``at`` is the key path of the bad value under ``world.disturbances``
    (e.g. ``("occlusion", 1, "link")``).
    """
    spec = disturbances if isinstance(disturbances, Disturbances) else Disturbances.model_validate(disturbances)
    installers = _installers(world, spec)
    for i, decoy in enumerate(spec.decoys):
        with _at("decoys", i, "wall"):
            world.scene.object(decoy.wall)  # unknown wall: the error lists the objects
    if spec.aperture_fit is not None:
        with _at("aperture_fit", "shape"):
            check_shapes(world.scene, spec.aperture_fit.shapes)  # unknown shape: the error lists the apertures
    if spec.wind is not None:
        world.wind = GustyWind(world, spec.wind)
    made = _rebuild(world, spec)
    schedule = DisturbanceSchedule.of(world)
    if made is not None:
        schedule.aperture_fit = made
    for path, add, args in installers:
        with _at(*path):
            add(schedule, *args)
    return schedule


def _installers(world: World, spec: Disturbances) -> list[Installer]:
    """The windowed disturbances and kidnaps of ``spec``, their robots, links and sensors resolved in ``world``."""
    installers: list[Installer] = []
    for i, occlusion in enumerate(spec.occlusion):
        with _at("occlusion", i, "robot"):
            robot = world.robot(occlusion.robot)
        if occlusion.link is not None:
            with _at("occlusion", i, "link"):
                robot.link_index(occlusion.link)  # unknown link: the error lists the robot's links
        installers.append((("occlusion", i), DisturbanceSchedule.occlude, (robot, occlusion.link, When.of(occlusion))))
    for i, drops in enumerate(spec.frame_drops):
        with _at("frame_drops", i, "camera"):
            sensor = find_sensor(world, drops.camera)
        installers.append((("frame_drops", i), DisturbanceSchedule.drop_frames, (sensor, drops.probability,
                                                                                  When.of(drops))))
    for i, latency in enumerate(spec.video_latency):
        with _at("video_latency", i, "camera"):
            sensor = find_sensor(world, latency.camera)
        installers.append((("video_latency", i), DisturbanceSchedule.delay, (sensor, latency.seconds,
                                                                              When.of(latency))))
    for i, kidnap in enumerate(spec.kidnap):
        with _at("kidnap", i, "robot"):
            robot = world.robot(kidnap.robot)
        installers.append((("kidnap", i), DisturbanceSchedule.kidnap, (robot, kidnap.at, kidnap.pose, kidnap.spread)))
    return installers


def _rebuild(world: World, spec: Disturbances) -> ApertureFit | None:
    """Make the scene changes of ``spec`` (decoys, a tight aperture), each from its own seeded stream."""
    numbers: dict[str, int] = {}
    for index, decoy in enumerate(spec.decoys):
        with _at("decoys", index):
            cut_decoys(world, decoy, world.rng_for(f"disturbance/decoys/{index}"), numbers)
    if spec.aperture_fit is None:
        return None
    with _at("aperture_fit"):
        return fit_aperture(world, spec.aperture_fit, world.rng_for("disturbance/aperture_fit"))


@contextlib.contextmanager
def _at(*path: Any) -> Iterator[None]:
    """Prefix the key path ``at`` of a :class:`WorldError` raised inside with ``path`` (the entry being installed)."""
    try:
        yield
    except WorldError as err:
        err.at = path + err.at
        raise


def find_sensor(world: World, path: str) -> Sensor:
    """The sensor called ``"robot/sensor"`` (e.g. ``"carrier/eye_in_hand"``); errors list the known ones."""
    robot_name, slash, sensor_name = path.partition("/")
    if not slash or not sensor_name:
        raise WorldError(f"a camera is named 'robot/sensor' (e.g. 'carrier/eye_in_hand'), got '{path}'")
    robot = world.robot(robot_name)
    for key in (path, sensor_name):
        if key in robot.sensors:
            return robot.sensors[key]
    known = [k if "/" in k else f"{robot_name}/{k}" for k in robot.sensors]
    raise UnknownNameError(f"sensor of {robot_name}", path, known)
