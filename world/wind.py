"""Gusty wind: a steady air velocity plus a seeded train of discrete gusts (a mission's ``world.disturbances.wind``).

:func:`~marsupial.world.disturbances.apply_disturbances` installs it as
``world.wind``; quadrotors feel it through their drag on the air-relative
velocity.
"""

from __future__ import annotations

import bisect
import math
from typing import TYPE_CHECKING

import numpy as np

from marsupial.api.config import WindConfig

if TYPE_CHECKING:
    from .world import World


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
    ``config`` gives the figures (:class:`~marsupial.api.config.WindConfig`, validated).
    """

    def __init__(self, world: World, config: WindConfig):
        self.steady = np.array(config.steady, dtype=float).reshape(3)
        self._steady = tuple(float(v) for v in self.steady)
        self.gust_amplitude = config.gust
        self.gust_period_s = config.gust_period_s
        self.gust_gap_s = self.gust_period_s if config.gust_gap_s is None else config.gust_gap_s
        self._max_elevation = math.radians(config.gust_elevation_deg)
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
