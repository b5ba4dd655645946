"""Joint encoders of the arms: what the arm's computer reads of its joint angles.

A Dynamixel MX/X-series servo reads its angle with a 12-bit contactless
magnetic encoder: 4096 counts per turn, 0.088° per count (ROBOTIS e-Manual).
A reading is the true angle plus white noise (1σ ``noise_counts`` counts,
chosen: one count of jitter peak to peak), quantised to whole counts. The
count size and the noise scale with ``world.noise_scale`` (0: exact angles).
FK from these readings is the skills' job (pinocchio, :mod:`..kinematics`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..world import World


@dataclass(frozen=True)
class EncoderSpec:
    """Resolution (counts per revolution) and 1σ white noise (counts) of a joint encoder."""

    counts_per_rev: int = 4096
    noise_counts: float = 0.5


class JointEncoders:
    """Seeded encoder readings of an arm's joints (``name`` keys the noise stream)."""

    def __init__(self, world: World, name: str, spec: EncoderSpec = EncoderSpec()):
        self.spec = spec
        self.rng = world.rng_for(f"encoders/{name}")
        #: size of one count (rad) after ``noise_scale``; 0 means exact readings
        self.resolution = 2.0 * math.pi / spec.counts_per_rev * world.noise_scale
        self.noise_std = spec.noise_counts * self.resolution

    def read(self, q: np.ndarray) -> np.ndarray:
        """Encoder readings (rad) of the true joint angles ``q`` (rad)."""
        if self.resolution == 0.0:
            return np.array(q, dtype=float)
        noisy = q + self.rng.normal(0.0, self.noise_std, len(q))
        return np.round(noisy / self.resolution) * self.resolution
