"""The scout's video relay: front-camera frames JPEG-encoded on the MAV, sent over the team link, decoded on the
carrier.

Arora & Papachristos, §III-B and §V: the Tello "feeds back an encoded video
stream to the main robot carrier", which computes the guidance on it; "each
MAV micro-scout relays a x264-encoded video stream back to the MMS". Here each
new frame of the MAV's front camera is one JPEG (``cv2.imencode``, quality
``jpeg_quality``), a stand-in for the x264 stream: lossy, blocky, chroma
subsampled. The bytes travel as one team-link message (:data:`VIDEO_TOPIC`),
so the link's latency, jitter and loss apply to every frame; the carrier reads
the newest delivered packet and decodes it (``cv2.imdecode``). Sequence numbers
tell the receiver how many frames never arrived (lost on the link, or
superseded by a newer one before it looked).

A packet may carry the frame's rendered depth (``depth_standin``) when the
carrier's depth estimator is the monocular error model: the stand-in for the
network's inference on that very frame (:mod:`.depth`); it travels, and is
lost, with the frame's JPEG.

Pixels: ``(h, w, 3)`` uint8 RGB; depth ``(h, w)`` float32 m along the optical axis; times in simulated s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

if TYPE_CHECKING:
    from marsupial.api.views import LinkView

VIDEO_TOPIC = "scout_video"
"""Team-link topic of the MAV's encoded frames (payload: :class:`VideoPacket`)."""


@dataclass(frozen=True)
class VideoPacket:
    """One encoded frame as the MAV sends it.

    Attributes:
        seq: frame number of the stream (0, 1, …; consecutive for consecutive sent frames).
        stamp: sim time (s) the camera took the frame.
        jpeg: the JPEG bytes of the RGB frame.
        K: 3×3 camera intrinsics (pixels).
        depth_standin: the frame's rendered depth (m) for the depth-network stand-in, or ``None``.
    """

    seq: int
    stamp: float
    jpeg: bytes
    K: np.ndarray
    depth_standin: np.ndarray | None = None


@dataclass(frozen=True)
class RelayedFrame:
    """A frame as the carrier has it after decoding: pixels, intrinsics, depth stand-in input and times (s)."""

    seq: int
    stamp: float
    delivered: float
    rgb: np.ndarray
    K: np.ndarray
    depth_standin: np.ndarray | None


def encode_frame(rgb: np.ndarray, quality: int) -> bytes:
    """JPEG bytes of an RGB frame at ``quality`` (0–100), via OpenCV (BGR channel order on the wire)."""
    ok, buffer = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError(f"JPEG encoding failed for a frame of shape {rgb.shape}")
    return buffer.tobytes()


def decode_frame(jpeg: bytes) -> np.ndarray:
    """The RGB frame ``(h, w, 3)`` uint8 of JPEG bytes; ``ValueError`` for bytes that are no JPEG."""
    bgr = cv2.imdecode(np.frombuffer(jpeg, dtype=np.uint8), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError("the relayed bytes are not a JPEG image")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


class VideoSender:
    """The MAV's side: each new camera frame, once, JPEG-encoded on :data:`VIDEO_TOPIC`.

    Attributes:
        sent: frames handed to the link.
        stamp: sim time (s) of the newest frame sent (``-inf`` before the first).
    """

    def __init__(self, link: LinkView, quality: int, with_depth: bool):
        self.link = link
        self.quality = quality
        self.with_depth = with_depth
        self.sent = 0
        self.stamp = float("-inf")

    def offer(self, stamp: float, rgb: np.ndarray, K: np.ndarray, depth: np.ndarray | None) -> bool:
        """Send the frame taken at ``stamp`` (s) if it is newer than the last one sent; returns whether it was."""
        if stamp <= self.stamp:
            return False
        standin = depth if self.with_depth else None
        self.link.send(VIDEO_TOPIC, VideoPacket(self.sent, stamp, encode_frame(rgb, self.quality), K, standin))
        self.sent += 1
        self.stamp = stamp
        return True


class VideoReceiver:
    """The carrier's side: the newest delivered packet of ``sender``, decoded once.

    Attributes:
        received: frames decoded.
        lost: frames never decoded between the first and the newest received (link loss, or overtaken).
    """

    def __init__(self, link: LinkView, sender: str):
        self.link = link
        self.sender = sender
        self.received = 0
        self.lost = 0
        self._seq = -1

    def newest(self) -> RelayedFrame | None:
        """The newest delivered frame if it was not decoded before, else ``None``."""
        message = self.link.latest(self.sender, VIDEO_TOPIC)
        if message is None or message.payload.seq <= self._seq:
            return None
        packet: VideoPacket = message.payload
        if self._seq >= 0:
            self.lost += packet.seq - self._seq - 1
        self._seq = packet.seq
        self.received += 1
        return RelayedFrame(packet.seq, packet.stamp, message.delivered, decode_frame(packet.jpeg), packet.K,
                            packet.depth_standin)
