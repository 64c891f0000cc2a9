"""Command-line arguments several commands share."""

from __future__ import annotations

import argparse


def add_robot_arguments(p: argparse.ArgumentParser) -> None:
    """``--robot`` (a folder of robots/ or a robot.toml) and ``--urdf`` (the model file of
    robots whose model the user provides; alone, a configuration generated from it)."""
    p.add_argument("--robot", default=None,
                   help="robot: a folder of robots/ (jvrc1, g1, hrp4c) or a robot.toml "
                        "(default jvrc1; with --urdf alone, generated from the URDF)")
    p.add_argument("--urdf", help="model file for robots whose model the user provides "
                   "(hrp4c); alone: any humanoid URDF, configured automatically "
                   "(imesh robots init)")
