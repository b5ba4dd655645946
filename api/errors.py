"""Errors raised by the world for bad input (unknown names, missing files)."""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import Any


class WorldError(Exception):
    """Base class of every error the world raises for bad user input.

    ``at`` is the key path of the bad value within the configuration the world
    was given, where it is known (``("occlusion", 1, "link")`` under a mission's
    ``world.disturbances``); ``()`` otherwise.
    """

    at: tuple[Any, ...] = ()


class UnknownNameError(WorldError, KeyError):
    """A scene, robot, asset or sensor name that is not known.

    The message lists the known names and the closest match, so a typo in a
    mission is fixed from the error alone.
    """

    def __init__(self, kind: str, name: str, known: Iterable[str]):
        self.kind = kind
        self.name = name
        self.known = sorted(known)
        close = difflib.get_close_matches(name, self.known, n=1)
        hint = f" Did you mean '{close[0]}'?" if close else ""
        super().__init__(
            f"unknown {kind} '{name}'.{hint} Known: {', '.join(self.known) or '(none)'}"
        )

    def __str__(self) -> str:  # KeyError would quote the message
        return self.args[0]
