"""The child's view of the benchmark, shared by its docking nodes, and what the two robots say over the team link.

One :class:`BenchmarkView` per child (blackboard key ``<child>/benchmark_view``,
made by the first docking node that looks, :func:`child_view`) turns each new
frame of the child's ``camera`` into the benchmark's features
(:func:`~.features.extract_features`, §3.1), counts the successive frames
without them (C4), and sends the features — and nothing else, as the paper
has it (§2: "these features instead of image/video data are transmitted to
the mother robot") — over the team link on :data:`FEATURES_TOPIC`. A frame
is processed once, whichever node reads it first.

The mother reports its platform over the link on :data:`PLATFORM_TOPIC`
(:class:`PlatformReport`: the load switch and the lift encoder), so the child
knows when it stands on the platform (``child_direct``).

Features in pixels (u right, v down) as in :mod:`.features`; times in simulated s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from marsupial.trees.metrics import MetricSpec

from .features import BenchmarkFeatures, FeatureParams, extract_features

if TYPE_CHECKING:
    from marsupial.api.views import LinkView, SensorView
    from marsupial.trees.skill import MissionNode

FEATURES_TOPIC = "benchmark_features"
"""Team-link topic of the child's features (payload: :class:`~.features.BenchmarkFeatures`)."""
PLATFORM_TOPIC = "platform"
"""Team-link topic of the mother's platform state (payload: :class:`PlatformReport`)."""
VIEW_KEY = "benchmark_view"
"""Blackboard key, under the child's name, of its :class:`BenchmarkView`."""
NEVER_SEEN = 1 << 30
"""``lost_frames`` before the first capture: the benchmark counts as lost for any number of frames."""
STALE_S = 1.0
"""A newest frame older than this (s) is no view: the camera went unread (between two dockings, or before the
first) and the benchmark counts as never seen until a fresh frame comes (5 camera periods at 5 Hz)."""


@dataclass(frozen=True)
class PlatformReport:
    """What the mother sends about its docking station.

    Attributes:
        occupied: the platform's load switch: a child stands wholly on the plate.
        height: platform height from the lift encoder (m; 0 on the floor).
    """

    occupied: bool
    height: float


class BenchmarkView:
    """The benchmark as the child's camera sees it, frame by frame (§3.1, §3.3).

    Attributes:
        current: the features of the newest frame, ``None`` if it did not capture the benchmark (C1 fails).
        last: the newest features ever extracted (``None`` before the first capture).
        lost_frames: successive frames without the benchmark up to the newest (0 when it captured it).
        stamp: sim time (s) of the newest frame processed.
    """

    def __init__(
        self,
        camera: SensorView,
        link: LinkView,
        params: FeatureParams | None = None,
        on_features: Callable[[BenchmarkFeatures], None] | None = None,
    ):
        self.camera = camera
        self.link = link
        self.params = params if params is not None else FeatureParams()
        self.on_features = on_features
        self.current: BenchmarkFeatures | None = None
        self.last: BenchmarkFeatures | None = None
        self.lost_frames = NEVER_SEEN
        self.stamp = float("-inf")

    def update(self, now: float) -> bool:
        """Process the camera's newest frame if it is new; returns whether there was one.

        ``now`` is the sim time (s): a newest frame older than :data:`STALE_S`
        clears the view (nothing current, nothing held, never seen). Captured
        features are sent on :data:`FEATURES_TOPIC` and passed to ``on_features``.
        """
        reading = self.camera.read()
        if reading is None or now - reading.stamp > STALE_S:
            self.current = self.last = None
            self.lost_frames = NEVER_SEEN
            return False
        if reading.stamp <= self.stamp:
            return False
        self.stamp = reading.stamp
        features = extract_features(reading.data.rgb, self.params)
        self.current = features
        if features is None:
            self.lost_frames = min(NEVER_SEEN, self.lost_frames + 1)
            return True
        self.last, self.lost_frames = features, 0
        self.link.send(FEATURES_TOPIC, features)
        if self.on_features is not None:
            self.on_features(features)
        return True

    def held(self, frames: int) -> BenchmarkFeatures | None:
        """The newest features while fewer than ``frames`` successive frames have missed the benchmark, else ``None``.

        A frame or two without the benchmark (a blur, a drop) keeps the child
        in its state (Exp. II: "does not change its approaching state
        immediately"); C4 ends that after ``frames`` frames.
        """
        return self.last if self.lost_frames < frames else None


#: the metrics :func:`child_view` records (declared by the nodes that use it)
FEATURE_METRICS = (
    MetricSpec("ugv_u_star", "1", "benchmark centre u_h / W across the child's image (Fig. 11b)"),
    MetricSpec("ugv_s_star", "1", "benchmark width s_u / W in the child's image (Fig. 11b)"),
    MetricSpec("ugv_k_h", "1", "slope k_h of the benchmark's top edge in the child's image (Fig. 11b)"),
)


def child_view(node: MissionNode[Any]) -> BenchmarkView:
    """The :class:`BenchmarkView` of ``node``'s robot (made on first use), updated to its camera's newest frame.

    ``node`` must declare ``{robot}/benchmark_view`` among its reads and
    writes. Captured features are recorded as the metrics of the paper's
    Fig. 11(b): ``ugv_u_star`` (u_h / W), ``ugv_s_star`` (s_u / W) and ``ugv_k_h``, labelled with the robot.
    """
    key = f"{node.robot_name}/{VIEW_KEY}"
    view = node.read(key)
    if view is None:
        context, robot = node.context, node.robot_name

        def record(f: BenchmarkFeatures) -> None:
            context.metric("ugv_u_star", f.u_h / f.image_width, robot=robot)
            context.metric("ugv_s_star", f.s_u / f.image_width, robot=robot)
            context.metric("ugv_k_h", f.k_h, robot=robot)

        view = BenchmarkView(node.robot.sensor("camera"), node.link, on_features=record)
        node.write(key, view)
    view.update(node.now)
    return view


def received_features(node: MissionNode[Any], child: str, max_age: float) -> BenchmarkFeatures | None:
    """The newest features ``child`` sent over the team link, if sent less than ``max_age`` s ago (else ``None``)."""
    message = node.link.latest(child, FEATURES_TOPIC)
    if message is None or node.now - message.sent > max_age:
        return None
    features: BenchmarkFeatures = message.payload
    return features


def report_platform(node: MissionNode[Any]) -> bool:
    """Send ``node``'s robot's platform (load switch, lift encoder) on :data:`PLATFORM_TOPIC`; returns the switch."""
    robot = node.robot
    occupied = bool(robot.platform_occupied)
    node.link.send(PLATFORM_TOPIC, PlatformReport(occupied, float(robot.platform_height())))
    return occupied
