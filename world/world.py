"""The simulated world of one run: a pybullet client, a simulated clock, seeded noise.

Everything in a run that moves or measures lives in one :class:`World`:
the scene's static geometry, the robots, their sensors and the disturbances.
Time only advances through :meth:`World.step`, in whole physics steps of
``1 / physics_hz`` seconds, so a run is deterministic for a given seed and
runs as fast as the machine allows. Nothing here reads the wall clock.

Frames: ``world`` is z-up, metres, radians; quaternions are ``[x, y, z, w]``
as pybullet returns them.
"""

from __future__ import annotations

import contextlib
import math
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import pybullet
from pybullet_utils.bullet_client import BulletClient

from marsupial.api.errors import UnknownNameError

from .quiet import quiet_fd
from .team_link import TeamLink, TeamLinkConfig

if TYPE_CHECKING:
    from .robots.base import Robot
    from .scene import Scene

GRAVITY = 9.81  # m/s^2
PHYSICS_HZ = 240  # fixed physics rate of every world


class Actor(Protocol):
    """Something the world advances every physics step (robots, disturbances).

    ``pre_physics`` runs before ``stepSimulation`` (apply forces, drive
    constraints); ``post_physics`` after it (integrate batteries, estimate
    accelerations). ``dt`` is the physics step in seconds.
    """

    def pre_physics(self, dt: float) -> None: ...

    def post_physics(self, dt: float) -> None: ...


@dataclass
class SimClock:
    """Simulated time of a world: a count of fixed physics steps.

    ``now`` is derived from the step count, never accumulated, so it carries
    no floating-point drift over long runs.
    """

    physics_hz: int = PHYSICS_HZ
    steps: int = 0

    @property
    def dt(self) -> float:
        """Physics step in seconds."""
        return 1.0 / self.physics_hz

    @property
    def now(self) -> float:
        """Simulated seconds since the world was created."""
        return self.steps / self.physics_hz

    def steps_for(self, seconds: float) -> int:
        """Number of whole physics steps closest to ``seconds`` (at least 0)."""
        return max(0, int(round(seconds * self.physics_hz)))


@dataclass
class _Wind:
    """No wind: the default air-velocity field (m/s, world frame)."""

    def velocity(self, t: float, position: np.ndarray) -> np.ndarray:
        return np.zeros(3)


