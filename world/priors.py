"""The building plan of a loaded scene, as the mission's operator would hand it to the robots.

The plan (:class:`~marsupial.api.priors.BuildingPlan`) is copied from the
data the scene file declares — labels, boxes, tags — never from the world's
bodies, and before any disturbance changes the scene: what a benchmark places
or scores (aperture shapes, decoys, fitted rims) is not on it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from marsupial.api.priors import STRUCTURE_TAGS, BuildingPlan, PlanElement, PlanZone


def building_plan(scene: Any) -> BuildingPlan:
    """The plan of a loaded scene, from the data its file declares (labels, boxes, tags; no bodies)."""
    structure = tuple(
        PlanElement(o.label, tuple(o.position), tuple(o.orientation), tuple(o.size), tuple(o.tags))
        for o in scene.objects.values()
        if STRUCTURE_TAGS & set(o.tags)
    )
    zones = tuple(PlanZone(z.label, tuple(z.lo), tuple(z.hi), tuple(z.tags)) for z in scene.zones.values())
    paths = {name: np.array(p, dtype=float) for name, p in scene.paths.items()}
    return BuildingPlan(scene.name, tuple(scene.size), structure, zones, paths)
