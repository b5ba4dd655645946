"""Control laws of the coordinated docking (Zhao et al., §3.3) on the benchmark features: plain functions.

The paper states what each task state achieves, not its control law; these
are the simplest laws that do it, uncalibrated as the paper asks (no camera
intrinsics: pixel errors are normalised by the half image width W/2):

- :func:`centring_rate` — the child turns so that I_h comes to a target
  column (approaching: the image centre, "with the guide of image feature u_h");
- :func:`target_column` — where the child keeps I_h while matching: the
  image centre shifted against k_h's sign, so that the child heads for a
  point of the entry line beside E and comes onto it (Remark 1: k_h's sign
  tells on which side of the entry direction it is);
- :func:`match_command` — matching, "the child robot advances and rotates
  alternately until the formula (7) is met": rotate in place while I_h is
  off its column, advance while s_u < s_u^e, back off when it is there but
  not aligned;
- :func:`align_rate` — the mother rotates by Remark 1: k_h < 0 means α < π/2,
  and turning the station counter-clockwise raises α towards π/2.

Frames and units: pixels (u right), turn rates in rad/s counter-clockwise
(seen from above), speeds in m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

from .criterion import MatchTolerances
from .features import BenchmarkFeatures


def clip(value: float, limit: float) -> float:
    """``value`` limited to ``[-limit, limit]``."""
    return max(-limit, min(limit, value))


def centring_rate(features: BenchmarkFeatures, column: float, gain: float, max_rate: float) -> float:
    """Turn rate (rad/s) bringing I_h to image column ``column`` (px): ``-gain · (u_h - column) / (W/2)``, clipped.

    I_h right of the column (u_h larger) turns the child right (negative rate).
    """
    return clip(-gain * (features.u_h - column) / (features.image_width / 2.0), max_rate)


def target_column(features: BenchmarkFeatures, lateral_gain: float, max_offset: float, delta_k: float) -> float:
    """Image column (px) at which the matching child keeps I_h.

    ``W/2 · (1 - clip(lateral_gain · k_h, max_offset))`` while ``|k_h| ≥ Δk``,
    the centre ``W/2`` once k_h is within Δk. With k_h > 0 (α > π/2: the
    entry line lies to the child's right) I_h is kept left of the centre:
    the child heads right of E, towards the entry line. ``max_offset`` (a
    fraction of W/2) keeps the benchmark in view.
    """
    half = features.image_width / 2.0
    if abs(features.k_h) < delta_k:
        return half
    return half * (1.0 - clip(lateral_gain * features.k_h, max_offset))


@dataclass(frozen=True)
class MatchGains:
    """Settings of :func:`match_command`.

    Attributes:
        speed: forward speed while advancing (m/s); backing off at half of it.
        turn_gain: gain of :func:`centring_rate` (rad/s per half image width).
        max_rate: turn-rate limit (rad/s).
        turn_band: I_h this far (px) off its column makes the child stop and rotate.
        lateral_gain: k_h to image offset gain of :func:`target_column` (half widths per unit k_h).
        max_offset: largest offset of the target column (fraction of W/2).
        retreat: backing off goes on until s_u is below this fraction of s_u^e.
    """

    speed: float = 0.04
    turn_gain: float = 0.6
    max_rate: float = 0.3
    turn_band: float = 12.0
    lateral_gain: float = 0.0
    max_offset: float = 0.3
    retreat: float = 0.8


def match_command(
    features: BenchmarkFeatures, tolerances: MatchTolerances, gains: MatchGains, retreating: bool = False
) -> tuple[float, float, str]:
    """``(v, omega, what)`` of one matching step: rotate, advance or back off (m/s, rad/s, a short description).

    Rotates in place while I_h is more than ``turn_band`` px off its column
    (:func:`target_column`); otherwise advances with the centring turn rate
    while s_u < s_u^e. At s_u ≥ s_u^e with k_h still outside Δk, a child
    steering onto the entry line itself (``lateral_gain`` > 0: the independent
    docking) backs off along its line of sight to E (column W/2) to come in
    again, and goes on backing off (``retreating``, what = "backing off") until
    s_u < ``retreat`` · s_u^e; with ``lateral_gain`` 0 (the coordinated
    docking, where the mother turns the entrance towards the child) it waits
    there, centring I_h.
    """
    column = target_column(features, gains.lateral_gain, gains.max_offset, tolerances.delta_k)
    close = features.s_u >= tolerances.s_u_e
    aligned = abs(features.k_h) < tolerances.delta_k
    retreating = retreating and features.s_u >= gains.retreat * tolerances.s_u_e
    if gains.lateral_gain > 0.0 and (retreating or (close and not aligned)):
        omega = centring_rate(features, features.image_width / 2.0, gains.turn_gain, gains.max_rate)
        return -0.5 * gains.speed, omega, "backing off"
    omega = centring_rate(features, column, gains.turn_gain, gains.max_rate)
    if abs(features.u_h - column) > gains.turn_band:
        return 0.0, omega, "rotating"
    if close:
        return 0.0, omega, "waiting for alignment" if not aligned else "centring"
    return gains.speed, omega, "advancing"


def align_rate(k_h: float, gain: float, max_rate: float) -> float:
    """The mother's turn rate (rad/s) by Remark 1: ``-gain · k_h``, clipped (k_h < 0: α < π/2, turn CCW)."""
    return clip(-gain * k_h, max_rate)
