"""Capsule proxies for self-collision: each moving body of the reduced model (the links one joint
moves) gets one or a few capsules that enclose its URDF collision geometry (mesh vertices, or the
support points of URDF primitives; the visual mesh for links listed in ``collision.use_visual``).

A capsule is a segment ``a-b`` in its frame plus a radius; the signed distance of two capsules is
the distance of their segments minus both radii (negative = penetration depth), exact and cheap,
with an analytic gradient:

    d = |p - q| - r_A - r_B,   n = (p - q) / |p - q|,
    dd/dv = n^T (J_A,lin + [w_A] x (p - o_A)) - n^T (J_B,lin + [w_B] x (q - o_B))

with p, q the closest points and J the world-aligned frame Jacobians (the closest points' motion
along the segments does not change d to first order).

Pairs that are never checked (:func:`imesh.robot.capsules.pairs.ignore_rule`): capsules of the
same body, of a body and its parent body, of both feet (the footprints keep them apart), and
pairs closer than ``NOMINAL_CLEARANCE_M`` in the nominal standing pose.
``robots/<name>/collision_pairs.toml`` lists them (``imesh robots NAME --collisions --write``
regenerates it; a test checks that the file equals the rule's output).

Modules, one concept each:

- :mod:`.model`: the :class:`~.model.Capsule` and :class:`~.model.CapsuleModel` types, signed
  distances of capsule pairs over frames and their gradient rows;
- :mod:`.fit`: capsules fitted to points and triangle meshes (no robot);
- :mod:`.bodies`: a robot's bodies and their geometry in the body frame;
- :mod:`.pairs`: the ignore rule and ``collision_pairs.toml``;
- :mod:`.cache`: fitted capsules on disk;
- :mod:`.mesh_check`: distances of the URDF's own geometry between the same bodies (coal);
- :mod:`.obstacles`: capsules moving with the frames (a partner robot's) and their distances
  to a robot's capsules;
- :mod:`.robot`: a robot's capsule model (fit, cache, ignore list) and its description.
"""
