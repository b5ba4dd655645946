"""The building plan of a loaded scene, as the mission's operator would hand it to the robots.

The plan (:class:`~marsupial.api.priors.BuildingPlan`) is copied from the
data the scene file declares — labels, boxes, tags — never from the world's
bodies, when the scene is loaded (before any disturbance changes it); what a
benchmark places or scores (:data:`SCORED_TAGS`: aperture openings and their
rims, decoys) is left out.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from marsupial.api.priors import STRUCTURE_TAGS, BuildingPlan, PlanElement, PlanZone

#: what a benchmark scores or places, never on a plan: aperture openings and their rims, decoys
SCORED_TAGS = frozenset({"aperture", "aperture_clear", "aperture_rim", "decoy"})


def building_plan(scene: Any) -> BuildingPlan:
    """The plan of a loaded scene, from the data its file declares (labels, boxes, tags; no bodies)."""
    structure = tuple(
        PlanElement(o.label, tuple(o.position), tuple(o.orientation), tuple(o.size), tuple(o.tags))
        for o in scene.objects.values()
        if STRUCTURE_TAGS & set(o.tags) and not SCORED_TAGS & set(o.tags)
    )
    zones = tuple(
        PlanZone(z.label, tuple(z.lo), tuple(z.hi), tuple(z.tags))
        for z in scene.zones.values()
        if not SCORED_TAGS & set(z.tags)
    )
    paths = {name: np.array(p, dtype=float) for name, p in scene.paths.items()}
    return BuildingPlan(scene.name, tuple(scene.size), structure, zones, paths)