class World:
    """One run's pybullet world: scene, robots, sensors, clock and seeded noise.

    Several worlds may exist in one process: each owns its own pybullet
    client (``client_id``), and every call made on its behalf passes that id.

    Args:
        scene: name of a scene under ``world/scenes/`` (``None``: a bare floor).
        seed: seed of every random draw in the run (noise, gusts, drops).
        gui: open the pybullet GUI instead of the headless DIRECT client.
        physics_hz: fixed physics rate in Hz (240 unless a test needs otherwise).
        noise_scale: multiplies every sensing noise, bias, drift, latency and loss figure
            (``world.sensing.noise_scale`` of a mission; 0: perfect sensing, for debugging only).
        team_link: latency, loss and telemetry rate of the team's radio (:mod:`.team_link`).
    """

    def __init__(
        self,
        scene: str | None = None,
        seed: int = 0,
        gui: bool = False,
        physics_hz: int = PHYSICS_HZ,
        noise_scale: float = 1.0,
        team_link: TeamLinkConfig | None = None,
    ):
        self.seed = int(seed)
        self.clock = SimClock(physics_hz=physics_hz)
        with quiet_fd(1):  # pybullet's C code prints "argv[0]=" on every connect
            self.bullet = BulletClient(connection_mode=pybullet.GUI if gui else pybullet.DIRECT)
        self.client_id: int = self.bullet._client
        self.rng = np.random.default_rng(self.seed)
        self.wind: Any = _Wind()
        self.robots: dict[str, Robot] = {}
        self._actors: list[Actor] = []
        self._step_hooks: list[Callable[[float], None]] = []
        self._closed = False
        if not (noise_scale >= 0.0 and math.isfinite(noise_scale)):
            raise ValueError(f"noise_scale must be a finite number >= 0, got {noise_scale}")
        #: multiplies every sensor noise, bias, drift, latency and loss figure (0: perfect sensing, for debugging)
        self.noise_scale = float(noise_scale)
        self.team_link = TeamLink(self, (team_link or TeamLinkConfig()).scaled(self.noise_scale))
        self._actors.append(self.team_link)

        b = self.bullet
        b.resetSimulation()
        b.setGravity(0.0, 0.0, -GRAVITY)
        b.setPhysicsEngineParameter(fixedTimeStep=self.clock.dt, numSubSteps=0, deterministicOverlappingPairs=1)
        if gui:
            b.configureDebugVisualizer(pybullet.COV_ENABLE_GUI, 0)

        from .priors import building_plan
        from .scene import load_scene

        self.scene: Scene = load_scene(self, scene)
        #: what an operator can hand the robots of the scene as loaded from its file, before any disturbance
        self.plan = building_plan(self.scene)

    # ----------------------------------------------------------------- time
    @property
    def now(self) -> float:
        """Simulated seconds since the world was created."""
        return self.clock.now

    def step(self, seconds: float | None = None) -> None:
        """Advance the world by ``seconds`` of simulated time (one physics step if ``None``).

        Each physics step runs every actor's ``pre_physics``, steps pybullet,
        then runs every actor's ``post_physics`` and the step hooks.
        """
        n = 1 if seconds is None else self.clock.steps_for(seconds)
        dt = self.clock.dt
        step_simulation = pybullet.stepSimulation
        cid = self.client_id
        for _ in range(n):
            for actor in self._actors:
                actor.pre_physics(dt)
            step_simulation(physicsClientId=cid)
            self.clock.steps += 1
            for actor in self._actors:
                actor.post_physics(dt)
            for hook in self._step_hooks:
                hook(dt)

    # ----------------------------------------------------------- randomness
    def rng_for(self, key: str) -> np.random.Generator:
        """A random generator for one noise source, derived from the world seed and ``key``.

        Each sensor or disturbance draws from its own stream, so adding one
        does not change what the others draw: a run is reproducible piece by piece.
        """
        return np.random.default_rng([self.seed, zlib.crc32(key.encode())])

    # ---------------------------------------------------------------- actors
    def add_actor(self, actor: Actor) -> None:
        """Advance ``actor`` with every physics step from now on."""
        self._actors.append(actor)

    def remove_actor(self, actor: Actor) -> None:
        """Stop advancing ``actor``."""
        self._actors.remove(actor)

    def add_step_hook(self, hook: Callable[[float], None]) -> None:
        """Call ``hook(dt)`` after every physics step (e.g. a recorder sampling poses)."""
        self._step_hooks.append(hook)

    # ---------------------------------------------------------------- robots
    def add_robot(self, kind: str, name: str | None = None, **options: Any) -> Robot:
        """Create a robot of ``kind`` (e.g. ``"bebop2"``) named ``name`` (default: the kind).

        ``options`` go to the robot's constructor (``pose``, sensor settings, …).
        Raises :class:`UnknownNameError` (listing the kinds) for an unknown kind and
        :class:`ValueError` for a name already in the world.
        """
        from .robots import robot_class

        cls = robot_class(kind)
        name = name or kind
        if name in self.robots:
            raise ValueError(f"a robot named '{name}' already exists in this world")
        robot = cls(self, name, **options)
        self.robots[name] = robot
        self.add_actor(robot)
        return robot

    def robot(self, name: str) -> Robot:
        """The robot called ``name``; the error lists the robots in the world."""
        try:
            return self.robots[name]
        except KeyError:
            raise UnknownNameError("robot", name, self.robots) from None

    # -------------------------------------------------------------- teardown
    def close(self) -> None:
        """Disconnect the pybullet client. Safe to call twice."""
        if not self._closed:
            self._closed = True
            self.bullet.disconnect()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:  # a forgotten world must not leak its client
        with contextlib.suppress(Exception):
            self.close()
