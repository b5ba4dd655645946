"""Aperture profile analysis (Arora & Papachristos, §IV-E, Algorithm 1 part 2): where the MAV fits through.

Input: the aperture as a binary mask in the fronto-parallel depth image I
(:mod:`.detection`; non-zero = the aperture's free region, its boundary is the
contour C_a) and the MAV contour C_m scaled to the same image at the plane
depth (:func:`~.silhouette.mav_contour`). Output: launch configurations
{p, θ} at which the transformed MAV contour C_m^t lies in the interior of C_a.

Image frame: pixels (u right, v down, OpenCV), angles in radians measured from
+u toward +v (clockwise as the image is shown), in (-π/2, π/2].

The search, as in the paper:

i)   G: every pair of points of C_a whose segment l lies in the interior of
     C_a and is at least as long as the MAV's major axis M_Cm, ranked by
     m_l = min(m1, m2), the weighted length and orientation differences of l
     from C_a's major and minor axes;
ii)  in that order, C_m with its centre of mass on l's midpoint and its major
     axis along l; if it does not cross C_a, {p, θ} joins V, else the pair
     joins the failed set F;
iii) while V holds fewer than N_v configurations, each pair of F in turn:
     C_m slides along l one pixel at a time, alternately toward either end
     (+1, -1, +2, -2, … px), until its edge reaches the end point; the first
     shift that fits joins V. V is bounded by N_v.
iv)  (a departure, ``centre_radius_px``) each configuration of V is moved, at its angle θ, to where C_m^t keeps
     the largest distance from C_a within that radius (:func:`centred`): V's configurations are the first
     that fit, which at a U put the MAV's top 4.5 mm under the tongue with 2.2 cm of clearance to spare, and
     the few millimetres the arm and the grasp add on the way touched it. The centred configurations come
     first (duplicates dropped), the uncentred ones fill V up to N_v after them. With step iv a
     configuration within ``distinct_angle`` and ``centre_radius_px`` of one already in V does not count
     toward N_v: the first fits are mostly one chord's neighbours, which centre to one place, and V then
     held three poses, all on the MAV's side where a level fit existed (the arm could not turn it level).

Departures (the paper gives no numbers or details for these):

- C_a's points are taken every ``pair_spacing_px`` along the contour (the
  paper pairs every contour point; its Table I times are ≈1 s per shape).
- Interior tests are raster tests, vectorised in numpy: a point is inside
  when the exact Euclidean distance transform of the filled contour at its
  pixel exceeds ``clearance_px`` plus :data:`RASTER_MARGIN_PX`, the most a
  pixel lookup can misjudge the distance to C_a's polygon. The check is
  therefore conservative by up to that margin. Since C_a is a simple closed
  contour, C_m^t's boundary inside it means all of C_m^t is.
- "||l - M_Ca||" is read as the difference of lengths, normalised by the
  axis length (w1 is then dimensionless); the angle term is the acute angle
  between the two lines (rad, weighted by w2).
- The axes of a contour are the principal axes of its vertices; an axis's
  length is the contour's extent along it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

#: how much nearer (px) the contour C_a can be than the distance transform at a point's nearest pixel says:
#: half a pixel diagonal to the pixel centre, plus the contour passing through boundary-pixel centres up to
#: one pixel diagonal from the nearest outside pixel
RASTER_MARGIN_PX = 2.0 * math.sqrt(0.5) + 0.5


@dataclass(frozen=True)
class ProfileParams:
    """Parameters of the aperture profile analysis (§IV-E); the paper gives no values for them.

    Attributes:
        w1: weight of the length difference of l from C_a's axes (per axis length; m1, m2 of §IV-E).
        w2: weight of the orientation difference of l from C_a's axes (per rad; m1, m2 of §IV-E).
        n_valid: N_v, the most configurations returned ("upper-bound by N_v", §IV-E).
        clearance_px: least distance (px) kept between C_m^t and C_a (0: the boundaries just do not cross).
        pair_spacing_px: spacing (px) of the points of C_a that the pairs of G are made of.
        chunk: configurations checked per vectorised batch in step ii (early exit at N_v).
        centre_radius_px: step iv, the farthest (px) a configuration is moved to keep C_m^t off C_a (0: the
            paper's configurations as found).
        distinct_angle: with step iv, a configuration within this angle (rad) of one already in V and within
            ``centre_radius_px`` of it does not count toward N_v (it would centre to the same place).
    """

    w1: float = 1.0
    w2: float = 1.0
    n_valid: int = 10
    clearance_px: float = 1.0
    pair_spacing_px: float = 2.0
    chunk: int = 256
    centre_radius_px: float = 24.0
    distinct_angle: float = math.radians(1.0)

    def __post_init__(self) -> None:
        if (self.n_valid < 1 or self.chunk < 1 or self.pair_spacing_px <= 0 or self.clearance_px < 0
                or self.centre_radius_px < 0 or not 0.0 <= self.distinct_angle <= math.pi / 2):
            raise ValueError(f"invalid profile parameters: {self}")


@dataclass(frozen=True)
class LaunchConfiguration:
    """One valid configuration {p, θ} of V: where the MAV's centre of mass goes and how its major axis lies.

    Attributes:
        center_px: p, ``(u, v)`` px in the fronto-parallel image I: the MAV's centre of mass
            (the origin of the contour C_m given to :func:`profile_analysis`).
        angle: θ (rad), slope of l: the MAV's major axis from +u toward +v, in (-π/2, π/2].
        pair_px: the two points x_i, x_j of C_a (px) whose segment l it lies on.
        score: m_l = min(m1, m2) of the pair (lower ranks first).
        shift_px: offset (px) of p from l's midpoint along l (0 in step ii; the sliding search's in step iii).
    """

    center_px: tuple[float, float]
    angle: float
    pair_px: tuple[tuple[float, float], tuple[float, float]]
    score: float
    shift_px: float

    def placed(self, mav_contour: np.ndarray) -> np.ndarray:
        """C_m^t: ``mav_contour`` (``(n, 2)`` px about the centre of mass) rotated and moved to this configuration."""
        aligned = _aligned(np.asarray(mav_contour, dtype=float))
        return _place(aligned, np.array([self.center_px]), np.array([self.angle]))[0]


def principal_axes(points: np.ndarray) -> tuple[np.ndarray, float, np.ndarray, float]:
    """Major and minor axes of a contour: unit directions and the contour's extent (px) along each.

    ``points``: ``(n, 2)`` px. Returns ``(e_major, length_major, e_minor, length_minor)``.
    """
    centred = points - points.mean(axis=0)
    _, vectors = np.linalg.eigh(centred.T @ centred)
    e_major, e_minor = vectors[:, 1], vectors[:, 0]
    extent = [float(np.ptp(centred @ e)) for e in (e_major, e_minor)]
    return e_major, extent[0], e_minor, extent[1]


def _aligned(mav_contour: np.ndarray) -> np.ndarray:
    """``mav_contour`` rotated about its origin (the centre of mass) so that its major axis lies along +u."""
    e_major, _, _, _ = principal_axes(_densified(mav_contour))  # evenly spread points: axes of the outline
    c, s = e_major
    return mav_contour @ np.array([[c, -s], [s, c]])  # row-wise R(-φ) x with φ = atan2(s, c)


def _densified(closed: np.ndarray, step: float = 1.0) -> np.ndarray:
    """Points along the closed polygon ``closed`` (its vertices and every ``step`` px between them)."""
    nxt = np.roll(closed, -1, axis=0)
    out = []
    for a, b in zip(closed, nxt, strict=True):
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / step))
        out.append(a + (b - a) * (np.arange(n)[:, None] / n))
    return np.concatenate(out)


def _place(contour: np.ndarray, centres: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """``(k, n, 2)``: ``contour`` (about its origin) rotated by each of ``angles`` and moved to each of ``centres``."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    x, y = contour[:, 0][None], contour[:, 1][None]
    return np.stack((c * x - s * y, s * x + c * y), axis=-1) + centres[:, None, :]


