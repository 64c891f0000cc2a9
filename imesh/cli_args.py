"""Command-line arguments several commands share."""

from __future__ import annotations

import argparse


def add_robot_arguments(p: argparse.ArgumentParser, default: str = "jvrc1") -> None:
    """``--robot`` (a folder of robots/ or a robot.toml) and ``--urdf`` (the model file of
    robots whose model the user provides)."""
    p.add_argument("--robot", default=default,
                   help="robot: a folder of robots/ (jvrc1, g1, hrp4c) or a robot.toml")
    p.add_argument("--urdf", help="model file for robots whose model the user provides (hrp4c)")
