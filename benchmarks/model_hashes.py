"""Hashes of the compiled models of robots x physics, and the paper robots' distances: the
check that a refactoring of compile and simulate changes no model and no result.

    python benchmarks/model_hashes.py --json before.json
    (change the code)
    python benchmarks/model_hashes.py --json after.json --compare before.json

Each case: sha256 of the model's MJCF text (`CompiledRobot.to_xml`, which holds every
number the model gets, the plugin's configuration included), and of its time step and start
keyframes as compiled; the paper robots' distances, and the tripod's over 0.1 s with each
physics (voxel lengths, as `simulate` returns them, compared bit for bit).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

from mjregen.grid import Material, Robot
from mjregen.physics import Physics, VoxelPipeline, box_physics, sphere_physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulate

PAPER = Path(__file__).resolve().parent.parent / "assets" / "robots" / "paper"


def robots() -> dict[str, Robot]:
    """Six robots: the paper's three, a 2D sheet, a mixed block, a 2D bimorph."""
    mixed = np.full((3, 3, 3), int(Material.SOFT), np.int8)
    mixed[0], mixed[2, :, 0] = int(Material.HARD), int(Material.MUSCLE_PLUS)
    mixed[1, 1] = int(Material.MUSCLE_MINUS)
    sheet = np.full((5, 5), int(Material.MUSCLE_PLUS), np.int8)
    sheet[:, 2:] = int(Material.MUSCLE_MINUS)
    assets = PAPER.parent
    return {
        **{name: Robot.load(PAPER / f"{name}.npy") for name in ("tripod", "biped", "multiped")},
        "sheet_2d": Robot(np.pad(sheet, 1)),
        "mixed_block": Robot(np.pad(mixed, 1)),
        "bimorph_2d": Robot.load(assets / "bimorph_walker_2d.npy"),
    }


def physics_cases() -> dict[str, Physics]:
    """Six physics: the default, its exact start, tendon bonds, MuJoCo's stepper, and the two
    pure-MuJoCo presets."""
    default = Physics()
    return {
        "default": default,
        "exact_start": default.replace(start_shift=0.0),
        "tendon_bonds": default.replace(pipeline=VoxelPipeline(bond_element="tendons")),
        "mujoco_stepper": default.replace(pipeline=VoxelPipeline(stepper="mujoco")),
        "sphere": sphere_physics(),
        "box": box_physics(),
    }


def case_hash(robot: Robot, physics: Physics) -> str:
    starts = (0, 1) if physics.scene.start_shift else (0,)  # shift 0: only the exact start
    compiled = compile_robot(robot, physics=physics, starts=starts)
    digest = hashlib.sha256(compiled.to_xml().encode())
    digest.update(np.float64(compiled.model.opt.timestep).tobytes())
    digest.update(np.asarray(compiled.model.key_qpos).tobytes())
    return digest.hexdigest()


def measure() -> dict:
    robots_by_name, cases = robots(), physics_cases()
    hashes = {f"{r} x {p}": case_hash(robot, physics) for r, robot in robots_by_name.items()
              for p, physics in cases.items()}
    distances = {name: simulate(robots_by_name[name]).distance
                 for name in ("tripod", "biped", "multiped")}
    distances.update({f"tripod 0.1 s x {p}": simulate(robots_by_name["tripod"], physics=physics,
                                                       duration=0.1).distance
                      for p, physics in cases.items()})
    return {"hashes": hashes, "distances": distances}


def module_stops(argv: list[str]) -> dict:
    """The modules of mjregen that the command `argv` (``mjregen`` arguments) passes through:
    each function at its first call, in call order (what a reader follows, loops counted
    once), as stops (each change of module), and how many stops return to a module already
    visited."""
    from mjregen.cli import main as cli_main

    stops: list[str] = []
    seen: set = set()

    def tracer(frame, event, arg):
        module = frame.f_globals.get("__name__", "")
        if event != "call" or not module.startswith("mjregen") or frame.f_code in seen:
            return
        seen.add(frame.f_code)
        if not stops or stops[-1] != module:
            stops.append(module)

    sys.setprofile(tracer)
    try:
        cli_main(argv)
    finally:
        sys.setprofile(None)
    revisits = sum(1 for i, module in enumerate(stops) if module in stops[:i])
    return {"stops": len(stops), "modules": len(set(stops)), "revisits": revisits,
            "path": stops}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, required=True, help="write the hashes here")
    parser.add_argument("--compare", type=Path, help="an earlier --json to compare with")
    args = parser.parse_args(argv)
    report = measure()
    report["walk"] = module_stops(["walk", str(PAPER / "tripod.npy"), "--duration", "0.01"])
    walk = report["walk"]
    print(f"mjregen walk: {walk['stops']} stops in {walk['modules']} modules, "
          f"{walk['revisits']} of them returns")
    args.json.write_text(json.dumps(report, indent=2))
    print(f"{len(report['hashes'])} models; distances {report['distances']}")
    if args.compare is None:
        return 0
    before = json.loads(args.compare.read_text())
    changed = [case for case, value in report["hashes"].items()
               if before["hashes"].get(case) != value]
    moved = [name for name, value in report["distances"].items()
             if before["distances"].get(name) != value]
    print(f"models changed: {changed or 'none'}; distances moved: {moved or 'none'}")
    return 1 if changed or moved else 0


if __name__ == "__main__":
    sys.exit(main())
