"""The team link: what robots tell each other over the radio, late and sometimes not at all.

Every team member's onboard estimate is broadcast as ``estimate`` telemetry
at :attr:`TeamLinkConfig.telemetry_hz`; skills may send their own messages
(image features, requests) with :meth:`TeamLink.send`. A message is
delivered ``latency_s`` (plus a seeded jitter) after it was sent, or lost
with probability ``drop``; a receiver sees the newest delivered message of
each sender and topic (:meth:`TeamLink.latest`), and of each topic whoever
sent it (:meth:`TeamLink.latest_on`: what a robot's firmware listening on a
topic hears, e.g. the vision fixes of a UAV). A robot's firmware may also
act on a topic as its messages arrive (:meth:`TeamLink.listen`: the commands
another member's computer sends it). A reliable message (acknowledged and
retried) is lost only after ``max_retries`` retries: each loss delays it by
a retry timeout, and its topic's messages arrive in the order sent. Simulated time throughout.

Default figures (scaled by ``world.sensing.noise_scale``): 802.11 telemetry
between robots a few metres apart, 20 ms one-way latency with 10 ms jitter
and 2 % loss, the order reported for ROS-over-Wi-Fi multi-robot links (see
the sources table in ``docs/world.md``).
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from marsupial.api.readings import LinkMessage

if TYPE_CHECKING:
    from .world import World


@dataclass(frozen=True)
class TeamLinkConfig:
    """Latency (s), its jitter (s, standard deviation), loss probability and estimate telemetry rate (Hz)."""

    latency_s: float = 0.02
    jitter_s: float = 0.01
    drop: float = 0.02
    telemetry_hz: float = 20.0
    #: seconds a reliable message's sender waits for the acknowledgement before it sends the message again, and
    #: how often it does so before it gives up (Parrot ARSDK's acknowledged command buffer for the Bebop: 500 ms, 3)
    retry_s: float = 0.5
    max_retries: int = 3

    def __post_init__(self) -> None:
        if (self.latency_s < 0 or self.jitter_s < 0 or not 0.0 <= self.drop <= 1.0 or self.telemetry_hz <= 0
                or self.retry_s <= 0 or self.max_retries < 0):
            raise ValueError(
                "team link needs latency_s >= 0, jitter_s >= 0, 0 <= drop <= 1, telemetry_hz > 0, retry_s > 0 and "
                f"max_retries >= 0; got {self.latency_s}, {self.jitter_s}, {self.drop}, {self.telemetry_hz}, "
                f"{self.retry_s}, {self.max_retries}"
            )

    def scaled(self, noise_scale: float) -> TeamLinkConfig:
        """This link with latency, jitter and loss multiplied by ``noise_scale`` (loss capped at 1)."""
        return TeamLinkConfig(
            self.latency_s * noise_scale,
            self.jitter_s * noise_scale,
            min(1.0, self.drop * noise_scale),
            self.telemetry_hz,
            self.retry_s,
            self.max_retries,
        )


class TeamLink:
    """The radio shared by one world's team (an actor: it delivers due messages every physics step)."""

    def __init__(self, world: World, config: TeamLinkConfig | None = None):
        self.world = world
        self.config = config or TeamLinkConfig()
        self.rng = world.rng_for("team_link")
        self._queue: list[tuple[int, int, LinkMessage]] = []
        self._order = itertools.count()
        self._latest: dict[tuple[str, str], LinkMessage] = {}
        self._latest_on: dict[str, LinkMessage] = {}
        self._telemetry_period = max(1, world.clock.steps_for(1.0 / self.config.telemetry_hz))
        self.sent = 0
        self.dropped = 0
        self._delivered: list[LinkMessage] = []
        self._listeners: dict[str, Callable[[Any], None]] = {}
        self._last_reliable: dict[tuple[str, str], int] = {}
        #: reliable messages sent again after a loss
        self.retried = 0

    def send(self, sender: str, topic: str, payload: Any, reliable: bool = False) -> None:
        """Broadcast ``payload`` from ``sender`` on ``topic`` now; it arrives later or is lost.

        ``reliable``: a loss costs a retry timeout instead of the message, up to ``max_retries`` losses (the
        retries are counted in :attr:`retried`); it arrives after those of its sender and topic sent before it.
        """
        cfg, clock = self.config, self.world.clock
        self.sent += 1
        retries = 0
        while cfg.drop > 0 and self.rng.random() < cfg.drop:
            if not reliable or retries >= cfg.max_retries:
                self.dropped += 1
                return
            retries += 1
        self.retried += retries
        delay = retries * cfg.retry_s + cfg.latency_s
        delay += abs(float(self.rng.normal(0.0, cfg.jitter_s))) if cfg.jitter_s > 0 else 0.0
        due = clock.steps + clock.steps_for(delay)
        if reliable:
            due = self._last_reliable[(sender, topic)] = max(due, self._last_reliable.get((sender, topic), due))
        message = LinkMessage(sender, topic, clock.now, due * clock.dt, payload)
        heapq.heappush(self._queue, (due, next(self._order), message))

    def listen(self, topic: str, act: Callable[[Any], None]) -> None:
        """Call ``act(payload)`` with each message on ``topic`` as it arrives (a late older one is not acted on)."""
        self._listeners[topic] = act

    def latest(self, sender: str, topic: str) -> LinkMessage | None:
        """The newest message delivered so far from ``sender`` on ``topic`` (``None``: nothing yet)."""
        return self._latest.get((sender, topic))

    def take_delivered(self) -> tuple[LinkMessage, ...]:
        """The messages delivered since the last call (each the newest of its sender and topic then), in order."""
        delivered, self._delivered = tuple(self._delivered), []
        return delivered

    def latest_on(self, topic: str) -> LinkMessage | None:
        """The newest message delivered so far on ``topic`` from any sender (``None``: nothing yet)."""
        return self._latest_on.get(topic)

    # ------------------------------------------------------------ stepping
    def pre_physics(self, dt: float) -> None:
        """Nothing before physics."""

    def post_physics(self, dt: float) -> None:
        """Deliver the messages that are due; broadcast every robot's estimate at the telemetry rate."""
        steps = self.world.clock.steps
        queue = self._queue
        while queue and queue[0][0] <= steps:
            message = heapq.heappop(queue)[2]
            key = (message.sender, message.topic)
            known = self._latest.get(key)
            if known is None or known.sent <= message.sent:  # a late older message does not replace a newer one
                self._latest[key] = message
                act = self._listeners.get(message.topic)
                if act is None:
                    self._delivered.append(message)
                else:  # a robot's firmware acts on it (another member's command): no node hears it
                    act(message.payload)
            known = self._latest_on.get(message.topic)
            if known is None or known.sent <= message.sent:
                self._latest_on[message.topic] = message
        if steps % self._telemetry_period == 0:
            for name, robot in self.world.robots.items():
                estimator = getattr(robot, "estimator", None)  # a rig without an onboard computer sends nothing
                if estimator is not None:
                    self.send(name, "estimate", estimator.estimate())

