"""Pluggable parts of the scout: depth estimators and object detectors, by entry-point name or import target.

A scout mission names its depth estimator and its object detector
(``depth_estimator: monocular_error_model``, ``detector: hsv_colour``). A name
is looked up in the entry-point group of its kind (:data:`DEPTH_GROUP`,
:data:`DETECTOR_GROUP`; marsupial registers its own in ``pyproject.toml``,
other distributions add theirs the same way), or given directly as an import
target ``"package.module:Class"``. Each plug-in class has an ``Options``
pydantic model: the mission's ``depth_options`` / ``detector_options`` are
validated against it when the mission is compiled.
"""

from __future__ import annotations

from functools import cache
from importlib.metadata import entry_points
from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict

from marsupial.trees.errors import MissionError
from marsupial.trees.registry import import_target

DEPTH_GROUP = "marsupial.scout.depth_estimators"
"""Entry-point group of the depth estimators (subclasses of :class:`~.depth.DepthEstimator`)."""
DETECTOR_GROUP = "marsupial.scout.detectors"
"""Entry-point group of the object detectors (subclasses of :class:`~.detection.ObjectDetector`)."""


class PluginOptions(BaseModel):
    """Base of a plug-in's ``Options``: unknown keys are errors, attribute docstrings are the docs."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, frozen=True, allow_inf_nan=False)


class Plugin:
    """Base of the scout's plug-ins: an ``Options`` model and what kind of plug-in it is (for error messages)."""

    Options: ClassVar[type[PluginOptions]] = PluginOptions
    kind: ClassVar[str] = "plug-in"


@cache
def registered(group: str) -> dict[str, str]:
    """``{name: "pkg.mod:Class"}`` of the installed entry points of ``group`` (cached per process)."""
    return {ep.name: ep.value for ep in entry_points(group=group)}


def resolve(group: str, name: str, base: type[Plugin]) -> type[Plugin]:
    """The plug-in class called ``name`` in ``group`` (or the import target ``name``); ``ValueError`` if none.

    The error lists the registered names, so a misspelt name in a mission
    reads like any other unknown name.
    """
    known = registered(group)
    target = known.get(name, name if ":" in name else None)
    if target is None:
        raise ValueError(f"unknown {base.kind} '{name}'; expected one of {', '.join(sorted(known))} "
                         "or an import target 'package.module:Class'")
    try:
        cls = import_target(target)
    except MissionError as err:
        raise ValueError(f"{base.kind} '{name}': {err}") from None
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise ValueError(f"{base.kind} '{name}' ({target}) is not a subclass of {base.__module__}.{base.__name__}")
    return cls


def build(group: str, name: str, base: type[Plugin], options: dict[str, Any], **kwargs: Any) -> Any:
    """An instance of plug-in ``name`` with ``options`` validated by its ``Options`` (and ``kwargs``)."""
    cls = resolve(group, name, base)
    return cls(cls.Options.model_validate(options), **kwargs)  # type: ignore[call-arg]
