"""Acclaim ASF/AMC reader (CMU motion capture database): bone-end positions by forward kinematics.

ASF conventions implemented (Acclaim, as used by the CMU database and its mocap players):

* ``:units length L`` scales lengths: one file unit is ``1/L`` inch, so metres per unit is
  ``0.0254 / L`` (CMU: ``length 0.45`` -> 0.05644 m, reported as unit "cmu").
* ``angle deg`` or ``angle rad`` (an AMC ``:DEGREES`` / ``:RADIANS`` line overrides it).
* A bone's ``axis ax ay az ORDER`` gives its local frame ``C`` in the world rest pose, and its
  AMC values (in ``dof`` order) a local rotation ``L``; rotations are *applied* in the listed
  order, so ``axis 0 0 20 XYZ`` is ``C = Rz @ Ry @ Rx``. The world rotation of a bone is
  ``D = D_parent @ C @ L @ C^T`` and its end is ``start + D @ (length * direction)``.
* The root sits at ``position + (TX, TY, TZ)`` and rotates by ``C_root @ L_root @ C_root^T``
  with ``C_root`` from ``orientation`` (about the root ``axis`` order).

Points reported: ``root`` and the *end* of every bone, named after the bone (``lfemur`` is the
knee, ``ltibia`` the ankle, ``head`` the top of the head).
"""

from __future__ import annotations

import logging
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import MotionFileError
from .raw import RawMotion, is_float
from .skeleton import euler_to_matrix, forward_kinematics

log = logging.getLogger(__name__)

__all__ = ["read_asf_amc", "find_asf", "DEFAULT_AMC_FPS"]

#: AMC files store no frame rate; the CMU trial listing gives 120 fps for most subjects.
DEFAULT_AMC_FPS = 120.0
_ROT_DOFS = ("rx", "ry", "rz")
_ROOT_ORDER_WORDS = ("TX", "TY", "TZ", "RX", "RY", "RZ")


@dataclass
class _Bone:
    name: str
    line: int
    direction: np.ndarray | None = None
    length: float | None = None
    axis: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis_order: str = "XYZ"
    dofs: list[str] = field(default_factory=list)
    parent: str | None = None


@dataclass
class _Skeleton:
    path: str
    length_scale: float = 1.0
    angle_unit: str = "deg"
    root_order: list[str] = field(default_factory=lambda: list(_ROOT_ORDER_WORDS))
    root_axis: str = "XYZ"
    root_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    root_orientation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bones: dict[str, _Bone] = field(default_factory=dict)
    order: list[str] = field(default_factory=list)  # bones in topological order


def find_asf(amc_path: str | Path) -> Path:
    """The skeleton file of an AMC: the .asf beside it whose stem prefixes the AMC stem.

    Raises:
        MotionFileError: no such file, or several (listing the candidates).
    """
    amc = Path(amc_path)
    asfs = sorted(p for p in amc.parent.iterdir() if p.suffix.lower() == ".asf" and p.is_file())
    matches = [p for p in asfs if amc.stem.lower().startswith(p.stem.lower())]
    if len(matches) == 1:
        return matches[0]
    if not matches:
        listing = ", ".join(p.name for p in asfs) or "none"
        raise MotionFileError(
            str(amc), f"no skeleton (.asf) whose name is a prefix of {amc.stem!r} in "
            f"{amc.parent}; .asf files there: {listing}; pass the skeleton explicitly (--asf FILE, "
            "or asf= in load_motion)")
    raise MotionFileError(
        str(amc), f"several skeletons could belong to this motion: "
        f"{', '.join(p.name for p in matches)}; pass one explicitly (--asf FILE, or asf= in "
        "load_motion)")


