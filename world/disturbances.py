"""Disturbances of a run: gusty wind, marker occlusion, camera frame drops, video latency and kidnapping.

A mission's ``world:`` section lists them and :func:`apply_disturbances`
installs them::

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
``duration`` s. Every random draw comes from ``world.rng_for("disturbance/…")``,
so a run is reproducible for its seed and adding one disturbance does not
change what another draws.
"""

from __future__ import annotations

import bisect
import math
import sys
import weakref
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from marsupial.api.errors import UnknownNameError, WorldError

from .aperture_fit import CLEARANCE_MAX_M, ApertureFit, ApertureFitSpec, check_shapes, fit_aperture
from .decoys import DecoySpec, cut_decoys
from .kidnap import Kidnap, spread_pose, teleport

if TYPE_CHECKING:
    from .robots.base import Robot
    from .sensors.base import Sensor
    from .world import World

DISTURBANCE_KEYS = ("wind", "occlusion", "frame_drops", "video_latency", "kidnap", "decoys", "aperture_fit")
"""Keys of a mission's ``world:`` section that :func:`apply_disturbances` handles."""

_NEVER = sys.maxsize  # physics step of a change that never comes


# ------------------------------------------------------------------- wind
class GustyWind:
    """Air velocity (m/s, world frame): a steady wind plus a seeded train of discrete gusts.

    Each gust blows for ``gust_period_s`` = T along a random direction ``d``
    (azimuth uniform, elevation uniform within ±``gust_elevation_deg``) with
    the "1 − cosine" discrete-gust profile of MIL-F-8785C

        v_gust(τ) = A · (1 − cos(2π τ / T)) / 2 · d,   0 ≤ τ ≤ T,

    which peaks at exactly ``A = gust`` (m/s) at τ = T / 2. Calm spells
    between gusts are exponential with mean ``gust_gap_s`` (default T), so
    gusts never overlap. The field is uniform in space (robots of a mission
    fly within metres of each other, inside one gust) and a pure function of
    simulated time and the world seed: the gust train is drawn lazily, in time
    order, from ``world.rng_for("disturbance/wind")``, so every query pattern
    sees the same wind. Quadrotors read it each physics step through
    ``world.wind.velocity(t, position)``; a call costs a few microseconds.
    """

    def __init__(
        self,
        world: World,
        steady: Sequence[float] = (0.0, 0.0, 0.0),
        gust: float = 0.0,
        gust_period_s: float = 2.0,
        gust_gap_s: float | None = None,
        gust_elevation_deg: float = 10.0,
    ):
        self.steady = np.array(steady, dtype=float).reshape(3)
        self._steady = tuple(float(v) for v in self.steady)
        self.gust_amplitude = float(gust)
        self.gust_period_s = float(gust_period_s)
        self.gust_gap_s = self.gust_period_s if gust_gap_s is None else float(gust_gap_s)
        self._max_elevation = math.radians(gust_elevation_deg)
        if self.gust_amplitude < 0 or self.gust_period_s <= 0 or self.gust_gap_s <= 0:
            raise ValueError("gust must be >= 0 m/s; gust_period_s and gust_gap_s must be > 0 s")
        self._rng = world.rng_for("disturbance/wind")
        self._starts: list[float] = []  # start time (s) of each gust drawn so far
        self._directions: list[tuple[float, float, float]] = []  # unit vector (world frame) of each gust
        self._drawn_until = 0.0  # end (s) of the last gust drawn

    def velocity(self, t: float, position: np.ndarray) -> np.ndarray:
        """Air velocity (m/s, world frame) at simulated time ``t`` (s); uniform in ``position``."""
        speed, i = self._gust_at(t)
        if speed == 0.0:
            return self.steady.copy()
        (sx, sy, sz), (dx, dy, dz) = self._steady, self._directions[i]
        return np.array((sx + speed * dx, sy + speed * dy, sz + speed * dz))

    def gust(self, t: float) -> np.ndarray:
        """The gust part of the wind (m/s, world frame) at time ``t`` (s): zero between gusts."""
        speed, i = self._gust_at(t)
        return speed * np.array(self._directions[i]) if speed > 0.0 else np.zeros(3)

    def _gust_at(self, t: float) -> tuple[float, int]:
        """Gust speed (m/s) at ``t`` and the index of the gust blowing (meaningless when the speed is 0)."""
        if self.gust_amplitude == 0.0 or t < 0.0:
            return 0.0, 0
        while self._drawn_until <= t:
            self._draw_next_gust()
        i = bisect.bisect_right(self._starts, t) - 1
        tau = t - self._starts[i] if i >= 0 else self.gust_period_s
        if tau >= self.gust_period_s:
            return 0.0, 0
        return 0.5 * self.gust_amplitude * (1.0 - math.cos(2.0 * math.pi * tau / self.gust_period_s)), i

    def _draw_next_gust(self) -> None:
        start = self._drawn_until + self._rng.exponential(self.gust_gap_s)
        azimuth = self._rng.uniform(0.0, 2.0 * math.pi)
        elevation = self._rng.uniform(-self._max_elevation, self._max_elevation)
        self._starts.append(start)
        self._directions.append(
            (math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth), math.sin(elevation))
        )
        self._drawn_until = start + self.gust_period_s


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
def apply_disturbances(world: World, spec: dict[str, Any], where: str = "world") -> DisturbanceSchedule:
    """Install the disturbances of a mission's ``world:`` section (keys :data:`DISTURBANCE_KEYS`).

    ``wind`` replaces ``world.wind`` with a :class:`GustyWind`; ``kidnap``
    entries (``robot``, ``at`` s, ``pose``, optional ``spread``) are
    :meth:`DisturbanceSchedule.kidnap` calls; ``decoys`` entries are cut into the scene's walls at once
    (:func:`~.decoys.cut_decoys`, entry ``i`` drawing from ``world.rng_for("disturbance/decoys/<i>")``); an
    ``aperture_fit`` entry rebuilds the aperture wall at once (:func:`~.aperture_fit.fit_aperture`, drawing from
    ``world.rng_for("disturbance/aperture_fit")``; the schedule's ``aperture_fit`` holds what it made); the
    other keys (one entry or a list of entries) go to the world's
    :class:`DisturbanceSchedule`, which is returned. Bad input raises
    :class:`WorldError` naming the entry (``where`` prefixes the path, e.g.
    ``world.occlusion[1].start``), the unknown keys or the expected type;
    unknown robots, links and cameras raise :class:`UnknownNameError`.
    """
    _check_keys(where, spec, DISTURBANCE_KEYS)
    # validate everything first: a bad entry leaves the world untouched
    wind = _wind(world, f"{where}.wind", spec["wind"]) if "wind" in spec else None
    effects: list[tuple[Callable[..., object], tuple[Any, ...]]] = []
    for i, entry in _entries(where, "occlusion", spec):
        path = f"{where}.occlusion{i}"
        _check_keys(path, entry, ("robot", "link", *_WHEN_KEYS), required=("robot",))
        robot = world.robot(_text(path, "robot", entry["robot"]))
        link = _text(path, "link", entry["link"]) if "link" in entry else None
        if link is not None:
            robot.link_index(link)  # unknown link: the error lists the robot's links
        effects.append((DisturbanceSchedule.occlude, (robot, link, _when(path, entry))))
    for i, entry in _entries(where, "frame_drops", spec):
        path = f"{where}.frame_drops{i}"
        _check_keys(path, entry, ("camera", "probability", *_WHEN_KEYS), required=("camera", "probability"))
        sensor = find_sensor(world, _text(path, "camera", entry["camera"]))
        probability = _number(path, "probability", entry["probability"], 0.0, 1.0)
        effects.append((DisturbanceSchedule.drop_frames, (sensor, probability, _when(path, entry))))
    for i, entry in _entries(where, "video_latency", spec):
        path = f"{where}.video_latency{i}"
        _check_keys(path, entry, ("camera", "seconds", *_WHEN_KEYS), required=("camera", "seconds"))
        sensor = find_sensor(world, _text(path, "camera", entry["camera"]))
        seconds = _number(path, "seconds", entry["seconds"], 0.0)
        effects.append((DisturbanceSchedule.delay, (sensor, seconds, _when(path, entry))))
    for i, entry in _entries(where, "kidnap", spec):
        path = f"{where}.kidnap{i}"
        _check_keys(path, entry, ("robot", "at", "pose", "spread"), required=("robot", "at", "pose"))
        robot = world.robot(_text(path, "robot", entry["robot"]))
        at = _number(path, "at", entry["at"], 0.0)
        pose = _numbers(path, "pose", entry["pose"], (3, 4), "[x, y, yaw] or [x, y, z, yaw] (m, rad, world frame)")
        spread = _numbers(path, "spread", entry.get("spread", [0.0, 0.0, 0.0]), (3,), "[dx, dy, dyaw] (m, rad)", 0.0)
        effects.append((DisturbanceSchedule.kidnap, (robot, at, pose, spread)))
    decoys, fit = _geometry(world, where, spec)
    if wind is not None:
        world.wind = wind
    made = _rebuild(world, decoys, fit)
    schedule = DisturbanceSchedule.of(world)
    if made is not None:
        schedule.aperture_fit = made
    for add, args in effects:
        add(schedule, *args)
    return schedule


