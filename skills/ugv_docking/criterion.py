"""Transition conditions on the benchmark features (Zhao et al., §3.2-3.3): C2 on the criterion list, C3 by eq. (7).

- C2 (Remark 2): the child is within the criterion distance of the station
  when its features ``(k_h, s_u)`` meet the recorded criterion list f_list:
  ``|k_h| ≥ |k_h^i|`` and ``s_u ≥ s_u^i`` for some entry i. The paper's set
  notation leaves the quantifier open; "some entry" is the reading under
  which the condition can hold: |k̄_h| and s_u both grow as the child comes
  closer (eq. 6, Remark 2), so every entry marks the features at the
  criterion distance for one relative direction, and a child nearer than it
  in that direction exceeds the entry in both. (With "every entry", an
  aligned child, k_h ≈ 0, could never meet the entries recorded obliquely.)
- C3 (Remark 3, eq. 7): matched to the entrance and close enough to drive
  straight in: ``|k_h| < Δk``, ``|u_h - W/2| < Δu``, ``s_u ≥ s_u^e``.

f_list is measured once per robot model, with the robot placed around the
benchmark (``python -m marsupial.tools.ugv_criterion`` records the
``child_ugv``'s into ``data/child_ugv_f_list.yaml``, shipped with this
package); :func:`load_criterion_list` reads it. Features as in
:mod:`.features` (pixels, u right, v down).
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from typing import Any

import numpy as np
import yaml

from .features import BenchmarkFeatures


@dataclass(frozen=True)
class CriterionList:
    """f_list of Remark 2: the features recorded with the child at the criterion distance around the benchmark.

    Attributes:
        robot: the robot model it was recorded for (e.g. ``"child_ugv"``).
        distance: the criterion distance (m): horizontal distance from the point
            under the camera to E, the ground projection of I_h.
        entries: ``(k_h, s_u)`` per recorded placement (s_u in px).
        placements: ``(bearing, heading_offset)`` (rad) of each entry: the
            bearing of the camera from E off the entry direction, and the
            heading's offset from pointing at E (left positive).
        s_u_e: s_u^e of eq. (7) measured for this robot model (px): s_u with the
            child aligned on the entry direction at :attr:`entrance_distance`;
            ``None`` when not recorded. Recorded because the paper's 203 px
            (Table 1) is never reached with the ``child_ugv``'s camera (see
            :class:`MatchTolerances`).
        entrance_distance: the distance d_e (m, camera ground point to E) at which :attr:`s_u_e` was measured.
    """

    robot: str
    distance: float
    entries: tuple[tuple[float, int], ...]
    placements: tuple[tuple[float, float], ...]
    s_u_e: int | None = None
    entrance_distance: float | None = None

    def __post_init__(self) -> None:
        if not self.entries or len(self.entries) != len(self.placements):
            raise ValueError(
                f"a criterion list needs entries, one per placement: {len(self.entries)} for {len(self.placements)}"
            )

    def to_yaml(self) -> str:
        """The list as the YAML document :func:`load_criterion_list` reads (angles in degrees)."""
        document = {
            "robot": self.robot,
            "distance_m": self.distance,
            "entries": [
                {"k_h": round(k, 5), "s_u": int(s), "bearing_deg": round(float(np.degrees(b)), 3),
                 "heading_offset_deg": round(float(np.degrees(o)), 3)}
                for (k, s), (b, o) in zip(self.entries, self.placements, strict=True)
            ],
        }
        if self.s_u_e is not None:
            document.update(s_u_e=int(self.s_u_e), entrance_distance_m=self.entrance_distance)
        return yaml.safe_dump(document, sort_keys=False, width=120)

    @classmethod
    def from_document(cls, document: dict[str, Any]) -> CriterionList:
        """The list from a parsed YAML document of :meth:`to_yaml`."""
        entries = document["entries"]
        return cls(
            robot=str(document["robot"]),
            distance=float(document["distance_m"]),
            entries=tuple((float(e["k_h"]), int(e["s_u"])) for e in entries),
            placements=tuple(
                (float(np.radians(e["bearing_deg"])), float(np.radians(e["heading_offset_deg"]))) for e in entries
            ),
            s_u_e=int(document["s_u_e"]) if "s_u_e" in document else None,
            entrance_distance=float(document["entrance_distance_m"]) if "entrance_distance_m" in document else None,
        )


def load_criterion_list(robot: str = "child_ugv") -> CriterionList:
    """The criterion list shipped for ``robot`` (``data/<robot>_f_list.yaml`` of this package)."""
    path = resources.files(__package__) / "data" / f"{robot}_f_list.yaml"
    if not path.is_file():
        raise FileNotFoundError(f"no criterion list recorded for robot model '{robot}' ({path})")
    return CriterionList.from_document(yaml.safe_load(path.read_text()))


def within_criterion(features: BenchmarkFeatures | None, f_list: CriterionList) -> bool:
    """C2 (Remark 2): some entry i of ``f_list`` has ``|k_h| ≥ |k_h^i|`` and ``s_u ≥ s_u^i``.

    ``None`` (the benchmark not captured) never meets it.
    """
    if features is None:
        return False
    table = np.asarray(f_list.entries, dtype=float)
    return bool(np.any((abs(features.k_h) >= np.abs(table[:, 0])) & (features.s_u >= table[:, 1])))


@dataclass(frozen=True)
class MatchTolerances:
    """Eq. (7)'s margins, Table 1's values by default.

    Attributes:
        delta_u: Δu, tolerance of u_h about the image centre W/2 (px).
        delta_k: Δk, tolerance of k_h about 0.
        s_u_e: s_u^e, the pre-measured s_u at the visual perception criterion distance d_e (px).
            The default is the paper's 203 px (Table 1). The ``child_ugv`` of this
            world never sees s_u that large (H_GS leaves its image at ≈196 px,
            y_e ≈ 0.23 m), so the docking skills and conditions use the value
            measured for the robot model instead (:attr:`CriterionList.s_u_e`,
            recorded with f_list); :func:`robot_tolerances` builds those.
    """

    delta_u: float = 5.0
    delta_k: float = 0.02
    s_u_e: int = 203


def matched(features: BenchmarkFeatures | None, tolerances: MatchTolerances = MatchTolerances()) -> bool:
    """C3 (Remark 3, eq. 7): ``k_h ∈ (-Δk, Δk)``, ``u_h ∈ (W/2 - Δu, W/2 + Δu)``, ``s_u ≥ s_u^e`` (``None``: False).

    W is the width of the frame the features come from.
    """
    if features is None:
        return False
    half_width = features.image_width / 2.0
    return (
        abs(features.k_h) < tolerances.delta_k
        and abs(features.u_h - half_width) < tolerances.delta_u
        and features.s_u >= tolerances.s_u_e
    )


def robot_tolerances(
    f_list: CriterionList, delta_u: float = 5.0, delta_k: float = 0.02, s_u_e: int | None = None
) -> MatchTolerances:
    """Eq. (7)'s margins for the robot model of ``f_list``: Δu, Δk as given, s_u^e given or else the recorded one.

    Falls back to the paper's 203 px when neither is given nor recorded.
    """
    measured = s_u_e if s_u_e is not None else f_list.s_u_e
    return MatchTolerances(delta_u, delta_k, measured if measured is not None else MatchTolerances.s_u_e)