def _floats(path: str, words: list[str], n: int, what: str, line: int) -> np.ndarray:
    if len(words) < n:
        raise MotionFileError(path, f"{what}: expected {n} numbers, found {len(words)}", line=line)
    try:
        out = np.array([float(w) for w in words[:n]])
    except ValueError:
        raise MotionFileError(path, f"{what}: expected {n} numbers, found "
                              f"{' '.join(words[:n])!r}", line=line) from None
    if not np.isfinite(out).all():
        raise MotionFileError(path, f"{what}: non-finite value in {' '.join(words[:n])!r}",
                              line=line)
    return out


def _parse_asf(path: Path) -> _Skeleton:
    p = str(path)
    try:
        text = path.read_bytes().decode("utf-8", errors="replace")
    except OSError as exc:
        raise MotionFileError(p, f"cannot read skeleton file: {exc.strerror or exc}") from None
    skel = _Skeleton(path=p)
    section = ""
    bone: _Bone | None = None
    hierarchy: list[tuple[list[str], int]] = []
    in_hier = False
    seen: set[str] = set()
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        words = line.split()
        key = words[0].lower()
        if key.startswith(":"):
            section = key
            seen.add(section)
            if bone is not None:
                raise MotionFileError(p, f"bone {bone.name or '?'} not closed with 'end'",
                                      line=lineno)
            continue
        if section == ":units":
            if key == "length":
                skel.length_scale = float(_floats(p, words[1:], 1, "units length", lineno)[0])
                if skel.length_scale <= 0:
                    raise MotionFileError(p, "units length must be positive", line=lineno)
            elif key == "angle":
                unit = words[1].lower() if len(words) > 1 else ""
                if unit not in ("deg", "rad"):
                    raise MotionFileError(p, f"unknown angle unit {unit!r}; valid: deg, rad",
                                          line=lineno)
                skel.angle_unit = unit
        elif section == ":root":
            if key == "order":
                order = [w.upper() for w in words[1:]]
                bad = [w for w in order if w not in _ROOT_ORDER_WORDS]
                if bad or len(set(order)) != len(order):
                    raise MotionFileError(p, f"bad root order {' '.join(words[1:])!r}; valid "
                                          f"entries: {' '.join(_ROOT_ORDER_WORDS)}", line=lineno)
                skel.root_order = order
            elif key == "axis":
                skel.root_axis = _axis_order(p, words[1] if len(words) > 1 else "", lineno)
            elif key == "position":
                skel.root_position = _floats(p, words[1:], 3, "root position", lineno)
            elif key == "orientation":
                skel.root_orientation = _floats(p, words[1:], 3, "root orientation", lineno)
        elif section == ":bonedata":
            if key == "begin":
                if bone is not None:
                    raise MotionFileError(p, "'begin' inside a bone block", line=lineno)
                bone = _Bone(name="", line=lineno)
            elif key == "end":
                if bone is None:
                    raise MotionFileError(p, "'end' without 'begin'", line=lineno)
                _finish_bone(p, bone, skel)
                bone = None
            elif bone is None:
                raise MotionFileError(p, f"{words[0]!r} outside a begin/end bone block",
                                      line=lineno)
            elif key == "name":
                bone.name = words[1] if len(words) > 1 else ""
            elif key == "direction":
                bone.direction = _floats(p, words[1:], 3, f"direction of {bone.name}", lineno)
            elif key == "length":
                bone.length = float(_floats(p, words[1:], 1, f"length of {bone.name}",
                                            lineno)[0])
            elif key == "axis":
                bone.axis = _floats(p, words[1:], 3, f"axis of {bone.name}", lineno)
                bone.axis_order = _axis_order(p, words[4] if len(words) > 4 else "XYZ", lineno)
            elif key == "dof":
                dofs = [w.lower() for w in words[1:]]
                bad = [d for d in dofs if d not in _ROT_DOFS]
                if bad:
                    raise MotionFileError(p, f"bone {bone.name}: dof {' '.join(bad)} not "
                                          f"supported; valid: {' '.join(_ROT_DOFS)}", line=lineno)
                bone.dofs = dofs
            # id, limits and their continuation lines "(lo hi)", bodymass, cofmass: ignored
        elif section == ":hierarchy":
            if key == "begin":
                in_hier = True
            elif key == "end":
                in_hier = False
            elif in_hier:
                hierarchy.append((words, lineno))
    if bone is not None:
        raise MotionFileError(p, f"file ends inside bone block {bone.name or '?'}",
                              line=bone.line)
    for required in (":bonedata", ":hierarchy"):
        if required not in seen:
            raise MotionFileError(p, f"malformed ASF: no {required} section")
    _link(p, skel, hierarchy)
    return skel


