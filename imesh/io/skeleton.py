"""Forward kinematics for hierarchical skeletons (BVH, ASF/AMC), vectorized over frames.

Conventions:
    * Rotation matrices act on column vectors: ``x_parent = R @ x_local``.
    * :func:`euler_to_matrix` composes elementary rotations in the order the axes are listed,
      ``R = R_a1(t1) @ R_a2(t2) @ ...`` (intrinsic rotations, the BVH convention: channels
      ``Zrotation Yrotation Xrotation`` give ``Rz @ Ry @ Rx``). For the Acclaim (ASF/AMC)
      convention, where the listed order is the order of *application*, pass ``applied=True``
      (``XYZ`` then gives ``Rz @ Ry @ Rx`` as well).
    * Joints are stored in topological order: ``parents[j] < j``, roots have parent ``-1``.

Only joints are looped over (in topological order); every operation is vectorized over frames.
"""

from __future__ import annotations

import numpy as np

__all__ = ["axis_rotation", "euler_to_matrix", "forward_kinematics", "check_topological"]

_AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}


def axis_rotation(axis: str, angle_rad: np.ndarray) -> np.ndarray:
    """Rotation matrices about one coordinate axis.

    Args:
        axis: "X", "Y" or "Z" (case-insensitive).
        angle_rad: (...,) angles [rad], right-handed.

    Returns:
        (..., 3, 3) rotation matrices.
    """
    a = np.asarray(angle_rad, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    out = np.zeros(a.shape + (3, 3))
    i = _AXIS_INDEX[axis.upper()]
    j, k = (i + 1) % 3, (i + 2) % 3
    out[..., i, i] = 1.0
    out[..., j, j] = c
    out[..., k, k] = c
    out[..., j, k] = -s
    out[..., k, j] = s
    return out


def euler_to_matrix(angles_rad: np.ndarray, axes: str, *, applied: bool = False) -> np.ndarray:
    """Rotation matrices from Euler angles in any axis order.

    Args:
        angles_rad: (..., K) angles [rad], one column per letter of ``axes``.
        axes: K axis letters, e.g. "ZYX", "ZXY", "XYZ" (K may be 0..3 or more; repeats allowed).
        applied: False (BVH): ``R = R_axes[0] @ R_axes[1] @ ...`` (intrinsic, listed order).
            True (Acclaim): the rotations are applied to the vector in the listed order,
            ``R = ... @ R_axes[1] @ R_axes[0]``.

    Returns:
        (..., 3, 3) rotation matrices.
    """
    angles = np.asarray(angles_rad, dtype=np.float64)
    if angles.shape[-1] != len(axes):
        raise ValueError(f"{angles.shape[-1]} angles for axes {axes!r}")
    out = np.broadcast_to(np.eye(3), angles.shape[:-1] + (3, 3)).copy()
    order = range(len(axes) - 1, -1, -1) if applied else range(len(axes))
    for k in order:
        out = out @ axis_rotation(axes[k], angles[..., k])
    return out


def check_topological(parents: np.ndarray) -> None:
    """Raise ValueError unless every parent index precedes its child (roots: -1)."""
    parents = np.asarray(parents, dtype=np.int64)
    bad = np.nonzero((parents >= np.arange(len(parents))) | (parents < -1))[0]
    if bad.size:
        raise ValueError(f"joints {bad.tolist()} are not in topological order")


def forward_kinematics(parents: np.ndarray, offsets: np.ndarray, rotations: np.ndarray | None,
                       *, offset_frame: str = "parent") -> tuple[np.ndarray, np.ndarray]:
    """World positions and orientations of every joint of a tree, for all frames at once.

    Args:
        parents: (J,) int parent index per joint, ``-1`` for roots; topological order.
        offsets: (J, 3) or (T, J, 3) local translation of each joint [file units]. For a root it
            is its world position.
        rotations: (T, J, 3, 3) local rotation of each joint, or None for all identity. Joints
            without rotation channels (end sites) should hold the identity.
        offset_frame: "parent" (BVH): ``p[j] = p[parent] + G[parent] @ offsets[j]``;
            "self" (Acclaim bone ends): ``p[j] = p[parent] + G[j] @ offsets[j]``. In both
            cases ``G[j] = G[parent] @ rotations[j]`` (``G[root] = rotations[root]``).

    Returns:
        positions: (T, J, 3) world positions [file units].
        orientations: (T, J, 3, 3) world rotation of each joint's frame.
    """
    parents = np.asarray(parents, dtype=np.int64)
    check_topological(parents)
    if offset_frame not in ("parent", "self"):
        raise ValueError(f"offset_frame must be 'parent' or 'self', got {offset_frame!r}")
    offsets = np.asarray(offsets, dtype=np.float64)
    n_joints = len(parents)
    if rotations is None:
        n_frames = offsets.shape[0] if offsets.ndim == 3 else 1
        rotations = np.broadcast_to(np.eye(3), (n_frames, n_joints, 3, 3))
    n_frames = rotations.shape[0]
    if offsets.ndim == 2:
        offsets = np.broadcast_to(offsets, (n_frames, n_joints, 3))
    if offsets.shape != (n_frames, n_joints, 3) or rotations.shape != (n_frames, n_joints, 3, 3):
        raise ValueError(f"shape mismatch: offsets {offsets.shape}, rotations {rotations.shape}, "
                         f"{n_joints} joints")
    pos = np.empty((n_frames, n_joints, 3))
    rot = np.empty((n_frames, n_joints, 3, 3))
    for j in range(n_joints):  # joints only; frames are vectorized
        p = parents[j]
        if p < 0:
            rot[:, j] = rotations[:, j]
            pos[:, j] = offsets[:, j]
            continue
        rot[:, j] = rot[:, p] @ rotations[:, j]
        frame = rot[:, p] if offset_frame == "parent" else rot[:, j]
        pos[:, j] = pos[:, p] + np.einsum("tab,tb->ta", frame, offsets[:, j])
    return pos, rot
