"""The transition conditions C1–C4 of the coordinated docking task model (Zhao et al., §3.3, Fig. 5).

- C1 ``benchmark_captured`` — the benchmark is captured (§3.1: a candidate
  group of N_G ≥ T_N and H_GS found) in the newest frame;
- C2 ``within_criterion`` — the child is within the criterion distance of the
  station: its features meet the recorded criterion list f_list (Remark 2);
- C3 ``entrance_matched`` — eq. (7) (Remark 3): ``|k_h| < Δk``,
  ``|u_h - W/2| < Δu``, ``s_u ≥ s_u^e`` in the newest frame;
- C4 ``features_lost`` — the features have been lost for a few successive frames.

On the child (``robot:`` the child, ``child`` unset) they judge from its own
camera (:func:`~.vision.child_view`). C1–C3 also serve the mother
(``robot:`` the mother, ``child:`` the child): they then judge from the
newest features the child sent over the team link, if not older than
``max_age`` — what the mother knows of the benchmark, late and sometimes lost.
C2 judges the features held over fewer than ``frames`` lost frames, so a
single missed frame does not throw the child out of matching. f_list and the
measured s_u^e are those of the child's robot model (``data/<kind>_f_list.yaml``).
"""

from __future__ import annotations

from typing import Annotated, Any, ClassVar

from pydantic import Field

from marsupial.api.capabilities import HasBase
from marsupial.trees.skill import Condition, NodeParams, P, TeamMember

from .criterion import CriterionList, load_criterion_list, matched, robot_tolerances, within_criterion
from .features import BenchmarkFeatures
from .vision import FEATURE_METRICS, VIEW_KEY, child_view, received_features

#: a parameter naming the child whose features a mother's condition judges (unset: the robot's own camera)
ChildName = Annotated[str, TeamMember(HasBase)] | None
LOST_FRAMES = 3  # "a few successive frames" (§3.3; the paper gives no number): 0.3 s at the camera's 10 Hz


class _FeatureCondition(Condition[P]):
    """Base: the features a condition judges, from the robot's own camera or received from ``params.child``."""

    robot_kinds = (HasBase,)
    reads = (f"{{robot}}/{VIEW_KEY}",)
    writes = (f"{{robot}}/{VIEW_KEY}",)
    metrics = FEATURE_METRICS

    @classmethod
    def sensors_read(cls, params: P, robot: str | None) -> tuple[tuple[str, str], ...]:
        """Its robot's ``camera`` when it judges its own frames (no ``child`` named), else nothing."""
        return ((str(robot), "camera"),) if getattr(params, "child", None) is None and robot is not None else ()

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self._f_list: CriterionList | None = None

    def features(self, child: str | None, max_age: float, frames: int = 1) -> BenchmarkFeatures | None:
        """Features received from ``child`` (if not older than ``max_age`` s), or else of the own newest frame.

        Own camera with ``frames`` > 1: the newest features held over fewer than ``frames`` lost frames.
        """
        if child is not None:
            return received_features(self, child, max_age)
        view = child_view(self)
        return view.current if frames <= 1 else view.held(frames)

    def criterion_list(self, child: str | None) -> CriterionList:
        """f_list of the camera's robot model (``child``'s, else the robot's own), loaded once."""
        if self._f_list is None:
            kind = self.member(child).kind if child is not None else self.robot.kind
            self._f_list = load_criterion_list(kind)
        return self._f_list


class BenchmarkCaptured(_FeatureCondition["BenchmarkCaptured.Params"]):
    """C1: the benchmark is captured in the newest frame (own camera, or the child's features over the link)."""

    class Params(NodeParams):
        child: ChildName = None
        """Judge from the features this team member sends over the team link (unset: the robot's own camera)."""
        max_age: float = Field(0.5, gt=0.0)
        """With ``child``: the newest features count if sent less than this long ago (s)."""

    def check(self) -> bool:
        return self.features(self.params.child, self.params.max_age) is not None


class WithinCriterion(_FeatureCondition["WithinCriterion.Params"]):
    """C2 (Remark 2): the features meet the criterion list f_list: the child is within the criterion distance."""

    class Params(NodeParams):
        child: ChildName = None
        """Judge from the features this team member sends over the team link (unset: the robot's own camera)."""
        max_age: float = Field(0.5, gt=0.0)
        """With ``child``: the newest features count if sent less than this long ago (s)."""
        frames: int = Field(LOST_FRAMES, ge=1)
        """Own camera: judge the newest features while fewer than this many successive frames missed them."""

    def check(self) -> bool:
        p = self.params
        return within_criterion(self.features(p.child, p.max_age, p.frames), self.criterion_list(p.child))


class EntranceMatched(_FeatureCondition["EntranceMatched.Params"]):
    """C3 (Remark 3, eq. 7): k_h within Δk, u_h within Δu of W/2, s_u ≥ s_u^e in the newest frame."""

    class Params(NodeParams):
        delta_u: float = Field(5.0, gt=0.0)  # Δu = 5 px, Table 1
        """Δu of eq. (7): tolerance of u_h about the image centre (px, Table 1: 5)."""
        delta_k: float = Field(0.02, gt=0.0)  # Δk = 0.02, Table 1
        """Δk of eq. (7): tolerance of k_h about 0 (Table 1: 0.02)."""
        s_u_e: int | None = Field(None, ge=1)
        """s_u^e of eq. (7) (px). Unset: the value measured for the child's robot model and recorded with its
        f_list (``child_ugv``: 184 px at 0.25 m); the paper's 203 px (Table 1) is never reached by this
        world's child camera (≈196 px at most, at 0.23 m)."""
        child: ChildName = None
        """Judge from the features this team member sends over the team link (unset: the robot's own camera)."""
        max_age: float = Field(0.5, gt=0.0)
        """With ``child``: the newest features count if sent less than this long ago (s)."""

    def check(self) -> bool:
        p = self.params
        tolerances = robot_tolerances(self.criterion_list(p.child), p.delta_u, p.delta_k, p.s_u_e)
        return matched(self.features(p.child, p.max_age), tolerances)


class FeaturesLost(_FeatureCondition["FeaturesLost.Params"]):
    """C4: the child's camera has missed the benchmark in this many successive frames (or never captured it)."""

    class Params(NodeParams):
        frames: int = Field(LOST_FRAMES, ge=1)
        """Successive frames without the features ("a few successive frames", §3.3; not given: 3)."""

    primary: ClassVar[str] = "frames"
    sensors = ("camera",)

    def check(self) -> bool:
        return child_view(self).lost_frames >= self.params.frames
