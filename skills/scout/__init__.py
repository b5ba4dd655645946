"""The visually-servoed micro-scout (Arora & Papachristos, §IV-G, §V): guided by the carrier over the team link.

- :mod:`.relay` — the MAV's front-camera frames JPEG-encoded, sent over the team link, decoded on the carrier;
- :mod:`.depth` — the pluggable dense depth estimator and its default, a monocular error model stand-in;
- :mod:`.policy` — three column averages → the action vector f / r / l with a direction bias;
- :mod:`.detection` — the pluggable object-of-interest detector and its default, HSV colour and shape checks;
- :mod:`.plugins` — how depth estimators and detectors are named (entry points, import targets) and built;
- :mod:`.skills` — the ``scout`` skill and the ``object_found`` condition;
- :mod:`.recovery` — ``scout_land`` and ``scout_return``, the preempting branches (battery, operator recall).
"""
