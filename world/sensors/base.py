"""Sampling shared by all sensors: a rate, seeded noise, dropouts and latency.

A sensor samples lazily: :meth:`Sensor.read` measures only when a new
sample is due at the sensor's rate (so a camera nobody reads never
renders), applies its seeded dropout, and returns the newest sample that
is older than the configured latency. All times are simulated seconds.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from marsupial.api.readings import Reading

if TYPE_CHECKING:
    from ..world import World

T = TypeVar("T")


@dataclass(frozen=True)
class SensorConfig:
    """How a sensor samples; every field can be set from the mission.

    Attributes:
        rate_hz: samples per simulated second.
        noise_std: standard deviation of the additive Gaussian noise, in the
            sensor's own unit (m for ranges, m/s² for accelerations, 0-255
            intensity for images).
        dropout: probability in [0, 1] that a due sample is lost.
        latency_s: delay (s) before a sample becomes readable (e.g. relayed video).
    """

    rate_hz: float
    noise_std: float = 0.0
    dropout: float = 0.0
    latency_s: float = 0.0

    def __post_init__(self) -> None:
        if self.rate_hz <= 0:
            raise ValueError(f"rate_hz must be > 0, got {self.rate_hz}")
        if not 0.0 <= self.dropout <= 1.0:
            raise ValueError(f"dropout must be within [0, 1], got {self.dropout}")
        if self.noise_std < 0 or self.latency_s < 0:
            raise ValueError("noise_std and latency_s must be >= 0")

    def with_overrides(self, overrides: Mapping[str, Any] | None) -> SensorConfig:
        """A copy with the fields named in ``overrides`` replaced (unknown names are an error)."""
        if not overrides:
            return self
        unknown = set(overrides) - set(self.__dataclass_fields__)
        if unknown:
            raise ValueError(
                f"unknown sensor setting(s) {sorted(unknown)}; expected {sorted(self.__dataclass_fields__)}"
            )
        return SensorConfig(**{**self.__dict__, **overrides})

    def scaled(self, noise_scale: float) -> SensorConfig:
        """A copy with noise, dropout (capped at 1) and latency multiplied by ``noise_scale`` (the rate is kept).

        The world applies it to every sensor after the mission's overrides
        (:meth:`with_overrides`), so an override states the unscaled figure.
        """
        if noise_scale == 1.0:
            return self
        return SensorConfig(
            rate_hz=self.rate_hz,
            noise_std=self.noise_std * noise_scale,
            dropout=min(1.0, self.dropout * noise_scale),
            latency_s=self.latency_s * noise_scale,
        )


class NormalStream:
    """Standard normal draws of one generator, fetched in blocks: a draw costs a list slice, not a numpy call.

    For the per-sample noise of the sensors read at the autopilot rate (plain
    ``math`` paths); deterministic for a given generator.
    """

    __slots__ = ("_rng", "_block", "_buf", "_i")

    def __init__(self, rng: Any, block: int = 1024):
        self._rng = rng
        self._block = block
        self._buf: list[float] = []
        self._i = 0

    def take(self, n: int) -> list[float]:
        """The next ``n`` standard normal values."""
        i, j = self._i, self._i + n
        if j > len(self._buf):
            self._buf = self._rng.standard_normal(max(self._block, n)).tolist()
            i, j = 0, n
        self._i = j
        return self._buf[i:j]


class Sensor(Generic[T]):
    """Base of every sensor. Subclasses implement :meth:`measure` (noise-free or noisy).

    ``self.rng`` is the sensor's own stream from the world seed; use it for
    every random draw so runs stay reproducible. ``config`` is the sensor's
    nominal figure (datasheet value plus the mission's overrides);
    ``self.config`` is that figure scaled by ``world.noise_scale``
    (:meth:`SensorConfig.scaled`), and ``self.noise_scale`` is the factor a
    subclass applies to its own error figures (biases, drifts, quantisation).
    """

    def __init__(self, world: World, name: str, config: SensorConfig):
        self.world = world
        self.name = name
        self.nominal = config
        self.noise_scale = world.noise_scale
        self.config = config.scaled(world.noise_scale)
        self.rng = world.rng_for(f"sensor/{name}")
        self.normals = NormalStream(self.rng)
        self.enabled = True
        self._period_steps = max(1, world.clock.steps_for(1.0 / config.rate_hz))
        #: actual sampling period (s): whole physics steps
        self.period = self._period_steps * world.clock.dt
        self._next_due_step = 0
        self._pending: deque[Reading[T]] = deque()
        self._latest: Reading[T] | None = None
        self.samples_taken = 0
        self.samples_dropped = 0

    def measure(self) -> T:
        """Take one measurement of the current world state (called when a sample is due)."""
        raise NotImplementedError

    def read(self) -> Reading[T] | None:
        """The newest readable sample (may be held from an earlier step), or ``None`` if none yet.

        Compare ``reading.stamp`` with ``world.now`` to know its age.
        """
        clock = self.world.clock
        if self.enabled and clock.steps >= self._next_due_step:
            # one sample per read at most: a sensor read late samples the state it sees now
            self._next_due_step = clock.steps - clock.steps % self._period_steps + self._period_steps
            if self.config.dropout > 0 and self.rng.random() < self.config.dropout:
                self.samples_dropped += 1
            else:
                self.samples_taken += 1
                self._pending.append(Reading(clock.now, self.measure()))
        ready_before = clock.now - self.config.latency_s + 1e-9
        while self._pending and self._pending[0].stamp <= ready_before:
            self._latest = self._pending.popleft()
        return self._latest
