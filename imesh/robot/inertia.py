"""Degenerate link inertias made physical, once for every model of a robot.

A point mass on a joint axis has no inertia about it: iCub's URDF writes its head (1.34 kg) and
neck with all moments 0, which makes the effective inertia of ``neck_yaw`` 1e-12 kg m^2. A
controller then either shakes the head at its torque limit (stable PD, torque clamped) or, if its
model has the point mass while the simulator does not, asks for torques the simulated head
cannot follow (the whole-body controller lost iCub's left arm and head in the 0.5 s settle, 0.6 m
from the reference, before the first frame). So a degenerate tensor is replaced by the inertia of
a solid sphere of water of the link's mass, a lower bound of any real body's, in the URDF that
both pinocchio (:func:`imesh.robot.build.build_model`) and DART (:func:`imesh.physics.world.
reduced_urdf`) read; the mass and centre of mass stay the URDF's, so gravity and the CoM are
unchanged.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET

import numpy as np

log = logging.getLogger(__name__)

#: Density [kg/m^3] of the solid sphere whose inertia replaces a degenerate inertia tensor.
SPHERE_DENSITY = 1000.0
#: An inertia tensor whose largest principal moment is below this fraction of that sphere's
#: moment is degenerate (a point mass, as iCub's URDF writes its head and neck).
DEGENERATE_FRACTION = 0.01
_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def sphere_moment(mass_kg: float) -> float:
    """Principal moment [kg m^2] of a solid sphere of ``SPHERE_DENSITY`` and this mass:
    ``2/5 m r^2`` with ``r = (3 m / (4 pi rho))^(1/3)``."""
    radius = (3.0 * mass_kg / (4.0 * np.pi * SPHERE_DENSITY)) ** (1.0 / 3.0)
    return 0.4 * mass_kg * radius ** 2


def regularize_inertias(root: ET.Element) -> list[str]:
    """Give every link of a URDF tree whose inertia tensor is degenerate the inertia of a solid
    sphere of its mass (in place).

    Args:
        root: the URDF's ``<robot>`` element.

    Returns:
        The names of the links changed.
    """
    changed = []
    for link in root.iter("link"):
        mass = link.find("inertial/mass")
        tensor = link.find("inertial/inertia")
        if mass is None or tensor is None:
            continue
        m = float(mass.get("value", "0"))
        if m <= 0:
            continue
        i = {key: float(tensor.get(key, "0")) for key in _KEYS}
        matrix = np.array([[i["ixx"], i["ixy"], i["ixz"]],
                           [i["ixy"], i["iyy"], i["iyz"]],
                           [i["ixz"], i["iyz"], i["izz"]]])
        floor = sphere_moment(m)
        if np.linalg.eigvalsh(matrix).max() >= DEGENERATE_FRACTION * floor:
            continue
        log.info("link %s: inertia tensor degenerate, set to a %.3g kg sphere's (%.3g kg m^2)",
                 link.get("name"), m, floor)
        for key in ("ixx", "iyy", "izz"):
            tensor.set(key, repr(floor))
        for key in ("ixy", "ixz", "iyz"):
            tensor.set(key, "0")
        changed.append(str(link.get("name")))
    return changed