class _Interior:
    """Raster interior test of the filled contour C_a: distance (px) to its outside at the nearest pixel."""

    def __init__(self, contour: np.ndarray, shape: tuple[int, int]):
        filled = np.zeros(shape, np.uint8)
        cv2.drawContours(filled, [contour.reshape(-1, 1, 2).astype(np.int32)], -1, 1, thickness=cv2.FILLED)
        padded = cv2.copyMakeBorder(filled, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)  # outside the image is outside
        self.distance = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Distance transform at the pixels nearest ``points`` (``(..., 2)`` px); 0 outside the image."""
        h, w = self.distance.shape
        u = np.rint(points[..., 0]).astype(np.intp)
        v = np.rint(points[..., 1]).astype(np.intp)
        inside = (u >= 0) & (u < w) & (v >= 0) & (v < h)
        out = np.zeros(points.shape[:-1], np.float32)
        out[inside] = self.distance[v[inside], u[inside]]
        return out


def aperture_contour(aperture_mask: np.ndarray) -> np.ndarray | None:
    """C_a: the outer contour (``(n, 2)`` px, every boundary pixel) of the largest region of ``aperture_mask``.

    ``None`` when the mask is empty.
    """
    binary = (np.asarray(aperture_mask) != 0).astype(np.uint8)
    contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return None
    largest = max(contours, key=cv2.contourArea)
    return largest.reshape(-1, 2).astype(float)


def _acute(a: np.ndarray, b: float) -> np.ndarray:
    """Acute angle (rad, 0 … π/2) between lines of slopes ``a`` and ``b`` (rad)."""
    d = np.mod(a - b, math.pi)
    return np.minimum(d, math.pi - d)


def _candidate_pairs(c_a: np.ndarray, mav_major: float, params: ProfileParams) -> tuple[np.ndarray, np.ndarray]:
    """Point pairs of C_a at least M_Cm apart, ranked by m_l = min(m1, m2) (§IV-E): ``(m, 2, 2)`` px and m_l.

    G is these pairs whose segment lies inside C_a (:func:`_inside_segments`); ranking first and testing the
    segments in rank order, chunk by chunk, gives G in the same order and stops testing once V is full.
    """
    step = max(1, round(params.pair_spacing_px))
    points = c_a[::step]
    i, j = np.triu_indices(len(points), k=1)
    a, b = points[i], points[j]
    length = np.linalg.norm(b - a, axis=1)
    keep = length >= mav_major
    a, b, length = a[keep], b[keep], length[keep]
    e_major, len_major, e_minor, len_minor = principal_axes(c_a)
    slope = np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0])
    m1 = params.w1 * np.abs(length - len_major) / len_major + params.w2 * _acute(slope, _angle(e_major))
    m2 = params.w1 * np.abs(length - len_minor) / len_minor + params.w2 * _acute(slope, _angle(e_minor))
    score = np.minimum(m1, m2)
    order = np.argsort(score, kind="stable")
    return np.stack((a[order], b[order]), axis=1), score[order]


def _angle(e: np.ndarray) -> float:
    """Slope (rad) of direction ``e``."""
    return math.atan2(float(e[1]), float(e[0]))


def _inside_segments(pairs: np.ndarray, interior: _Interior) -> np.ndarray:
    """l ∈ C_a for each pair: every pixel of the segment but the end pixels (on C_a) strictly inside C_a."""
    a, b = pairs[:, 0], pairs[:, 1]
    length = np.linalg.norm(b - a, axis=1)
    t = np.linspace(0.0, 1.0, max(3, math.ceil(float(length.max(initial=0.0))) + 1))
    along = a[:, None, :] + (b - a)[:, None, :] * t[None, :, None]
    near_end = np.minimum(t[None, :], 1.0 - t[None, :]) * length[:, None] < 1.5
    return ((interior.depth(along) > 1.0) | near_end).all(axis=1)


def _slope(pairs: np.ndarray) -> np.ndarray:
    """Slope θ (rad, (-π/2, π/2]) of each pair's segment."""
    d = pairs[:, 1] - pairs[:, 0]
    theta = np.arctan2(d[:, 1], d[:, 0])
    theta = np.where(theta > math.pi / 2, theta - math.pi, theta)
    return np.where(theta <= -math.pi / 2, theta + math.pi, theta)