def _axis_order(path: str, word: str, line: int) -> str:
    order = word.upper()
    if len(order) != 3 or set(order) != set("XYZ"):
        raise MotionFileError(path, f"bad axis order {word!r}; expected a permutation of XYZ",
                              line=line)
    return order


def _finish_bone(path: str, bone: _Bone, skel: _Skeleton) -> None:
    if not bone.name:
        raise MotionFileError(path, "bone without a name", line=bone.line)
    if bone.name == "root" or bone.name in skel.bones:
        raise MotionFileError(path, f"duplicate bone name {bone.name!r}", line=bone.line)
    if bone.direction is None or bone.length is None:
        raise MotionFileError(path, f"bone {bone.name} needs a direction and a length",
                              line=bone.line)
    norm = float(np.linalg.norm(bone.direction))
    if norm == 0 and bone.length != 0:
        raise MotionFileError(path, f"bone {bone.name} has a zero direction", line=bone.line)
    if norm > 0:
        bone.direction = bone.direction / norm
    skel.bones[bone.name] = bone


def _link(path: str, skel: _Skeleton, hierarchy: list[tuple[list[str], int]]) -> None:
    """Set parents from the :hierarchy lines and order bones topologically from the root."""
    children: dict[str, list[str]] = {}
    for words, lineno in hierarchy:
        parent, kids = words[0], words[1:]
        for name in [parent, *kids]:
            if name != "root" and name not in skel.bones:
                raise MotionFileError(path, f"hierarchy names unknown bone {name!r}; bones: "
                                      f"{', '.join(skel.bones)}", line=lineno)
        for kid in kids:
            if kid == "root" or skel.bones[kid].parent is not None:
                raise MotionFileError(path, f"bone {kid!r} has two parents", line=lineno)
            skel.bones[kid].parent = parent
        children.setdefault(parent, []).extend(kids)
    order: list[str] = []
    stack = list(reversed(children.get("root", [])))
    while stack:
        name = stack.pop()
        order.append(name)
        stack.extend(reversed(children.get(name, [])))
    orphans = [b for b in skel.bones if b not in order]
    if orphans:
        raise MotionFileError(path, f"bones not connected to the root in :hierarchy: "
                              f"{', '.join(orphans)}")
    skel.order = order


