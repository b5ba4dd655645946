"""The visually-servoed exploration policy: three column averages of a depth map → forward or a yaw turn.

Arora & Papachristos, §IV-G: "We divide the estimated depth image into three
column subsets, and follow-up with pixel-averaging that allows us to compute a
3×1 action vector. A simple control allocation comprises of three actions:
forward (f), clockwise yaw (r), counter-clockwise yaw (l), and aims to move
and/or orient the MAV towards a region of greater depth." §V: "a
directionality bias can be applied to make each MAV favor a right-or-left turn
direction".

With ``D̄_l, D̄_c, D̄_r`` the mean depth of the left, centre and right thirds
of the image columns (within a band of rows), and the bias ``b`` in [-1, 1]
(> 0 favours the right), the action vector is

    a = (a_f, a_r, a_l) = (D̄_c, (1 + b) D̄_r, (1 − b) D̄_l)

and the action taken is its largest entry. The policy compares depths only
with each other, so a depth map known up to a scale (monocular) serves.

Image frame: columns left to right as the camera sees them (the MAV's left is
the image's left); yaw rates rad/s, counter-clockwise (left) positive about
world z; speeds m/s in the MAV's heading frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FORWARD, CLOCKWISE, COUNTER_CLOCKWISE = "f", "r", "l"
"""The three actions of §IV-G: forward, clockwise yaw (turn right), counter-clockwise yaw (turn left)."""
ACTIONS = (FORWARD, CLOCKWISE, COUNTER_CLOCKWISE)
"""The order of the entries of the action vector."""


@dataclass(frozen=True)
class Decision:
    """One evaluation of the policy.

    Attributes:
        columns: ``(D̄_l, D̄_c, D̄_r)``, mean depth of the left, centre and right column thirds (the map's scale).
        vector: ``(a_f, a_r, a_l)``, the biased action vector.
        action: the action taken (:data:`FORWARD`, :data:`CLOCKWISE` or :data:`COUNTER_CLOCKWISE`).
    """

    columns: tuple[float, float, float]
    vector: tuple[float, float, float]
    action: str


def column_averages(depth: np.ndarray, rows: tuple[float, float] = (0.0, 1.0)) -> tuple[float, float, float]:
    """Mean depth of the left, centre and right thirds of the columns of ``depth`` ``(h, w)``.

    ``rows``: the band of rows averaged, as fractions of the height from the top (0, 1: all of them).
    """
    h = depth.shape[0]
    top, bottom = int(round(rows[0] * h)), max(int(round(rows[1] * h)), int(round(rows[0] * h)) + 1)
    left, centre, right = np.array_split(depth[top:bottom], 3, axis=1)
    return float(left.mean()), float(centre.mean()), float(right.mean())


def decide(depth: np.ndarray, bias: float = 0.0, rows: tuple[float, float] = (0.0, 1.0)) -> Decision:
    """The action towards greater depth: the largest entry of ``a = (D̄_c, (1 + b) D̄_r, (1 − b) D̄_l)``.

    ``bias`` ``b`` in [-1, 1]: > 0 favours clockwise (right) turns, < 0 counter-clockwise (left) turns.
    Ties go to the earlier action in :data:`ACTIONS` (forward first).
    """
    if not -1.0 <= bias <= 1.0:
        raise ValueError(f"the direction bias must lie in [-1, 1], got {bias}")
    d_l, d_c, d_r = column_averages(depth, rows)
    vector = (d_c, (1.0 + bias) * d_r, (1.0 - bias) * d_l)
    return Decision((d_l, d_c, d_r), vector, ACTIONS[int(np.argmax(vector))])


def velocity_command(action: str, forward_speed: float, turn_speed: float, yaw_rate: float) -> tuple[float, float]:
    """``(vx, yaw_rate)`` (m/s, rad/s) of an action: ``forward_speed`` ahead, or ``turn_speed`` and ∓``yaw_rate``.

    Clockwise (``r``) is a negative yaw rate about the up axis, counter-clockwise (``l``) positive.
    """
    if action == FORWARD:
        return forward_speed, 0.0
    if action == CLOCKWISE:
        return turn_speed, -yaw_rate
    if action == COUNTER_CLOCKWISE:
        return turn_speed, yaw_rate
    raise ValueError(f"unknown action {action!r}; expected one of {', '.join(ACTIONS)}")