def _configuration(
    pair: np.ndarray, score: float, centre: np.ndarray, theta: float, shift: float
) -> LaunchConfiguration:
    """A configuration of V from one pair of G, its score, the MAV's centre (px), slope (rad) and shift (px)."""
    return LaunchConfiguration(
        (float(centre[0]), float(centre[1])), float(theta),
        ((float(pair[0, 0]), float(pair[0, 1])), (float(pair[1, 0]), float(pair[1, 1]))), float(score), float(shift),
    )


def _interleaved_shifts(length: float, mav_major: float) -> np.ndarray:
    """Shifts (px) of the sliding search: +1, -1, +2, -2, … until C_m's edge reaches an end of l."""
    reach = math.floor((length - mav_major) / 2.0)
    k = np.arange(1, reach + 1, dtype=float)
    return np.stack((k, -k), axis=1).ravel()


def profile_analysis(
    aperture_mask: np.ndarray, mav_contour: np.ndarray, params: ProfileParams | None = None
) -> list[LaunchConfiguration]:
    """Launch configurations at which the MAV contour fits inside the aperture (§IV-E, Algorithm 1 lines 10-35).

    Args:
        aperture_mask: ``(h, w)`` image I_binary of the aperture: non-zero in the aperture's free region;
            C_a is the outer contour of its largest region.
        mav_contour: C_m, ``(n, 2)`` closed polygon (px) in the same image's scale, about the MAV's centre of
            mass (:func:`~.silhouette.mav_contour`); its major axis is aligned with each segment l.
        params: the search's parameters (:class:`ProfileParams`).

    Returns:
        V: at most ``params.n_valid`` configurations, those of step ii first (by rank), then those of the
        sliding search (step iii); with ``centre_radius_px`` each of them centred (step iv) first, then the
        ones as found; empty when the MAV fits nowhere.
    """
    params = params or ProfileParams()
    c_a = aperture_contour(aperture_mask)
    if c_a is None or len(c_a) < 3:
        return []
    mav = _aligned(np.asarray(mav_contour, dtype=float))
    mav_major = float(np.ptp(mav[:, 0]))
    boundary = _densified(mav)  # C_m's boundary every pixel at most
    interior = _Interior(c_a, np.asarray(aperture_mask).shape[:2])
    pairs, scores = _candidate_pairs(c_a, mav_major, params)
    thetas, mids = _slope(pairs), pairs.mean(axis=1)
    need = params.clearance_px + RASTER_MARGIN_PX
    valid: list[LaunchConfiguration] = []
    failed: list[int] = []
    for start in range(0, len(pairs), params.chunk):  # steps i and ii, in rank order
        in_g = start + np.flatnonzero(_inside_segments(pairs[start : start + params.chunk], interior))
        fits = (interior.depth(_place(boundary, mids[in_g], thetas[in_g])) > need).all(axis=1)
        for n in in_g[fits]:
            if _admitted(_configuration(pairs[n], float(scores[n]), mids[n], float(thetas[n]), 0.0), valid, params):
                return _with_centred(valid, interior, boundary, params)
        failed.extend(int(n) for n in in_g[~fits])
    for k in failed:  # step iii: the sliding search along each initially-failed pair
        length = float(np.linalg.norm(pairs[k, 1] - pairs[k, 0]))
        shifts = _interleaved_shifts(length, mav_major)
        if not len(shifts):
            continue
        direction = np.array([math.cos(thetas[k]), math.sin(thetas[k])])
        centres = mids[k] + shifts[:, None] * direction
        fits = (interior.depth(_place(boundary, centres, np.full(len(shifts), thetas[k]))) > need).all(axis=1)
        first = np.flatnonzero(fits)
        if len(first):
            config = _configuration(pairs[k], float(scores[k]), centres[first[0]], float(thetas[k]),
                                    float(shifts[first[0]]))
            if _admitted(config, valid, params):
                break
    return _with_centred(valid, interior, boundary, params)


