"""Sensors of the world: each samples at its own rate with seeded noise, dropout and latency."""

from marsupial.api.readings import Reading

from .base import Sensor, SensorConfig

__all__ = ["Reading", "Sensor", "SensorConfig"]
