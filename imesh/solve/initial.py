"""The initializer of the whole-body solve: the initial fit, low-passed.

The per-frame fit follows each frame's markers; where they jump (the first frames while the fit
settles, a marker glitch) the fitted base and joints jump too, and through the second
differences the multibody ZMP swings metres out of the support polygon (CMU wave on G1: CoM
accelerations of 20 m/s^2 at two frames). Linearized there, the ZMP rows mean little and the
SQP spends its iterations repairing them. A zero-phase low-pass of the base and joint
trajectories (joints clipped back into their position limits) removes those jumps before the
solve; the key-point terms of the solve bring back what the filter smoothed away.
"""

from __future__ import annotations

import numpy as np

from ..human.filtering import lowpass_array


def smooth_initializer(robot, q: np.ndarray, fps: float, cutoff_hz: float) -> np.ndarray:
    """(T, nq) ``q`` low-passed at ``cutoff_hz``: base position and joints directly, the base
    quaternion component-wise on a sign-continuous copy (then normalized); joints clipped into
    their position limits. Returned unchanged when the clip is too short for the filter."""
    q = np.array(q, dtype=float)
    quat = q[:, 3:7].copy()
    flip = np.cumprod(np.where(np.sum(quat[1:] * quat[:-1], axis=1) < 0, -1.0, 1.0))
    quat[1:] *= flip[:, None]
    x = np.concatenate([q[:, :3], quat, q[:, 7:]], axis=1)
    y = lowpass_array(x, fps, min(cutoff_hz, 0.45 * fps))
    if y is None:
        return q
    y[:, 3:7] /= np.linalg.norm(y[:, 3:7], axis=1, keepdims=True)
    y[:, 7:] = np.clip(y[:, 7:], robot.q_lower, robot.q_upper)
    return y