def _parse_amc(path: Path, skel: _Skeleton) -> tuple[dict[str, np.ndarray], int, str | None]:
    """Per-bone (T, n_dof) value arrays, frame count and the AMC angle unit (or None)."""
    p = str(path)
    try:
        text = path.read_bytes().decode("utf-8", errors="replace")
    except OSError as exc:
        raise MotionFileError(p, f"cannot read file: {exc.strerror or exc}") from None
    angle = None
    if re.search(r"^\s*:RADIANS\b", text, re.M | re.I):
        angle = "rad"
    elif re.search(r"^\s*:DEGREES\b", text, re.M | re.I):
        angle = "deg"
    frame_marks = list(re.finditer(r"^[ \t]*(\d+)[ \t]*\r?$", text, re.M))
    if not frame_marks:
        raise MotionFileError(p, "no frames (an AMC frame starts with a line holding its number)",
                              line=text.count("\n") + 1)
    n_frames = len(frame_marks)
    starts = np.array([m.start() for m in frame_marks])

    def line_at(pos: int) -> int:
        return text.count("\n", 0, pos) + 1

    names = set(re.findall(r"^[ \t]*([A-Za-z_][^\s]*)", text, re.M))
    unknown = sorted(n for n in names if n != "root" and n not in skel.bones)
    if unknown:
        found = re.search(rf"^[ \t]*{re.escape(unknown[0])}(?=\s|$)", text, re.M)
        assert found is not None  # the name was read from the start of a line of this text
        at = found.start()
        raise MotionFileError(p, f"unknown bone {unknown[0]!r} (skeleton {skel.path} has "
                              f"{', '.join(['root', *skel.bones])})", line=line_at(at),
                              frame=int(np.searchsorted(starts, at)) - 1)

    first_frame = int(frame_marks[0].group(1))
    numbers = np.array([int(m.group(1)) for m in frame_marks])
    if not np.array_equal(numbers, np.arange(first_frame, first_frame + n_frames)):
        k = int(np.nonzero(numbers != np.arange(first_frame, first_frame + n_frames))[0][0])
        log.warning("%s: frame numbers are not consecutive (frame %d is numbered %d)", p, k,
                    numbers[k])

    wanted = [("root", len(skel.root_order))] + [
        (b, len(skel.bones[b].dofs)) for b in skel.order if skel.bones[b].dofs]
    values: dict[str, np.ndarray] = {}
    for name, n_dof in wanted:
        matches = list(re.finditer(rf"^[ \t]*{re.escape(name)}[ \t]+([^\n]*)$", text, re.M))
        pos = np.array([m.start() for m in matches], dtype=np.int64)
        frame_of = np.searchsorted(starts, pos) - 1
        if frame_of.size and frame_of[0] < 0:
            raise MotionFileError(p, f"bone {name} data before the first frame number",
                                  line=line_at(int(pos[0])))
        counts = np.bincount(frame_of, minlength=n_frames)
        bad = np.nonzero(counts != 1)[0]
        if bad.size:
            k = int(bad[0])
            msg = (f"bone {name} missing (frame incomplete or file truncated)" if counts[k] == 0
                   else f"bone {name} appears {counts[k]} times in one frame")
            raise MotionFileError(p, msg, line=line_at(int(starts[k])), frame=k)
        words = " ".join(m.group(1) for m in matches).split()
        try:
            arr = np.array(words, dtype=np.float64)
        except ValueError:
            arr = None
        if arr is None or arr.size != n_frames * n_dof:
            # error path: the first line with a wrong count or a non-number
            fields = [m.group(1).split() for m in matches]
            bad = np.nonzero([len(f) != n_dof or not all(is_float(w) for w in f)
                              for f in fields])[0]
            k = int(bad[0])
            raise MotionFileError(p, f"bone {name}: expected {n_dof} numbers, found "
                                  f"{matches[k].group(1).strip()!r}",
                                  line=line_at(int(pos[k])), frame=k)
        arr = arr.reshape(n_frames, n_dof)
        finite = np.isfinite(arr)
        if not finite.all():
            t, c = (int(i[0]) for i in np.nonzero(~finite))
            raise MotionFileError(p, f"non-finite value in bone {name} (value {c + 1} of "
                                  f"{n_dof})", line=line_at(int(pos[t])), frame=t)
        values[name] = arr
    return values, n_frames, angle


