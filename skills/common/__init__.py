"""Helpers shared by more than one skill family: no skill is registered here.

A family (``aperture``, ``uav_docking``, ``ugv_docking``, ``landing``,
``scout``) imports no other family (an import-linter contract in
``pyproject.toml``); what two of them use lives here instead:

- :mod:`.ik_engine` — inverse kinematics of the carrier's arm: the closed
  form of its spherical wrist and damped least squares on the pinocchio
  model, in batches, in this process or a pool (Narváez et al., Algorithm 3);
- :mod:`.trajectory` — joint paths time-parameterised by toppra within the
  arm's joint speed and acceleration limits;
- :mod:`.carrier_frame` — the carrier's arm frame M in its navigation frame
  and how it moves, from the carrier's own estimate.

These modules import only ``marsupial.api``, ``marsupial.geometry``, the
node API of ``marsupial.trees`` and libraries: never a skill.
"""