def _margin(interior: _Interior, boundary: np.ndarray, centres: np.ndarray, theta: float) -> np.ndarray:
    """The least distance transform (px) over C_m's ``boundary`` placed at each of ``centres`` ``(k, 2)``, turned by
    ``theta``."""
    return interior.depth(_place(boundary, centres, np.full(len(centres), theta))).min(axis=1)


def centred(config: LaunchConfiguration, interior: _Interior, boundary: np.ndarray, radius: float
            ) -> LaunchConfiguration:
    """``config`` moved, at its angle, to the centre within ``radius`` (px) at which C_m^t (``boundary``, C_m's
    boundary aligned with +u) keeps the largest distance from C_a (step iv, a departure).

    A grid of 2 px over the disc, then of 1 px about its best; of equal margins the nearest to ``config``'s centre.
    Its ``pair_px``, ``score`` and ``shift_px`` stay those it was found with.
    """
    start = np.asarray(config.center_px, dtype=float)
    best, best_margin = start, float(_margin(interior, boundary, start[None], config.angle)[0])
    for step, reach in ((2.0, radius), (1.0, 2.0)):
        k = np.arange(-math.floor(reach / step), math.floor(reach / step) + 1) * step
        offsets = np.stack(np.meshgrid(k, k), axis=-1).reshape(-1, 2)
        offsets = offsets[np.hypot(offsets[:, 0], offsets[:, 1]) <= reach]
        centres = best + offsets
        if step < 2.0:
            centres = centres[np.linalg.norm(centres - start, axis=1) <= radius]
        margins = _margin(interior, boundary, centres, config.angle)
        top = np.flatnonzero(margins >= margins.max() - 1e-6)
        pick = top[np.argmin(np.linalg.norm(centres[top] - start, axis=1))]
        if margins[pick] > best_margin + 1e-6:
            best, best_margin = centres[pick], float(margins[pick])
    return LaunchConfiguration((float(best[0]), float(best[1])), config.angle, config.pair_px, config.score,
                               config.shift_px)