def read_asf_amc(amc_path: str | os.PathLike[str], asf_path: str | os.PathLike[str] | None = None,
                 fps: float | None = None) -> RawMotion:
    """Read a CMU Acclaim motion (.amc) with its skeleton (.asf).

    Args:
        amc_path: the .amc motion file.
        asf_path: the .asf skeleton; by default the single .asf beside the AMC whose stem is a
            prefix of the AMC stem (``cmu_07.asf`` for ``cmu_07_05.amc``).
        fps: frame rate [1/s]; AMC stores none, default :data:`DEFAULT_AMC_FPS` (120, the CMU
            listing for most subjects), logged.

    Returns:
        RawMotion with ``positions`` (T, 1 + B, 3) of the root and every bone end in ASF units
        (``declared_scale_m = 0.0254 / length``, unit "cmu" for ``length 0.45``), ASF axes
        (``declared_up="+Y"``), ``bones`` (parent, child) pairs, ``rig="cmu_asf"``.

    Raises:
        MotionFileError: missing/ambiguous skeleton, malformed ASF or AMC, unknown bones,
            incomplete frames or non-finite values (message names file, line and frame).
    """
    amc = Path(amc_path)
    if not amc.is_file():
        raise MotionFileError(str(amc), "no such file")
    asf = Path(asf_path) if asf_path is not None else find_asf(amc)
    if not asf.is_file():
        raise MotionFileError(str(asf), "no such skeleton file")
    skel = _parse_asf(asf)
    values, n_frames, amc_angle = _parse_amc(amc, skel)
    angle = amc_angle or skel.angle_unit
    to_rad = np.pi / 180.0 if angle == "deg" else 1.0
    fps_default = fps is None
    if fps is None:
        fps = DEFAULT_AMC_FPS
        log.info("%s: AMC stores no frame rate; using %g fps (CMU listing default)", amc, fps)
    if not (np.isfinite(fps) and fps > 0):
        raise MotionFileError(str(amc), f"fps must be a positive number, got {fps!r}")

    names = ["root", *skel.order]
    index = {n: i for i, n in enumerate(names)}
    n_nodes = len(names)
    parent_index = [-1]
    for b in skel.order:
        parent = skel.bones[b].parent
        assert parent is not None  # _link gave every bone of the order its parent
        parent_index.append(index[parent])
    parents = np.array(parent_index, dtype=np.int64)
    offsets = np.zeros((n_frames, n_nodes, 3))
    rotations = np.broadcast_to(np.eye(3), (n_frames, n_nodes, 3, 3)).copy()

    # root: position + translation channels; rotation C L C^T about the root axis order
    root_vals = values["root"]
    trans = np.zeros((n_frames, 3))
    rot_axes, rot_cols = "", []
    for col, word in enumerate(skel.root_order):
        if word[0] == "T":
            trans[:, "XYZ".index(word[1])] = root_vals[:, col]
        else:
            rot_axes += word[1]
            rot_cols.append(col)
    offsets[:, 0] = skel.root_position + trans
    c_root = euler_to_matrix(skel.root_orientation * to_rad, skel.root_axis, applied=True)
    local = euler_to_matrix(root_vals[:, rot_cols] * to_rad, rot_axes, applied=True)
    rotations[:, 0] = c_root @ local @ c_root.T

    for j, name in enumerate(skel.order, start=1):
        bone = skel.bones[name]
        # _finish_bone rejected a bone without a direction or a length
        assert bone.direction is not None and bone.length is not None
        offsets[:, j] = bone.length * bone.direction
        if bone.dofs:
            c = euler_to_matrix(bone.axis * to_rad, bone.axis_order, applied=True)
            axes = "".join(d[1].upper() for d in bone.dofs)
            local = euler_to_matrix(values[name] * to_rad, axes, applied=True)
            rotations[:, j] = c @ local @ c.T
    positions, _ = forward_kinematics(parents, offsets, rotations, offset_frame="self")

    scale_m = 0.0254 / skel.length_scale
    unit = "cmu" if abs(skel.length_scale - 0.45) < 1e-9 else None
    log.info("%s (+ %s): %d frames, %d bones, units length %g -> %.6g m/unit, angles %s", amc,
             asf.name, n_frames, len(skel.order), skel.length_scale, scale_m, angle)
    bones = np.stack([parents[1:], np.arange(1, n_nodes)], axis=1).astype(np.int64)
    return RawMotion(
        positions=positions, fps=float(fps), names=tuple(names),
        valid=np.ones((n_frames, n_nodes), dtype=bool), path=str(amc), format="asf/amc",
        bones=bones, declared_units=unit, declared_scale_m=scale_m, declared_up="+Y",
        rig="cmu_asf",
        meta={"asf": str(asf), "angle_unit": angle, "length_scale": skel.length_scale,
              "fps_default_used": fps_default},
    )
