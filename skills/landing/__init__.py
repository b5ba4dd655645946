"""UAV takeoff, tracking and landing on a moving platform (Palafox et al. 2019).

Algorithms, numpy in and out:

- :mod:`.detection` — the red landing platform in a downward camera frame
  (Algorithm 1, §3.2): HSV red mask, Gaussian blur, Canny, Hough lines,
  polygon fitting, centroid from first-order moments, inverse pinhole with Z
  from the sonar, frames discarded beyond an IMU tilt threshold.
- :mod:`.prediction` — constant-velocity Kalman filter of the platform in the
  world frame and its prediction over the path time (§3.3.2).
- :mod:`.control` — height-adaptive PI (§3.3.1) and the platform tracker that
  feeds it the measured (reactive) or predicted (predictive) platform position.
- :mod:`.touchdown` — the landed test (§3.3.1): sonar low persistently and
  the IMU's samples showing the moving platform.

Behaviours built on them, on the UAV's onboard information only (sensors,
state estimate, URDF mounts; the platform's size as a static prior):

- :mod:`.tracking` — the tracking module one UAV's skills share (detection
  posed with the estimate at each frame's stamp, tracker, loss clock, the
  five states of §3.1) and the gain schedules.
- :mod:`.skills` — ``takeoff``, ``follow`` (``track_reactive``,
  ``track_predictive``), ``land``, ``relocalize`` for the ``ardrone2`` and
  ``drive_pattern`` for the ``summit_xl``.
- :mod:`.conditions` — ``platform_lost``, ``landed``, ``flight_time``: the
  transitions of the state machine (``missions/subtrees/landing_cycle.yaml``).
"""
