"""UGV–UGV coordinated docking with embedded vision (Zhao et al.): the child's vision algorithms.

Plain functions, numpy in and out; frames as in the paper (image pixels u
right, v down; the child's ground frame {R}; metres and radians):

- :mod:`.features` — the benchmark's features (u_h, v_h, k_h, s_u, N_G) in one
  frame of the child's camera (§3.1, eq. 5), from the ``rgb`` of the
  :class:`~marsupial.api.readings.CameraImage` its ``camera`` port delivers;
- :mod:`.geometry` — the imaging of H_GS (eqs. 1, 3, 4) and its theoretical slope k̄_h (eq. 6);
- :mod:`.criterion` — C2 on the recorded criterion list f_list (Remark 2,
  ``data/<robot>_f_list.yaml``) and C3 (Remark 3, eq. 7);
- :mod:`.precision` — the precision analysis of the final stage (§3.4, eqs. 8–16) on Table 1's parameters;
- :mod:`.steering` — the control laws of the task states on the features (plain functions).

The mission nodes built on them (``docs/ugv_docking.md``):

- :mod:`.vision` — the child's benchmark view shared by its nodes, and the team-link messages;
- :mod:`.conditions` — the transitions C1–C4;
- :mod:`.child` — the child's states: ``child_link``, ``child_approach``, ``child_match``, ``child_direct``;
- :mod:`.reposition` — ``child_reposition``: the independent docking's drive onto the entry line, estimated
  from one view by inverting eqs. (1), (4) and (6) (:mod:`.geometry`);
- :mod:`.mother` — the mother's states: ``mother_link``, ``mother_align``, ``mother_direct``;
- :mod:`.station` — the lifting station after the docking: ``lift``, ``carry``, ``release``.
"""
