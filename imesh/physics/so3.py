"""Rotations of one 3-vector or 3x3 matrix at a time, in plain numpy: the controller calls them
every control step, where scipy's ``Rotation`` (built for batches) costs 10-50 us a call."""

from __future__ import annotations

import numpy as np

_I3 = np.eye(3)
_I3.flags.writeable = False


def exp_so3(w: np.ndarray) -> np.ndarray:
    """(3, 3) rotation of the rotation vector ``w`` (3,) [rad] (Rodrigues' formula)."""
    theta = float(np.sqrt(w @ w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if theta < 1e-9:
        return _I3 + K
    return (_I3 + (np.sin(theta) / theta) * K
            + ((1.0 - np.cos(theta)) / theta ** 2) * (K @ K))


def log_so3(R: np.ndarray) -> np.ndarray:
    """(3,) rotation vector [rad] of the rotation ``R`` (3, 3) (angle in [0, pi])."""
    c = min(max(0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0), -1.0), 1.0)
    theta = float(np.arccos(c))
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if theta < 1e-6:
        return 0.5 * v
    if theta > np.pi - 1e-4:  # near pi: from the symmetric part
        B = 0.5 * (R + _I3)
        axis = np.sqrt(np.maximum(np.diag(B), 0.0))
        k = int(np.argmax(axis))
        axis[:] = B[k] / axis[k]
        axis /= np.linalg.norm(axis)
        if v @ axis < 0:
            axis = -axis
        return theta * axis
    return (theta / (2.0 * np.sin(theta))) * v


def quat_xyzw_to_matrix(q: np.ndarray) -> np.ndarray:
    """(3, 3) rotation of a unit quaternion ``q`` (4,) in (x, y, z, w) order."""
    x, y, z, w = q / np.sqrt(q @ q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def matrix_to_quat_xyzw(R: np.ndarray) -> np.ndarray:
    """(4,) unit quaternion (x, y, z, w) of a rotation ``R`` (3, 3) (Shepperd's method)."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        q = [(R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, 0.25 * s]
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = [0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s, (R[2, 1] - R[1, 2]) / s]
    elif R[1, 1] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q = [(R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s, (R[0, 2] - R[2, 0]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q = [(R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s, (R[1, 0] - R[0, 1]) / s]
    out = np.array(q)
    return out / np.linalg.norm(out)
