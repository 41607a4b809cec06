"""Commands on single robots: grow, show."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from mjregen.cli.common import material_counts
from mjregen.errors import MjregenError
from mjregen.grid import Robot


def add_grow(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "grow",
        help="grow a robot with an NCA and print it",
        description="Grow a robot with an NCA (a checkpoint, or a random NCA with the paper's "
        "initial genes N(0, 0.1^2) from --seed), print each step's voxel counts and the robot.",
    )
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--checkpoint", type=Path, help="NCA checkpoint (.npz)")
    source.add_argument("--seed", type=int, default=0, help="seed of a random NCA (default 0)")
    parser.add_argument("--dim", type=int, choices=(2, 3), default=3, help="random NCA: 2D or 3D")
    parser.add_argument("--net", choices=("ff", "lstm"), default="ff", help="random NCA: network")
    parser.add_argument("--steps", type=int, help="growth steps (default: the NCA's, 10)")
    parser.add_argument("--show-steps", action="store_true", help="print the grid after every step")
    parser.add_argument("--out", type=Path, help="save the grown robot to this .npy file")
    parser.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    parser.add_argument("--json", action="store_true", help="print JSON instead of text")
    parser.set_defaults(handler=_grow)


def _grow(args: argparse.Namespace) -> int:
    from mjregen.checkpoint import load_nca
    from mjregen.nca import NCA, NCAConfig

    if args.steps is not None and args.steps < 1:
        raise MjregenError(f"--steps must be at least 1, got {args.steps}")
    if args.checkpoint is not None:
        nca, _ = load_nca(args.checkpoint)
        source = str(args.checkpoint)
    else:
        nca = NCA.random(NCAConfig(dim=args.dim, kind=args.net), seed=args.seed)
        source = f"random {args.dim}D {args.net} NCA, seed {args.seed}"
    growth = nca.grow(steps=args.steps)
    robot = growth.robot()
    steps = [Robot(state) for state in growth.states[0]]
    if args.out is not None:
        robot.save(args.out, overwrite=args.force)
    if args.json:
        print(json.dumps({
            "source": source,
            "config": nca.config.to_dict(),
            "steps": [{"step": i, "voxels": s.n_voxels, "materials": material_counts(s)} for i, s in enumerate(steps)],
            "robot": {"voxels": robot.n_voxels, "materials": material_counts(robot), "grid": robot.grid.tolist()},
            "out": None if args.out is None else str(args.out),
        }))
        return 0
    print(f"growing: {source}")
    for i, state in enumerate(steps):
        print(f"step {i:2d}: {state.n_voxels:4d} voxels  " + "  ".join(f"{k} {v}" for k, v in material_counts(state).items()))
        if args.show_steps:
            print(state.to_text())
    print("after cleaning:")
    print(robot.to_text())
    if args.out is not None:
        print(f"saved {args.out}")
    return 0


def add_show(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "show",
        help="print a robot file as text",
        description="Print a robot (.npy grid) layer by layer, top layer first.",
    )
    parser.add_argument("robot", type=Path, help="robot file (.npy)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of text")
    parser.set_defaults(handler=_show)


def _show(args: argparse.Namespace) -> int:
    robot = Robot.load(args.robot)
    if args.json:
        print(json.dumps({
            "shape": list(robot.shape),
            "voxels": robot.n_voxels,
            "materials": material_counts(robot),
            "grid": np.asarray(robot.grid).tolist(),
        }))
    else:
        print(robot.to_text())
    return 0
