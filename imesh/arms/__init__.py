"""Arm imitation by optimization IK with motor limits (Kim, Kim & Oh 2005). See docs/arms.md.

Per arm and frame, the increments of the arm joints (eq. 1) minimize the weighted errors of three
hand points and the upper-arm orientation error (eqs 2-6), inside the bounds that joint position,
velocity and acceleration limits put on the increment (eqs 9-15); the robot arm is scaled by
``rho = L_human / L_robot`` (sec. 2); gradients are analytic (eqs 16-18).

Example:
    >>> import imesh
    >>> from imesh.robot import load_robot
    >>> from imesh.arms import ArmsConfig, imitate_arms
    >>> robot = load_robot("jvrc1")
    >>> result = imitate_arms(robot, imesh.load_motion("cmu_141_16_wave_hello.bvh"))
    >>> result.motion             # RobotMotion: base and legs at the nominal pose, arms solved
    >>> result.report()           # hand-point RMS, upper-arm error, frames outside the limits
"""

from ..core.lazy import lazy_exports

_LAZY = {
    **dict.fromkeys(("Violations", "check_limits"), ".bounds"),
    **dict.fromkeys(("SOLVERS", "ArmsConfig"), ".config"),
    "ArmsError": ".errors",
    **dict.fromkeys(("ArmModel", "arm_model", "derived_arm_joints"),
                    ".geometry"),
    "FrameObjective": ".problem",
    **dict.fromkeys(("REFINE_CONFIG", "ArmResult", "ArmsResult", "human_arm_markers",
                     "imitate_arms", "refine_arms", "solve_arms"), ".solve"),
    **dict.fromkeys(("ArmScaling", "ArmTargets", "arm_targets"), ".targets"),
}
__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())

__all__ = [
    "REFINE_CONFIG", "SOLVERS", "ArmModel", "ArmResult", "ArmScaling", "ArmTargets",
    "ArmsConfig", "ArmsError", "ArmsResult", "FrameObjective", "Violations",
    "arm_model", "arm_targets", "check_limits", "derived_arm_joints",
    "human_arm_markers", "imitate_arms", "refine_arms", "solve_arms",
]
