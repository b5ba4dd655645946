"""The plug-in contract between the simulator and the decisions: what skills and conditions may hold.

Everything a skill or condition holds is defined here (or in the node API of
:mod:`marsupial.trees`) as data: readings in (:mod:`.readings`), commands out
(:mod:`.commands`), the robot as one node sees it (:mod:`.views`: the
readings of this tick and an outbox, never a handle on the simulator), the
capabilities a robot has (:mod:`.capabilities`), typed blackboard keys
(:mod:`.keys`), what the robots' designers know (:mod:`.model`,
:mod:`.kinematics`, :mod:`.tags`, :mod:`.silhouette`), what an operator
knows of the scene (:mod:`.priors`), the typed settings of a mission's world
and team sections (:mod:`.config`) and the errors for bad input
(:mod:`.errors`). The world implements it; the runtime and the skills consume
it. It imports neither pybullet nor OpenCV, nor the world or the runtime.
"""
