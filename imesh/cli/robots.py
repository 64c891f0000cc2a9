"""``imesh robots init ROBOT.urdf -o DIR``: a robot configuration from its URDF alone."""

from __future__ import annotations

import sys
from pathlib import Path

from ..errors import ImeshError


def cmd_robots_init(urdf: str | None, output: str | None, name: str | None = None,
                    picture: bool = True) -> int:
    """Generate robot.toml, markers.toml, report.txt (and keypoints.png) for a humanoid URDF;
    print the report. Exit code 0."""
    from ..robot.generate import generate_robot_config
    from ..robot.generate_files import report_text, write_generated

    if not urdf:
        raise ImeshError("imesh robots init needs the URDF: imesh robots init ROBOT.urdf -o DIR")
    out = Path(output) if output else Path(Path(urdf).stem)
    gen = generate_robot_config(urdf, name=name)
    files = write_generated(gen, out)
    if picture:
        from ..viz.adapt import plot_keypoints

        files.append(plot_keypoints(gen, out / "keypoints.png"))
    sys.stdout.write(report_text(gen))
    sys.stdout.write("\nwrote " + ", ".join(str(f) for f in files) + "\n"
                     f"use it: imesh retarget CLIP --robot {out} --urdf {urdf}\n")
    return 0