def _geometry(world: World, where: str, spec: dict[str, Any]) -> tuple[list[DecoySpec], ApertureFitSpec | None]:
    """The scene changes of ``spec``, checked: its ``decoys`` entries and its ``aperture_fit`` entry (not both)."""
    decoys = [_decoys(world, f"{where}.decoys{i}", entry) for i, entry in _entries(where, "decoys", spec)]
    fit = _aperture_fit(world, f"{where}.aperture_fit", spec["aperture_fit"]) if "aperture_fit" in spec else None
    if fit is not None and decoys:
        raise WorldError(f"{where}: aperture_fit rebuilds the whole aperture wall, decoys cut into one of its boxes: "
                         "give one or the other")
    return decoys, fit


def _rebuild(world: World, decoys: list[DecoySpec], fit: ApertureFitSpec | None) -> ApertureFit | None:
    """Make the checked scene changes (:func:`_geometry`), each from its own seeded stream; the tight aperture."""
    numbers: dict[str, int] = {}
    for index, decoy_spec in enumerate(decoys):
        cut_decoys(world, decoy_spec, world.rng_for(f"disturbance/decoys/{index}"), numbers)
    return fit_aperture(world, fit, world.rng_for("disturbance/aperture_fit")) if fit is not None else None


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


# ------------------------------------------------------------- validation
_WHEN_KEYS = ("start", "duration", "rate_hz", "stop")
_WIND_KEYS = ("steady", "gust", "gust_period_s", "gust_gap_s", "gust_elevation_deg")


