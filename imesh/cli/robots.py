"""``imesh robots``: the robots imesh knows, a robot's self-collision capsules
(``imesh robots NAME --collisions``) and a robot configuration from its URDF alone
(``imesh robots init ROBOT.urdf -o DIR``)."""

from __future__ import annotations

import sys
from pathlib import Path

from ..errors import ImeshError
from ..robot import list_robots, load_robot
from ..robot.capsules.robot import describe_collisions
from ..robot.generate import generate_robot_config
from ..robot.generate_files import report_text, write_generated
from ..viz.adapt import plot_keypoints


def run(args) -> int:
    """List the robots, print (and ``--write``) a robot's collisions, or run ``init``; returns
    the exit status."""
    if args.name == "init":
        return run_init(args.path, args.output, args.robot_name)
    if args.collisions or args.name:
        if not args.name:
            raise ImeshError("imesh robots --collisions needs a robot name")
        print(describe_collisions(load_robot(args.name, urdf=args.urdf), write=args.write))
        return 0

    rows = list_robots()
    print(f"{'robot':<8} {'DOF':>4}  {'licence':<14} source")
    for r in rows:
        dof = r.get("dof", "?")
        print(f"{r['name']:<8} {dof!s:>4}  {r.get('licence', ''):<14} {r.get('source', '')}")
    print("any other humanoid: imesh robots init ROBOT.urdf -o DIR (docs/byo-robot.md)")
    return 0


def run_init(urdf: str | None, output: str | None, name: str | None = None,
             picture: bool = True) -> int:
    """Generate robot.toml, markers.toml, report.txt (and keypoints.png) for a humanoid URDF;
    print the report. Exit code 0."""
    if not urdf:
        raise ImeshError("imesh robots init needs the URDF: imesh robots init ROBOT.urdf -o DIR")
    out = Path(output) if output else Path(Path(urdf).stem)
    gen = generate_robot_config(urdf, name=name)
    files = write_generated(gen, out)
    if picture:
        files.append(plot_keypoints(gen, out / "keypoints.png"))
    sys.stdout.write(report_text(gen))
    sys.stdout.write("\nwrote " + ", ".join(str(f) for f in files) + "\n"
                     f"use it: imesh retarget CLIP --robot {out} --urdf {urdf}\n")
    return 0
