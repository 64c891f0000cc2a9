"""The build step pyproject.toml cannot say: the robot configurations of ``robots/`` (robot.toml,
markers.toml, collision pairs; no model files) go into the wheel as ``imesh/robots``, where
:data:`imesh.robot.config.ROBOTS_DIR` finds them in an installed imesh (a checkout uses
``robots/`` itself)."""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROBOTS = Path(__file__).resolve().parent / "robots"


class BuildWithRobots(build_py):
    """build_py, then ``robots/`` copied into the built package as ``imesh/robots``."""

    def run(self):
        super().run()
        if not self.editable_mode:
            shutil.copytree(ROBOTS, Path(self.build_lib) / "imesh" / "robots",
                            dirs_exist_ok=True)


setup(cmdclass={"build_py": BuildWithRobots})
