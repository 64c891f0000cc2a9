"""Static scenes: props (boxes, steps) given as meshes or a URDF of fixed links, in the human's
world, mapped to the robot's with the retarget's human-to-robot scale, and written beside the
robot motion (docs/terrain.md).

- :mod:`imesh.scene.props`: reading OBJ/STL/PLY meshes and URDFs into :class:`Prop` objects.
- :mod:`imesh.scene.scene`: :class:`Scene`, the human-world and robot-world maps, the
  ``.scene.npz`` file beside a motion.
- :mod:`imesh.scene.morph_frame`: the retarget's scale and its fixed point.

- :mod:`imesh.scene.surfaces`: the support surface under a point (the floor or a prop's top).

In the retarget (``retarget(..., scene=)``) a foot on a prop's top is a support there
(:mod:`imesh.contacts.surfaces`) and the whole-body solve keeps the robot out of the props
(:mod:`imesh.solve.props`); the prop metrics (:mod:`imesh.metrics.props`) measure what the
robot does to them.
"""

from .props import MESH_EXTENSIONS, SCENE_EXTENSIONS, Prop, SceneFileError, load_props, prop_planes
from .scene import (
    SCENE_SUFFIX,
    Scene,
    find_scene,
    human_scene,
    load_saved_scene,
    load_scene,
    robot_scene,
    save_scene,
    scene_from_files,
    scene_path_for,
)

__all__ = ["MESH_EXTENSIONS", "SCENE_EXTENSIONS", "SCENE_SUFFIX", "Prop", "Scene",
           "SceneFileError", "find_scene", "human_scene", "load_props", "load_saved_scene",
           "load_scene", "prop_planes", "robot_scene", "save_scene", "scene_from_files",
           "scene_path_for"]
