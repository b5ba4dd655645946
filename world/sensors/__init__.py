"""Sensors of the world: each samples at its own rate with seeded noise, dropout and latency."""

from .base import Reading, Sensor, SensorConfig

__all__ = ["Reading", "Sensor", "SensorConfig"]
