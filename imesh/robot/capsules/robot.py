"""A robot's capsule model: its bodies' capsules (fitted, or read from the cache), the ignore
list of its ``collision_pairs.toml`` (or the rule's), and the text of
``imesh robots NAME --collisions``."""

from __future__ import annotations

import logging
import zipfile
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..collision import pair_key
from .bodies import body_points, robot_bodies
from .cache import capsule_cache_dir, fit_key, read_capsules, write_capsules
from .fit import fit_capsules
from .hulls import hull_vertices
from .mesh_check import MeshCollisionChecker
from .model import Capsule, CapsuleModel
from .pairs import (
    PAIRS_FILE,
    capsule_source,
    capsule_split_excess,
    format_pairs_toml,
    ignore_rule,
    pairs_file,
    read_pairs_toml,
)

if TYPE_CHECKING:  # pragma: no cover - typing only (the Robot uses this package)
    from ..model import Robot

log = logging.getLogger(__name__)


#: (body, (P, 3) points [m], (K, 3) triangles or None) of a body's collision geometry in its
#: frame
BodyGeometry = tuple[str, np.ndarray, "np.ndarray | None"]


def body_geometry(robot: Robot) -> list[BodyGeometry]:
    """Every body with geometry (two points or more), its points and triangles
    (:func:`imesh.robot.capsules.bodies.body_points`): what the capsules are fitted to and the
    hulls spanned over. Reading the meshes is the slow part (G1: 2 s in a new process)."""
    links, _ = robot_bodies(robot)
    inputs = [(body, *body_points(robot, body, members)) for body, members in links.items()]
    return [(body, pts, tris) for body, pts, tris in inputs if len(pts) >= 2]


def fit_robot_capsules(robot: Robot, cache: bool = True,
                       bodies: Sequence[BodyGeometry] | None = None) -> list[Capsule]:
    """Capsules of every body of the robot (:func:`imesh.robot.capsules.fit.fit_capsules` on
    its URDF collision geometry, in the body's frame).

    The fit takes 1-6 s per robot, so its result is kept on disk
    (:func:`imesh.robot.capsules.cache.capsule_cache_dir`),
    keyed by a hash of exactly what it is computed from: every body's name, points and
    triangles, and the fit's settings and ``FIT_VERSION``. Another mesh, URDF origin,
    ``use_visual``/``skip`` list or fit setting gives another key (a robot generated from a
    URDF is cached the same way as a shipped one).

    Args:
        robot: an :class:`imesh.robot.Robot`.
        cache: read and write the cache (when it is enabled).
        bodies: the robot's :func:`body_geometry`, when the caller has read it already.
    """
    inputs = body_geometry(robot) if bodies is None else list(bodies)
    split_excess = capsule_split_excess(robot)
    folder = capsule_cache_dir() if cache else None
    path = (folder / f"capsules-{fit_key(inputs, split_excess)}.npz" if folder is not None
            else None)
    if path is not None and path.is_file():
        try:
            out = read_capsules(path)
            log.debug("robot %s: capsules read from %s", robot.name, path)
            return out
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            # a damaged file: fit again
            log.warning("capsule cache %s unreadable (%s): fitting again", path, exc)
    out = []
    for body, pts, tris in inputs:
        fitted = fit_capsules(pts, triangles=tris, split_excess=split_excess)
        for k, (a, b, r) in enumerate(fitted):
            name = body if len(fitted) == 1 else f"{body}#{k + 1}"
            out.append(Capsule(name=name, body=body, frame=body, a=a, b=b, radius=r))
    if path is not None:
        try:
            write_capsules(path, out)
        except OSError as exc:  # a read-only home: no cache, no failure
            log.warning("capsule cache %s not written: %s", path, exc)
    return out


