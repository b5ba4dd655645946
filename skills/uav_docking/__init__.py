"""VTOL-UAV docking on a mobile manipulator (Narváez et al., 2020): the algorithms of the Motion Engine.

Plain functions and classes with numpy in and out, all in the manipulator
frame M (``arm_base`` of the carrier), metres and radians:

- :mod:`.pose` — AprilTag bundle detection, bundle pose by one solvePnP over
  every visible tag, and the UAV pose in M by eq. (1);
- :mod:`.cord` — the switching-regression cord (Algorithm 1, eqs. 2–6);
- :mod:`.vicinity` — the vicinity of ellipse sections around the cord (eqs. 7–8);
- :mod:`.zones` — the local map of obstacles and prohibited zones, the cord
  repair that keeps the vicinity free (Fig. 9), and the random-sample validation;
- :mod:`.graph` — the OMPL RRT* graph over IK-valid poses of the vicinity,
  recycling the previous graph (Algorithm 2);
- :mod:`.selection` — P_VS, the tracking state and path length (eqs. 9–12), P_R;
- :mod:`.engine` — the Motion Engine (Fig. 5) at f_B and f_O = 2·f_B in simulated time.

The IK engine over random end-effector poses (Algorithm 3) and the joint
trajectories timed by toppra within 15 rpm are shared with the aperture
skills: :mod:`marsupial.skills.common.ik_engine`, :mod:`marsupial.skills.common.trajectory`.
"""
