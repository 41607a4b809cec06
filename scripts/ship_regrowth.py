#!/usr/bin/env python3
"""Ship regrowth NCAs from regrowth run folders into assets/regen/, with a manifest.

For each run folder (written by `mjregen regen` / `run_regrowth`): take its regrowth.npz
(the best regrowth NCA, with the robot and the damaged state it regrows), replay it with the
current code and the default physics (`mjregen.experiments.regrowth.replay_regrowth`:
regrow, then walk the original, damaged and regrown robots), check the replay's similarity
against the run's record, copy the NCA to assets/regen/<robot>_<net>.npz and write its entry
in assets/regen/manifest.json: robot, network, start state, damage, similarity (cells of
729), the three distances and percentages, the GA's scale and the generations run, the run's
wall time, the date, versions and the git commit, and the sha256 of the file.
The entry records the physics of its walks; tests/test_assets.py replays every entry with
it. Nothing that exists is replaced without --overwrite. `--refresh` walks every shipped
entry again with today's default physics (after the default changed) and rewrites its
distances, percentages, physics, versions and commit, keeping its run's provenance.

Examples:
  python scripts/ship_regrowth.py runs/table1/biped_ff runs/table1/tripod_ff --overwrite
  python scripts/ship_regrowth.py --refresh
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

from mjregen.errors import MjregenError
from mjregen.experiments.regrowth import REGROWTH_FILE, replay_regrowth
from mjregen.fileio import atomic_open
from ship_assets import git_commit, sha256, versions  # the same provenance as the NCAs'

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = "manifest.json"


def entry_of(run: Path) -> tuple[str, dict]:
    """(file name, manifest entry) of the run folder `run`, replayed now."""
    path = run / REGROWTH_FILE
    if not path.is_file():
        raise MjregenError(f"{run} holds no {REGROWTH_FILE}: not a finished regrowth run")
    config = json.loads((run / "config.json").read_text())
    with (run / "metrics.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    replay = replay_regrowth(path)
    recorded = replay.metadata["similarity"]
    if replay.similarity != recorded:
        raise MjregenError(f"{path}: regrows {replay.similarity} cells, the run recorded "
                           f"{recorded}")
    net = config["task"]["nca"]["kind"]
    robot = replay.metadata["robot"]
    return f"{robot}_{net}.npz", {
        "robot": robot, "net": net, "start": replay.metadata["start"],
        "source": replay.metadata["source"], "damage": replay.metadata["damage"],
        "similarity": replay.similarity, **walks_of(replay),
        "ga": config["ga"], "seed": config["seed"], "generations_run": len(rows),
        "best_generation": replay.metadata["generation"],
        "run_wall_s": float(rows[-1]["elapsed"]) if rows else 0.0,
        "shipped": datetime.now(UTC).date().isoformat(),
    }


def walks_of(replay) -> dict:
    """The entry's fields that its walks decide: cells, distances, percentages, voxels,
    duration, the physics (today's default), versions and commit."""
    from mjregen.physics import Physics

    report = replay.report.to_dict()
    return {"grid_cells": report["grid_cells"],
            "damaged_similarity": report["similarity"]["damaged"],
            "distance": report["distance"], "percent_of_original": report["percent_of_original"],
            "voxels": report["voxels"], "duration": report["duration"],
            "physics": Physics().to_dict(), "versions": versions(), "git": git_commit()}


def refresh(folder: Path, manifest: dict) -> None:
    """Walk every shipped entry again with today's default physics (`walks_of`)."""
    for name, entry in manifest.items():
        replay = replay_regrowth(folder / entry["file"])
        if replay.similarity != entry["similarity"]:
            raise MjregenError(f"{name}: regrows {replay.similarity} cells, its entry records "
                               f"{entry['similarity']}")
        entry.update(walks_of(replay), refreshed=datetime.now(UTC).date().isoformat())
        print(f"{name}: distances {entry['distance']}")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="*", type=Path, help="regrowth run folders")
    parser.add_argument("--refresh", action="store_true",
                        help="walk every shipped entry again with today's default physics")
    parser.add_argument("--assets", type=Path, default=ROOT / "assets")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace shipped files and entries of the same name")
    args = parser.parse_args(argv)
    folder = args.assets / "regen"
    folder.mkdir(parents=True, exist_ok=True)
    manifest_path = folder / MANIFEST
    manifest = json.loads(manifest_path.read_text()) if manifest_path.is_file() else {}
    if not args.runs and not args.refresh:
        parser.error("name regrowth run folders, or --refresh")
    try:
        if args.refresh:
            refresh(folder, manifest)
        for run in args.runs:
            name, entry = entry_of(run)
            target = folder / name
            if (target.exists() or name in manifest) and not args.overwrite:
                raise MjregenError(f"{target} is shipped already; pass --overwrite to replace it")
            shutil.copyfile(run / REGROWTH_FILE, target)
            manifest[name] = {"file": name, **entry, "sha256": sha256(target)}
            print(f"{name}: {entry['similarity']}/{entry['grid_cells']} cells, distances "
                  f"{entry['distance']}")
    except (MjregenError, OSError) as error:
        print(f"ship_regrowth: error: {error}", file=sys.stderr)
        return 1
    with atomic_open(manifest_path, "w", overwrite=True) as handle:
        json.dump(dict(sorted(manifest.items())), handle, indent=2)
        handle.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