def capsule_ignore_rule(robot: Robot, capsules: Sequence[Capsule] | None = None
                        ) -> dict[tuple[str, str], str]:
    """:func:`imesh.robot.capsules.pairs.ignore_rule` for a robot (what its
    ``collision_pairs.toml`` must list), plus the body pairs whose URDF geometry touches in the
    nominal pose."""
    capsules = fit_robot_capsules(robot) if capsules is None else list(capsules)
    model = CapsuleModel(capsules, set())
    _, parent = robot_bodies(robot)
    bodies, _ = robot_bodies(robot)
    feet = []
    for side in ("left", "right"):
        foot = robot.foot_frames[side]
        feet += [b for b, members in bodies.items() if foot in members]
    nominal = robot.frame_placements(robot.q_nominal, model.frames)[None]
    rule = ignore_rule(model, parent, feet, nominal)
    # the URDF's own geometry (as check_self_collisions scores it) touching in the nominal
    # pose: never checked either, on either geometry
    mesh = MeshCollisionChecker(robot, ignored=set(rule))
    for key, d in sorted(mesh.distances(robot.q_nominal).items()):
        if d < 0.0:
            rule[pair_key(*key)] = f"URDF geometry nominal {1e3 * d:.1f} mm"
    return rule


def body_hulls(bodies: Sequence[BodyGeometry]) -> dict[str, np.ndarray]:
    """body -> (V, 3) [m] vertices of the convex hull of its geometry (the points its capsules
    enclose; :func:`body_geometry`) in the body's frame (:mod:`imesh.robot.capsules.hulls`)."""
    return {body: hull_vertices(pts) for body, pts, _ in bodies}


def build_capsule_model(robot: Robot) -> CapsuleModel:
    """The robot's capsules with the ignore list of its ``collision_pairs.toml`` (the rule's
    output when the robot has no such file, e.g. a user's URDF)."""
    bodies = body_geometry(robot)  # read once, for the capsules and the hulls
    capsules = fit_robot_capsules(robot, bodies=bodies)
    path = pairs_file(robot)
    if path.is_file():
        ignored = read_pairs_toml(path)
    else:
        ignored = set(capsule_ignore_rule(robot, capsules))
        log.info("robot %s has no %s: ignoring %d body pairs by rule", robot.name, PAIRS_FILE,
                 len(ignored))
    model = CapsuleModel(capsules, ignored, body_hulls(bodies))
    log.info("robot %s: %d capsules on %d bodies, %d pairs checked", robot.name,
             len(capsules), len({c.body for c in capsules}), len(model.pairs))
    return model


def describe_collisions(robot: Robot, write: bool = False) -> str:
    """Text for ``imesh robots NAME --collisions``: the capsules, the ignored pairs and their
    reasons, whether ``collision_pairs.toml`` matches the rule (``write``: write it)."""
    capsules = fit_robot_capsules(robot)
    rule = capsule_ignore_rule(robot, capsules)
    path = pairs_file(robot)
    if write:
        path.write_text(format_pairs_toml(robot.name, rule, capsule_source(robot),
                                          capsule_split_excess(robot)))
    model = robot.capsule_model()
    lines = [f"{robot.name}: {len(capsules)} capsules on "
             f"{len({c.body for c in capsules})} bodies, {len(model.pairs)} capsule pairs "
             "checked", "",
             f"{'capsule':<30} {'frame':<28} {'radius mm':>9} {'length mm':>9}"]
    for c in capsules:
        lines.append(f"{c.name:<30} {c.frame:<28} {1e3 * c.radius:>9.1f} {1e3 * c.length:>9.1f}")
    stored = read_pairs_toml(path) if path.is_file() else None
    state = ("written" if write else "matches the rule" if stored == set(rule)
             else "missing: the rule is used" if stored is None else "DIFFERS from the rule")
    lines += ["", f"ignored body pairs ({len(rule)}; {path}: {state}):"]
    for (a, b), why in sorted(rule.items()):
        lines.append(f"  {a} - {b}: {why}")
    return "\n".join(lines)