def _check_keys(where: str, spec: Any, allowed: Sequence[str], required: Sequence[str] = ()) -> None:
    if not isinstance(spec, dict):
        raise WorldError(f"{where}: expected a mapping with keys {list(allowed)}, got {type(spec).__name__} {spec!r}")
    unknown = sorted(str(k) for k in spec if k not in allowed)
    if unknown:
        raise WorldError(f"{where}: unknown key(s) {unknown}; expected some of {list(allowed)}")
    missing = [k for k in required if k not in spec]
    if missing:
        raise WorldError(f"{where}: missing key(s) {missing}")


def _entries(where: str, key: str, spec: dict[str, Any]) -> Iterator[tuple[str, Any]]:
    """The entries under ``key`` (one mapping or a list) with their index suffix for messages."""
    value = spec.get(key)
    if value is None:
        return
    if isinstance(value, dict):
        yield "", value
    elif isinstance(value, list):
        for i, entry in enumerate(value):
            yield f"[{i}]", entry
    else:
        raise WorldError(
            f"{where}.{key}: expected a mapping or a list of mappings, got {type(value).__name__} {value!r}"
        )


def _number(where: str, key: str, value: Any, low: float | None = None, high: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise WorldError(f"{where}.{key}: expected a number, got {type(value).__name__} {value!r}")
    if (low is not None and value < low) or (high is not None and value > high) or math.isnan(value):
        bounds = f"within [{low}, {high}]" if high is not None else f">= {low}"
        raise WorldError(f"{where}.{key}: expected a number {bounds}, got {value}")
    return float(value)


def _numbers(
    where: str, key: str, value: Any, lengths: Sequence[int], what: str, low: float | None = None
) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) not in lengths:
        raise WorldError(f"{where}.{key}: expected {what}, got {value!r}")
    return [_number(where, f"{key}[{i}]", v, low) for i, v in enumerate(value)]


def _positive(where: str, key: str, value: Any) -> float:
    number = _number(where, key, value, 0.0)
    if number == 0.0:
        raise WorldError(f"{where}.{key}: expected a number > 0, got {value}")
    return number


