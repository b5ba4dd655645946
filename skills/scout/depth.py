"""Dense depth from the relayed frames: the carrier's monocular depth estimator and its documented stand-in.

Arora & Papachristos, §IV-G: "a trained model for monocular depth estimation
[40] [Monodepth2, Godard et al. 2019]; the network is deployed on the MMS
onboard powerful GPU and provides dense depth map estimates of the visual
imagery relayed by the MAV". A :class:`DepthEstimator` is that step: a
relayed frame in, a dense depth map out, in an arbitrary but positive scale
(a self-supervised monocular network knows depth only up to scale; the
guidance of :mod:`.policy` uses ratios of column averages and needs no more).

No trained network ships with a Python package reachable here (the ones on
the package index download their weights at run time; see ``docs/scout.md``),
so the default, :class:`MonocularErrorModel`, is a stand-in: it takes the
frame's rendered depth (relayed beside the JPEG, :mod:`.relay`) as what an
ideal network would infer, and degrades it the way monocular networks err.
A real network is a :class:`DepthEstimator` subclass registered under
:data:`~.plugins.DEPTH_GROUP` that reads ``frame.rgb`` (the decoded JPEG) only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import cv2
import numpy as np
from pydantic import Field

from .plugins import Plugin, PluginOptions

if TYPE_CHECKING:
    from .relay import RelayedFrame


class DepthEstimator(Plugin):
    """Base of depth estimators: :meth:`estimate` one relayed frame.

    ``uses_rendered_depth``: the estimator is a stand-in that needs the
    frame's rendered depth relayed with it (the MAV then sends it).
    """

    kind: ClassVar[str] = "depth estimator"
    uses_rendered_depth: ClassVar[bool] = False

    def __init__(self, options: PluginOptions, rng: np.random.Generator):
        self.options = options
        self.rng = rng

    def estimate(self, frame: RelayedFrame) -> np.ndarray:
        """Dense depth ``(h', w')`` float32 > 0 of ``frame`` (any positive scale; image rows and columns kept)."""
        raise NotImplementedError(f"{type(self).__name__} must implement estimate()")


class MonocularErrorModel(DepthEstimator):
    """Stand-in for a monocular depth network: the rendered depth, range-limited, smoothed, scaled and noisy.

    Steps, on the frame's rendered depth ``D`` (m):

    1. range: ``min(D, max_depth)``; empty pixels (the open top of the mockup, at the far plane) read
       ``max_depth`` — a network trained on indoor scenes saturates there;
    2. resolution and smoothing: area-resampled by ``1/downsample`` and blurred with a Gaussian of
       ``blur_px`` (output pixels) — the soft, bleeding edges of a network's decoder;
    3. scale ambiguity: the whole map times ``exp(s)``, ``s ~ N(0, scale_std²)`` drawn per frame —
       self-supervised monocular depth is known only up to a scale, which also drifts between frames
       (Godard et al. 2019 scale each prediction by the ground truth's median to evaluate it);
    4. structured relative error: times ``exp(e(u, v))``, ``e`` a Gaussian field of 1σ ``noise_rel``
       drawn on a coarse ``noise_grid`` and upsampled bicubically — errors of whole surfaces rather than
       of pixels (Monodepth2's KITTI AbsRel is 0.106-0.115, Table 1 of [40]: 0.1 is that order).
    """

    class Options(PluginOptions):
        max_depth: float = Field(10.0, gt=0.0)
        """Largest depth the network outputs (m); farther and empty pixels read this."""
        downsample: int = Field(2, ge=1)
        """Output resolution divisor (the network's input and output are smaller than the frame)."""
        blur_px: float = Field(2.0, ge=0.0)
        """1σ of the Gaussian smoothing (output pixels); 0: none."""
        scale_std: float = Field(0.3, ge=0.0)
        """1σ of the log of the per-frame global scale."""
        noise_rel: float = Field(0.1, ge=0.0)
        """1σ of the log of the structured relative error."""
        noise_grid: tuple[int, int] = (8, 6)
        """Columns and rows of the coarse grid the relative error is drawn on."""

    uses_rendered_depth: ClassVar[bool] = True
    options: MonocularErrorModel.Options

    def estimate(self, frame: RelayedFrame) -> np.ndarray:
        """The degraded depth map (relative scale) of ``frame``'s relayed rendered depth."""
        if frame.depth_standin is None:
            raise ValueError("the monocular error model needs the frame's rendered depth relayed with it")
        o = self.options
        depth = np.minimum(frame.depth_standin, np.float32(o.max_depth))
        h, w = depth.shape
        size = (max(1, w // o.downsample), max(1, h // o.downsample))
        out = cv2.resize(depth, size, interpolation=cv2.INTER_AREA)
        if o.blur_px > 0:
            out = cv2.GaussianBlur(out, (0, 0), o.blur_px)
        log_error = np.float32(o.scale_std * self.rng.standard_normal())
        if o.noise_rel > 0:
            grid = (o.noise_rel * self.rng.standard_normal((o.noise_grid[1], o.noise_grid[0]))).astype(np.float32)
            log_error = log_error + cv2.resize(grid, size, interpolation=cv2.INTER_CUBIC)
        return (out * np.exp(log_error)).astype(np.float32)
