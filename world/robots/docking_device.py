"""Docking device of Narváez et al. (§IV-C, Figs. 11-12): electromagnet + servo levers.

Two complementary parts. *Part A*, on the carrier's end effector, holds a
12 V–250 N electromagnet and a set of levers that a micro servo closes
through gears; *Part B* is a light adapter with a metal disc under the UAV.
The sequence (Fig. 12): Part A approaches Part B until they are closer
than ``D_c`` (the ``contact`` skill's parameter, 6 mm); the electromagnet pulls them into an initial contact; the
servo then closes the levers around Part B's ring, which fixes the UAV to
the arm (here: a rigid pybullet constraint). Releasing opens the levers and
switches the magnet off.

Frames and conventions. Part A's link frame has its origin at the centre of
its mating face and z pointing away from the arm (the approach direction).
Part B is the link named ``part_b`` of any other robot of the world, origin
at the centre of its mating face, z pointing into the UAV (up when the UAV
is level). Docked, the two origins coincide and the z axes are parallel.

Magnet force. A holding magnet's pull falls off steeply with the air gap
``d``; we use ``F(d) = F_hold / (1 + d / d_0)²`` with ``F_hold = 250 N``
(§V-B) and ``d_0 = 2 mm``, applied only within the magnet's reach
(``capture_distance``). At its 10 mm it still pulls 6.9 N, more than the
4.9 N weight of the 0.5 kg Bebop 2, so a hovering UAV is drawn into contact.

Reach and D_c. §IV-C: "When Part B is aligned at a distance less than
D_c with the Part A, the electromagnet is activated to force an initial
contact"; the figure printed with it in the available text ("0 mm") is the
gap the magnet closes, not where it is switched on. The reach is taken as
the range of such a magnet on a light adapter disc, 10 mm, and ``D_c``
(where the skill switches it on) must lie within it.

Robots that want to know implement ``on_docked(charger: bool)`` (called
when the levers lock; ``charger`` says whether the carrier charges the UAV,
12.6 V / 3.5 A on Narváez's carrier, §V-A) and ``on_released()``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from .attachment import place_link_at, set_collisions, weld
from .base import rotation_matrix

if TYPE_CHECKING:
    from .base import Robot

CAPTURE_DISTANCE = 0.010  # m, the magnet's reach: range within which it draws Part B into contact (D_c ≤ it, §IV-C)
HOLDING_FORCE = 250.0  # N, the 12 V–250 N electromagnet of Part A, §V-B
FORCE_LENGTH = 0.002  # m, d_0 of the pull F(d) = F_hold / (1 + d / d_0)²
CONTACT_DISTANCE = 0.004  # m: gap counted as contact (touching faces rest ≈2 mm apart in pybullet)
LOCK_TIME = 0.3  # s of simulated time for the micro servo to close the levers (§IV-C: "considerable speed")
LATERAL_TOLERANCE = 0.015  # m: Part B centre off Part A's axis still guided by the conical structure
TILT_TOLERANCE = math.radians(15.0)  # rad: roll/pitch between the parts the cone absorbs (§IV-C)
LOCK_FORCE = 2000.0  # N: strength of the locked joint


class DockingDevice:
    """Part A of the docking device on ``carrier``'s link ``link``.

    The carrier calls :meth:`pre_physics` every physics step (magnet pull,
    lever actuation). Commands: :meth:`magnet_on`, :meth:`magnet_off`,
    :meth:`lock`, :meth:`release`. :attr:`state` is ``"open"``,
    ``"magnet"`` (magnet on, levers open) or ``"locked"``.

    Args:
        carrier: robot carrying Part A.
        link: name of Part A's link.
        capture_distance: the magnet's reach (m); the skill's ``D_c`` (§IV-C) lies within it.
        holding_force: magnet pull at contact (N), §V-B.
        force_length: ``d_0`` (m) of the pull's fall-off with the gap.
        contact_distance: gap (m) between the faces, along Part A's axis, up to which the parts count as in contact.
        lock_time: lever actuation time (s, simulated).
        lateral_tolerance: largest offset (m) of Part B from Part A's axis for :meth:`aligned`.
        tilt_tolerance: largest angle (rad) between the parts' axes for :meth:`aligned`.
        charger: whether the carrier charges a docked UAV (passed to ``on_docked``).
    """

    def __init__(
        self,
        carrier: Robot,
        link: str = "part_a",
        *,
        capture_distance: float = CAPTURE_DISTANCE,
        holding_force: float = HOLDING_FORCE,
        force_length: float = FORCE_LENGTH,
        contact_distance: float = CONTACT_DISTANCE,
        lock_time: float = LOCK_TIME,
        lateral_tolerance: float = LATERAL_TOLERANCE,
        tilt_tolerance: float = TILT_TOLERANCE,
        charger: bool = True,
    ):
        if not 0.0 <= contact_distance <= capture_distance:
            raise ValueError(
                f"need 0 <= contact_distance <= capture_distance; got {contact_distance}, {capture_distance}"
            )
        self.carrier = carrier
        self.world = carrier.world
        self.cid = carrier.cid
        self.link = carrier.link_index(link)
        self.capture_distance = capture_distance
        self.holding_force = holding_force
        self.force_length = force_length
        self.contact_distance = contact_distance
        self.lock_time = lock_time
        self.lateral_tolerance = lateral_tolerance
        self.tilt_tolerance = tilt_tolerance
        self.charger = charger
        self.magnet = False
        self.docked: Robot | None = None  # the UAV held by the levers
        self._constraint: int | None = None
        self._locking: Robot | None = None  # UAV the levers are closing on
        self._lock_due_step = 0

    # ---------------------------------------------------------------- state
    @property
    def state(self) -> str:
        """``"locked"`` (levers closed on a UAV), ``"magnet"`` (magnet on) or ``"open"``."""
        if self.docked is not None:
            return "locked"
        return "magnet" if self.magnet else "open"

    @property
    def locking(self) -> bool:
        """True while the levers are closing (between :meth:`lock` and the lock or its failure)."""
        return self._locking is not None

    def part_a_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position (m) and rotation matrix of Part A's frame (z = approach direction)."""
        p, q = self.carrier.link_pose(self.link)
        return p, rotation_matrix(q)

    def part_b_pose(self, uav: Robot) -> tuple[np.ndarray, np.ndarray]:
        """World position (m) and rotation matrix of ``uav``'s Part B frame."""
        p, q = uav.link_pose("part_b")
        return p, rotation_matrix(q)

    def distance_to(self, uav: Robot) -> float:
        """Distance (m) between the centres of Part A's and ``uav``'s Part B mating faces."""
        p_a, _ = self.part_a_pose()
        p_b, _ = self.part_b_pose(uav)
        return float(np.linalg.norm(p_b - p_a))

    def offset_to(self, uav: Robot) -> tuple[float, float, float]:
        """``(axial, lateral, tilt)`` of ``uav``'s Part B seen from Part A.

        ``axial`` (m): height of Part B's face above Part A's face along Part
        A's z; ``lateral`` (m): distance of Part B's centre from Part A's
        axis; ``tilt`` (rad): angle between the two parts' z axes.
        """
        p_a, R_a = self.part_a_pose()
        p_b, R_b = self.part_b_pose(uav)
        p_b_A = R_a.T @ (p_b - p_a)
        tilt = math.acos(max(-1.0, min(1.0, float(R_a[:, 2] @ R_b[:, 2]))))
        return float(p_b_A[2]), float(math.hypot(p_b_A[0], p_b_A[1])), tilt

    def aligned(self, uav: Robot) -> bool:
        """True when ``uav``'s Part B is on Part A's axis and parallel to it, within the tolerances."""
        _, lateral, tilt = self.offset_to(uav)
        return lateral <= self.lateral_tolerance and tilt <= self.tilt_tolerance

    def in_contact(self, uav: Robot) -> bool:
        """True when ``uav``'s Part B rests on Part A: the faces within ``contact_distance`` along Part A's axis,
        Part B's centre and axis within the lateral and tilt tolerances the conical structure centres (§IV-C)."""
        return abs(self.offset_to(uav)[0]) <= self.contact_distance and self.aligned(uav)
    def contact_switch(self) -> bool:
        """The limit switch under Part A's face: closed while some UAV's Part B rests seated on it (device state)."""
        return self._uav_in_contact() is not None

    def status(self) -> dict[str, Any]:
        """JSON-ready summary: state, docked UAV name (or ``None``), levers moving."""
        return {
            "state": self.state,
            "docked": self.docked.name if self.docked is not None else None,
            "locking": self.locking,
        }

    # ------------------------------------------------------------- commands
    def magnet_on(self) -> None:
        """Energise the electromagnet: Part B within its reach (``capture_distance``) is pulled onto Part A."""
        self.magnet = True

    def magnet_off(self) -> None:
        """De-energise the electromagnet (a locked UAV stays held by the levers)."""
        self.magnet = False
    def lock(self) -> bool:
        """Start closing the levers on the UAV in contact with Part A.

        Returns False (and does nothing) when no Part B is in contact. Otherwise
        the levers close within ``lock_time`` of simulated time; if Part B is
        still in contact then, the UAV is fixed rigidly to Part A at its
        current relative pose, ``state`` becomes ``"locked"`` and the UAV's
        ``on_docked(charger=...)`` is called. Returns True if already locked
        or locking (calling it again does not restart the levers).
        """
        if self.docked is not None or self._locking is not None:
            return True
        uav = self._uav_in_contact()
        if uav is None:
            return False
        self._locking = uav
        self._lock_due_step = self.world.clock.steps + self.world.clock.steps_for(self.lock_time)
        return True
    def release(self) -> None:
        """Open the levers and switch the magnet off; a docked UAV is freed (``on_released()``)."""
        self.magnet = False
        self._locking = None
        uav = self.docked
        if uav is None:
            return
        pybullet.removeConstraint(self._constraint, physicsClientId=self.cid)
        self._constraint = None
        self.docked = None
        self._set_collisions(uav, enable=True)
        if hasattr(uav, "on_released"):
            uav.on_released()

    # ------------------------------------------------------------- stepping
    def pre_physics(self, dt: float) -> None:
        """Apply the magnet's pull and finish a lever closing that is due (called every physics step)."""
        if self.magnet and self.docked is None:
            self._pull()
        if self._locking is not None and self.world.clock.steps >= self._lock_due_step:
            uav, self._locking = self._locking, None
            if self.in_contact(uav):
                self._attach(uav)

    def _candidates(self) -> list[Robot]:
        return [r for r in self.world.robots.values() if r is not self.carrier and "part_b" in r.links]

    def _uav_in_contact(self) -> Robot | None:
        touching = [(self.distance_to(r), r.name, r) for r in self._candidates() if self.in_contact(r)]
        return min(touching)[2] if touching else None

    def _pull(self) -> None:
        cid = self.cid
        p_a, R_a = self.part_a_pose()
        for uav in self._candidates():
            p_b, _ = uav.link_pose("part_b")
            gap = p_a - p_b
            d = float(np.linalg.norm(gap))
            if d > self.capture_distance:
                continue
            # faces touching: the pot magnet pulls along its axis onto its face (the centre-to-centre
            # direction turns sideways there, and its 100 N-class pull would fling the UAV off the face)
            touching = float(-gap @ R_a[:, 2]) <= self.contact_distance or d <= 1e-9
            direction = -R_a[:, 2] if touching else gap / d
            force = self.holding_force / (1.0 + d / self.force_length) ** 2 * direction
            on_b, on_a = force.tolist(), (-force).tolist()  # equal and opposite
            pybullet.applyExternalForce(
                uav.body_id, uav.links["part_b"], on_b, p_b.tolist(), pybullet.WORLD_FRAME, physicsClientId=cid
            )
            pybullet.applyExternalForce(
                self.carrier.body_id, self.link, on_a, p_a.tolist(), pybullet.WORLD_FRAME, physicsClientId=cid
            )

    def attach_now(self, uav: Robot) -> None:
        """Put ``uav``'s Part B on Part A and lock at once (a UAV that starts the run stored)."""
        if self.docked is not None:
            raise ValueError(f"{self.carrier.name}'s Part A already holds {self.docked.name}")
        place_link_at(uav, "part_b", *self.carrier.link_pose(self.link))
        self._attach(uav)

    def _attach(self, uav: Robot) -> None:
        """Fix ``uav``'s base to Part A at their current relative pose."""
        self._constraint = weld(self.carrier.body_id, self.link, uav.body_id, -1, LOCK_FORCE, self.cid)
        self.docked = uav
        self._set_collisions(uav, enable=False)
        if hasattr(uav, "on_docked"):
            uav.on_docked(charger=self.charger)

    def _set_collisions(self, uav: Robot, enable: bool) -> None:
        """A docked UAV is part of the carrier: no contacts between the two while locked."""
        set_collisions(
            self.carrier.body_id, list(self.carrier.links.values()), uav.body_id, list(uav.links.values()),
            enable, self.cid,
        )