def _text(where: str, key: str, value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise WorldError(f"{where}.{key}: expected a name (text), got {type(value).__name__} {value!r}")
    return value


def _when(where: str, entry: dict[str, Any]) -> When:
    start = _number(where, "start", entry.get("start", 0.0), 0.0)
    if "rate_hz" not in entry:
        if "stop" in entry:
            raise WorldError(f"{where}.stop: only random windows (with rate_hz) have a stop time; use duration")
        duration = _positive(where, "duration", entry["duration"]) if "duration" in entry else math.inf
        return When(start=start, duration=duration)
    if "duration" not in entry:
        raise WorldError(f"{where}: random windows (rate_hz) need a duration (s)")
    stop = _number(where, "stop", entry["stop"], start) if "stop" in entry else math.inf
    return When(
        start=start,
        duration=_positive(where, "duration", entry["duration"]),
        rate_hz=_positive(where, "rate_hz", entry["rate_hz"]),
        stop=stop,
    )


_DECOY_RANGES = ("recess_width", "recess_height", "recess_depth", "hole_size")


def _decoys(world: World, where: str, entry: Any) -> DecoySpec:
    """One ``decoys`` entry (:mod:`.decoys`), checked: the wall exists, counts are whole, ranges increasing."""
    _check_keys(where, entry, ("wall", "x", "z", "recesses", "holes", "gap", *_DECOY_RANGES),
                required=("wall", "x", "z"))
    world.scene.object(_text(where, "wall", entry["wall"]))  # unknown wall: the error lists the objects
    ranges: dict[str, tuple[float, float]] = {}
    for key in ("x", "z", *_DECOY_RANGES):
        if key in entry:
            low, high = _numbers(where, key, entry[key], (2,), "[low, high] in metres")
            if not low < high or (key != "x" and key != "z" and low <= 0):
                raise WorldError(f"{where}.{key}: expected [low, high] with low < high (and > 0 for sizes), "
                                 f"got {entry[key]!r}")
            ranges[key] = (low, high)
    counts = {}
    for key in ("recesses", "holes"):
        value = entry.get(key, 0)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise WorldError(f"{where}.{key}: expected a whole number >= 0, got {value!r}")
        counts[key] = value
    extra = {"gap": _number(where, "gap", entry["gap"], 0.0)} if "gap" in entry else {}
    return DecoySpec(entry["wall"], **ranges, **counts, **extra)  # type: ignore[arg-type]


def _aperture_fit(world: World, where: str, entry: Any) -> ApertureFitSpec:
    """The ``aperture_fit`` entry (:mod:`.aperture_fit`), checked: known shape classes, clearances in range."""
    _check_keys(where, entry, ("shape", "clearance"), required=("shape", "clearance"))
    shape = entry["shape"]
    shapes = [shape] if isinstance(shape, str) else shape
    if not isinstance(shapes, list) or not shapes or not all(isinstance(s, str) and s for s in shapes):
        raise WorldError(f"{where}.shape: expected a shape class (text) or a non-empty list of them, got {shape!r}")
    check_shapes(world.scene, shapes)  # unknown shape: the error lists the scene's apertures
    value = entry["clearance"]
    if isinstance(value, (list, tuple)):
        low, high = _numbers(where, "clearance", value, (2,), "[low, high] in metres")
    else:
        low = high = _number(where, "clearance", value)
    if not 0.0 < low <= high <= CLEARANCE_MAX_M:
        raise WorldError(f"{where}.clearance: expected a clearance in metres, or [low, high] with "
                         f"0 < low <= high <= {CLEARANCE_MAX_M}, got {value!r}")
    return ApertureFitSpec(tuple(shapes), (low, high))


def _wind(world: World, where: str, spec: Any) -> GustyWind:
    _check_keys(where, spec, _WIND_KEYS)
    steady = spec.get("steady", [0.0, 0.0, 0.0])
    if not isinstance(steady, (list, tuple)) or len(steady) != 3:
        raise WorldError(f"{where}.steady: expected [vx, vy, vz] in m/s (world frame), got {steady!r}")
    return GustyWind(
        world,
        steady=[_number(where, f"steady[{i}]", v) for i, v in enumerate(steady)],
        gust=_number(where, "gust", spec.get("gust", 0.0), 0.0),
        gust_period_s=_positive(where, "gust_period_s", spec.get("gust_period_s", 2.0)),
        gust_gap_s=_positive(where, "gust_gap_s", spec["gust_gap_s"]) if "gust_gap_s" in spec else None,
        gust_elevation_deg=_number(where, "gust_elevation_deg", spec.get("gust_elevation_deg", 10.0), 0.0, 90.0),
    )