def _admitted(config: LaunchConfiguration, valid: list[LaunchConfiguration], params: ProfileParams) -> bool:
    """Append ``config`` to V (``valid``) unless, with step iv, it would centre where one of V does (an angle
    within ``distinct_angle`` rad and a centre within ``centre_radius_px`` px of it); whether V is now full."""
    redundant = params.centre_radius_px > 0 and any(
        abs(config.angle - o.angle) <= params.distinct_angle
        and math.dist(config.center_px, o.center_px) <= params.centre_radius_px for o in valid)
    if not redundant:
        valid.append(config)
    return len(valid) >= params.n_valid


def _with_centred(valid: list[LaunchConfiguration], interior: _Interior, boundary: np.ndarray,
                  params: ProfileParams) -> list[LaunchConfiguration]:
    """Step iv: V's configurations centred (duplicates dropped), then the uncentred ones, at most N_v."""
    if params.centre_radius_px <= 0 or not valid:
        return valid
    out: list[LaunchConfiguration] = []
    for config in [centred(c, interior, boundary, params.centre_radius_px) for c in valid] + valid:
        if not any(math.dist(config.center_px, o.center_px) < 0.5 and abs(config.angle - o.angle) < 1e-6
                   for o in out):
            out.append(config)
    return out[: params.n_valid]
