#!/usr/bin/env python3
"""Ship evolved NCAs and walkers from the results runs into assets/, with a manifest.

--best: for every evolution condition with runs under --root (runs/results/<condition>/
seed_<n>), take the run whose best fitness is highest and that run's first generation that
reached it (best/gen_NNNN.npz), grow the NCA again and simulate the robot again with the
current code and the run's own settings (its physics and measured time, from config.json),
then copy the NCA to assets/nca/walker_<dim>d_<kind>.npz, the grown robot to the same name
with .npy, and write its entry in assets/nca/manifest.json: condition, settings, source run,
seed, generation, fitness, distance, stability, voxel and material counts, date, versions of
mjregen/torch/mujoco/numpy, git commit and sha256 of both files. tests/test_assets.py
checks every such entry by growing and simulating again.

--walkers: the three diverse 3D walkers of the regrowth experiment
(`mjregen.experiments.walkers.load_or_pick_walkers`: picked once into <root>/walkers, see DIVERSITY
there) copied to assets/robots/walkers/walker_<i>.{npz,npy} with walkers.json, each
re-measured like the NCAs and with its regrowth recovery when <root> has one.

--voxelyze DIR (the paper's engine, `mjregen.validation.engine`) ships a 3D condition's walker by
whether it transfers, not by the score its run gave it from one start: every run's best robot
is walked from --starts starts, from as many fresh ones, turned and in the engine
(`mjregen.validation.transfer`), and the farthest of those that transfer (the mean of its
starts) is shipped, its measurements recorded in the entry as "transfer"; no robot that
transfers is an error, and nothing is shipped for that condition. Without it, the run with the
highest best fitness is shipped and its entry has no "transfer" (measure it with
benchmarks/transfer.py --assets).

--replace-default also copies the best 3D NCA over assets/nca/walker_3d.npz, the NCA that
scripts/grow_and_walk.py grows by default (needs --overwrite: it replaces the placeholder).

Nothing that exists is replaced without --overwrite.

Examples:
  python scripts/ship_assets.py --best --walkers
  python scripts/ship_assets.py --best --condition 3d_ff --overwrite --replace-default
  python scripts/ship_assets.py --root records/paper --best --voxelyze DIR --overwrite

Ship from records/ (the runs kept in git, scripts/snapshot_runs.py), so that each entry's
source run can be traced; tests/test_assets.py checks it.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from mjregen.errors import MjregenError
from mjregen.experiments import paper as ex
from mjregen.experiments import walkers as wk
from mjregen.fileio import atomic_open
from mjregen.grid import Material, Robot
from mjregen.validation.engine import PaperEngine
from mjregen.validation.transfer import (
    Transfer,
    best_transferring,
    measure_transfer,
    transfer_record,
)

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_ASSETS = ROOT / "assets"
DEFAULT_WALKER = "walker_3d.npz"  # scripts/grow_and_walk.py's default NCA
TOLERANCE = {"relative": 1e-6, "absolute": 1e-9}  # fitness re-simulation, see tests/test_assets.py


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def versions() -> dict[str, str]:
    import mujoco
    import torch

    from mjregen import __version__

    return {"mjregen": __version__, "torch": torch.__version__, "mujoco": mujoco.__version__,
            "numpy": np.__version__}


def git_commit() -> dict[str, object]:
    """HEAD of the repository this script is in, and whether mjregen/ has uncommitted changes."""
    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", *args], check=False, cwd=ROOT, capture_output=True, text=True,
                                  timeout=30)
        except (OSError, subprocess.TimeoutExpired):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    status = git("status", "--porcelain", "--", "mjregen")
    return {"commit": commit, "mjregen_modified": None if status is None else bool(status)}


def material_counts(robot: Robot) -> dict[str, int]:
    return {m.name.lower(): int(robot.material_counts().get(m, 0))
            for m in Material if m != Material.EMPTY}


def measure(npz: Path, run_config: dict, expected_robot: Path | None = None) -> dict:
    """Grow the NCA in `npz` and walk its robot as the run scored it: its body (a 2D run's
    sheet is the pattern laid flat), physics, measured time, starts and their seed.

    Returns:
      nca config, robot (`Robot`), fitness, distance (voxel lengths, None when unstable),
      stable, reason, voxels, materials, evaluation settings.
    Raises:
      MjregenError: the run's config has no physics description, or the grown robot differs
        from `expected_robot` (the run's own .npy).
    """
    from mjregen.growth.checkpoint import load_nca
    from mjregen.physics import Physics
    from mjregen.tasks.bodies import body_physics, body_robot
    from mjregen.tasks.evaluation import RobotJob, evaluate_robot

    task = run_config.get("task", {})
    if not isinstance(task.get("physics"), dict):
        raise MjregenError(f"the run of {npz} stores no physics description in config.json")
    stored = Physics.from_dict(task["physics"])
    body = task.get("body", "grid")
    physics = body_physics(stored, body)
    duration = task.get("duration")
    nca, _ = load_nca(npz)
    robot = body_robot(nca.grow().robot(), body)
    if expected_robot is not None and Robot.load(expected_robot) != robot:
        raise MjregenError(f"{npz} grows another robot than {expected_robot} with this code")
    starts, start_seed = task.get("starts", 1), task.get("start_seed", 0)
    result = evaluate_robot(RobotJob(np.asarray(robot.grid), physics, duration, starts,
                                     start_seed, rule=nca.config.dim))
    settle, measured = physics.scene.timing(robot.dim)
    return {
        "nca": nca.config.to_dict(), "robot": robot, "fitness": float(result.fitness),
        "distance": float(result.distance) if result.stable else None, "stable": result.stable,
        "reason": result.reason, "voxels": robot.n_voxels, "materials": material_counts(robot),
        "evaluation": {"physics": task["physics"], "body": body, "settle_s": settle,
                       "duration_s": measured if duration is None else duration,
                       "duration_arg": duration, "starts": starts, "start_seed": start_seed,
                       "physics_is_current_default": stored == Physics()},
    }


def _copy(source: Path, target: Path, *, overwrite: bool) -> None:
    with atomic_open(target, overwrite=overwrite) as handle:
        handle.write(source.read_bytes())


def _check_free(paths: list[Path], manifest: dict, keys: list[str], *, overwrite: bool) -> None:
    if overwrite:
        return
    taken = [str(p) for p in paths if p.exists()] + [f"manifest entry {k}" for k in keys if k in manifest]
    if taken:
        raise MjregenError(f"{', '.join(taken)} already exist(s); pass --overwrite to replace")


def read_manifest(path: Path) -> dict:
    return json.loads(path.read_text()) if path.is_file() else {}


def write_manifest(path: Path, manifest: dict) -> None:
    with atomic_open(path, "w") as handle:
        json.dump(manifest, handle, indent=2)
        handle.write("\n")


def transferring_run(runs: list[ex.RunInfo], engine: PaperEngine, starts: int
                     ) -> tuple[ex.RunInfo, Transfer]:
    """The run whose best robot walks farthest among those that transfer, and its walks.

    Raises:
      MjregenError: no run's best robot transfers (each one's numbers listed).
    """
    rows = {}
    for run in runs:
        _, npy = run.best_files()
        rows[run.seed] = measure_transfer(Robot.load(npy), name=f"seed {run.seed}",
                                          starts=starts, engine=engine,
                                          physics=run.robot_physics)
        print(f"    {run.path}: {_transfer_line(rows[run.seed])}", flush=True)
    best = best_transferring(list(rows.values()))
    if best is None:
        raise MjregenError(f"no best robot of the {len(runs)} runs of {runs[0].condition} "
                           "transfers: " + "; ".join(f"{row.name} {_transfer_line(row)}"
                                                     for row in rows.values()))
    return next(run for run in runs if rows[run.seed] is best), best


def _transfer_line(row: Transfer) -> str:
    engine = "n/a" if row.engine_ratio is None else f"{row.engine_ratio:.0%}"
    return (f"distance {row.distance:.2f}, fresh starts keep {row.fresh_kept:.0%}, turned "
            f"{row.rotated_kept:.0%}, engine {engine}: "
            + ("transfers" if row.transfers else "does not transfer"))


def _choose(runs: dict[str, list[ex.RunInfo]], names: list[str], engine: PaperEngine | None,
            starts: int) -> dict[str, tuple[ex.RunInfo, Transfer | None]]:
    """Each condition's run to ship and, for one of 3D robots (3D, or 2D sheets) with
    `engine`, its transfer walks."""
    chosen = {}
    for name in names:
        condition = ex.CONDITIONS[name]
        if engine is not None and (condition.dim == 3 or condition.body == "sheet"):
            print(f"{name}: the transfer check of each run's best robot ...", flush=True)
            chosen[name] = transferring_run(runs[name], engine, starts)
        else:
            chosen[name] = (ex.best_run(runs[name]), None)
    return chosen


def ship_best(root: Path, assets: Path, *, conditions: list[str] | None, overwrite: bool,
              replace_default: bool, engine: PaperEngine | None = None,
              starts: int = 10) -> list[dict]:
    """Ship the best NCA of each condition (see the module docstring: with `engine`, a 3D
    condition's farthest robot that transfers, from `starts` starts); returns the entries."""
    runs = ex.list_runs(root)
    names = [n for n in (conditions or list(ex.CONDITIONS)) if n in runs]
    missing = [n for n in (conditions or []) if n not in runs]
    if missing:
        raise MjregenError(f"no runs of {', '.join(missing)} under {root}")
    if not names:
        raise MjregenError(f"no evolution runs under {root}; run scripts/paper_experiments.py first")
    folder = assets / "nca"
    manifest_path = folder / "manifest.json"
    manifest = read_manifest(manifest_path)
    targets = {n: folder / f"walker_{n}.npz" for n in names}
    keys = [t.name for t in targets.values()]
    paths = [p for t in targets.values() for p in (t, t.with_suffix(".npy"))]
    _check_free(paths, manifest, keys, overwrite=overwrite)
    if replace_default and not overwrite and (folder / DEFAULT_WALKER).exists():
        raise MjregenError(f"--replace-default replaces {folder / DEFAULT_WALKER}: pass --overwrite")
    stamp = {"date": datetime.now(UTC).isoformat(timespec="seconds"),
             "versions": versions(), "git": git_commit()}
    entries = []
    chosen = _choose(runs, names, engine, starts)  # all of them before any file is copied
    for name in names:
        run, transfer = chosen[name]
        npz, npy = run.best_files()
        print(f"{name}: {run.path} generation {run.best_generation} (fitness in the run "
              f"{run.best_fitness:.6g}); growing and simulating again ...", flush=True)
        measured = measure(npz, run.config, npy)
        target = targets[name]
        _copy(npz, target, overwrite=overwrite)
        measured["robot"].save(target.with_suffix(".npy"), overwrite=overwrite)
        entry = _entry(name, run, npz, target, measured, stamp, len(runs[name]))
        if transfer is not None:
            entry["transfer"] = {**transfer_record(transfer, starts, run.robot_physics),
                                 "command": "python scripts/ship_assets.py --best --voxelyze DIR"}
        manifest[target.name] = entry
        entries.append(entry)
        print(f"    fitness {entry['fitness']:.6g}, distance {entry['distance']}, "
              f"{entry['robot']['voxels']} voxels -> {target}"
              + ("" if entry["source"]["matches_run"] else "  (differs from the run's fitness!)"))
    if replace_default:
        best3d = max((e for e in entries if e["nca"]["dim"] == 3), key=lambda e: e["fitness"],
                     default=None)
        if best3d is None:
            raise MjregenError("--replace-default needs a 3D condition among those shipped")
        default = folder / DEFAULT_WALKER
        _copy(folder / best3d["file"], default, overwrite=True)
        default.with_suffix(".npy").write_bytes((folder / best3d["robot_file"]).read_bytes())
        manifest[DEFAULT_WALKER] = {**best3d, "file": DEFAULT_WALKER,
                                    "robot_file": default.with_suffix(".npy").name,
                                    "same_as": best3d["file"],
                                    "note": "scripts/grow_and_walk.py grows this NCA by default"}
        print(f"{default} = {best3d['file']}")
    write_manifest(manifest_path, manifest)
    print(f"wrote {manifest_path}")
    return entries


def _entry(name: str, run: ex.RunInfo, npz: Path, target: Path, measured: dict, stamp: dict,
           runs_in_condition: int) -> dict:
    fitness = measured["fitness"]
    matches = bool(np.isclose(fitness, run.best_fitness, rtol=1e-5, atol=1e-6))  # csv has 6 digits
    return {
        "placeholder": False,
        "file": target.name,
        "robot_file": target.with_suffix(".npy").name,
        "condition": name,
        "nca": measured["nca"],
        "scale": ex.scale_of(run.config),
        "ga": run.config["ga"],
        "source": {"run": str(run.path), "seed": run.seed, "generation": run.best_generation,
                   "file": str(npz.relative_to(run.path)), "generations_run": run.generations_done,
                   "runs_in_condition": runs_in_condition, "fitness_in_run": run.best_fitness,
                   "matches_run": matches},
        "evaluation": measured["evaluation"],
        "fitness": fitness,
        "distance": measured["distance"],
        "stable": measured["stable"],
        "robot": {"voxels": measured["voxels"], **measured["materials"],
                  "pieces": wk.pieces(measured["robot"])},
        "tolerance": TOLERANCE,
        **stamp,
        "sha256": sha256(target),
        "robot_sha256": sha256(target.with_suffix(".npy")),
    }


def ship_walkers(root: Path, assets: Path, *, overwrite: bool) -> list[dict]:
    """Copy the regrowth experiment's walkers to assets/robots/walkers (module docstring)."""
    walkers = wk.load_or_pick_walkers(root)
    folder = assets / "robots" / "walkers"
    index = folder / "walkers.json"
    paths = [folder / f"{w['name']}{s}" for w in walkers for s in (".npz", ".npy")] + [index]
    _check_free(paths, {}, [], overwrite=overwrite)
    recoveries = {(w, net): path for w, net, path in ex.list_regen_runs(root)}
    stamp = {"date": datetime.now(UTC).isoformat(timespec="seconds"),
             "versions": versions(), "git": git_commit()}
    shipped = []
    for walker in walkers:
        run = ex.read_run(Path(walker["run"]))
        print(f"{walker['name']}: {walker['run']} generation {walker['generation']}; measuring ...",
              flush=True)
        measured = measure(Path(walker["npz"]), run.config, Path(walker["npy"]))
        target = folder / f"{walker['name']}.npz"
        _copy(Path(walker["npz"]), target, overwrite=overwrite)
        measured["robot"].save(target.with_suffix(".npy"), overwrite=overwrite)
        regen = {net: {"run": str(path), **json.loads((path / "recovery.json").read_text())}
                 for (w, net), path in recoveries.items() if w == walker["name"]}
        shipped.append({
            **{k: walker[k] for k in ("name", "condition", "seed", "generation", "features")},
            "run": walker["run"], "file": target.name, "robot_file": target.with_suffix(".npy").name,
            "fitness": measured["fitness"], "distance": measured["distance"],
            "stable": measured["stable"], "voxels": measured["voxels"],
            "materials": measured["materials"], "evaluation": measured["evaluation"],
            "regrowth": regen, "sha256": sha256(target),
            "robot_sha256": sha256(target.with_suffix(".npy")), **stamp})
        print(f"    fitness {measured['fitness']:.6g}, distance {measured['distance']}, "
              f"{measured['voxels']} voxels -> {target}")
    with atomic_open(index, "w", overwrite=overwrite) as handle:
        json.dump({"diversity": wk.DIVERSITY, "walkers": shipped}, handle, indent=2)
        handle.write("\n")
    print(f"wrote {index}")
    return shipped


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description="Copy the best evolved NCAs (and three diverse 3D walkers) from the results "
        "runs into assets/, re-measured with the current code, with a manifest.",
        epilog="example: python scripts/ship_assets.py --best --walkers")
    parser.add_argument("--best", action="store_true",
                        help="ship the best NCA of each condition to assets/nca")
    parser.add_argument("--walkers", action="store_true",
                        help="ship the regrowth experiment's three walkers to assets/robots/walkers")
    parser.add_argument("--condition", action="append", choices=list(ex.CONDITIONS),
                        help="with --best: only this condition (repeatable)")
    parser.add_argument("--replace-default", action="store_true",
                        help=f"with --best: also copy the best 3D NCA over assets/nca/{DEFAULT_WALKER}")
    parser.add_argument("--root", type=Path, default=ex.DEFAULT_ROOT,
                        help=f"results folder (default {ex.DEFAULT_ROOT})")
    parser.add_argument("--assets", type=Path, default=DEFAULT_ASSETS,
                        help="assets folder (default: the repository's)")
    parser.add_argument("--overwrite", action="store_true", help="replace existing assets")
    parser.add_argument("--voxelyze", type=Path, metavar="DIR",
                        help="with --best: the paper's engine; ship each 3D condition's "
                             "farthest robot that transfers (module docstring)")
    parser.add_argument("--starts", type=int, default=10,
                        help="with --voxelyze: starts per robot of the transfer check "
                             "(default 10)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not (args.best or args.walkers):
        parser.error("choose --best and/or --walkers")
    try:
        engine = None if args.voxelyze is None else PaperEngine(args.voxelyze)
        if args.best:
            ship_best(args.root, args.assets, conditions=args.condition, overwrite=args.overwrite,
                      replace_default=args.replace_default, engine=engine, starts=args.starts)
        if args.walkers:
            ship_walkers(args.root, args.assets, overwrite=args.overwrite)
    except (MjregenError, OSError, ValueError) as error:
        print(f"ship_assets: error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
