#!/usr/bin/env python3
"""GA against MAP-Elites at equal evaluations on 3D feed-forward NCAs: runs, then the report.

Each method runs once per seed into <root>/<method>/seed_<n> (`mjregen evolve` run folders,
resumable: run the same command again after a kill), its walks from starts seeded by that
seed as `mjregen evolve --seed n` seeds them: the GA run of seed n at the paper's 3D settings
(--pop 100 --gens 300) is the evolution of `mjregen evolve --dim 3 --net ff --preset 3d
--seed n`. Every evaluation of every run is also
recorded (its robot, fitness and distance) in <run>/evaluations/NNNN.npz, so that the GA's
robots can be placed in the same archive as MAP-Elites' (the same descriptors and cells).

The report (``--report``) writes quality_diversity.md and its figures (quality_diversity/)
into --docs, the figures folder of the results page that includes it (docs/results/ for
docs/results.md, `scripts/results_report.py`): per method over seeds, the best fitness, the
QD score and coverage of all its evaluations placed in one archive, and the number of distinct
walking morphologies (archive cells whose elite walks at least 25 % as far as the farthest robot
of the whole comparison) and how many of those the paper's engine walks at least 80 % as far
(the transfer rule's share; ``--engine DIR`` walks the elites not yet measured, kept in
<root>/engine_walks.json, which a report without the engine reads); curves of best fitness and
QD score over evaluations (means and bootstrapped 95 % CIs); each method's archive heatmap and
MAP-Elites' gallery (seed 0).

Examples:
  python scripts/qd_comparison.py --root runs/qd --seeds 0 1 2 --pop 50 --gens 40 --workers 2
  python scripts/qd_comparison.py --root runs/qd --seeds 0 1 2 --pop 50 --gens 40 --report \
      --docs docs/results [--engine DIR]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mjregen import interrupt
from mjregen.experiments.engine_walks import read_kept, walk_new
from mjregen.grid import Robot
from mjregen.growth.nca import NCAConfig
from mjregen.physics import Physics
from mjregen.search.backends import make_backend
from mjregen.search.ga import PRESETS
from mjregen.search.map_elites import MapElites, MapElitesConfig
from mjregen.search.qd_runs import run_map_elites
from mjregen.search.run_folder import read_progress
from mjregen.search.runs import run_evolution
from mjregen.search.stats import bootstrap_curves
from mjregen.tasks.descriptors import default_cells, describe, descriptor_ranges
from mjregen.tasks.locomotion import LocomotionTask
from mjregen.validation.engine import PaperEngine
from mjregen.validation.transfer import ENGINE

METHODS = ("ga", "map-elites")
DESCRIPTORS = ("voxels", "muscle")
WALKING = 0.25  # a morphology walks when it goes this fraction of the comparison's farthest
SMALL = 50  # voxels: a small robot (where the fitness's voxel cost pushes the GA)
ENGINE_WALKS = "engine_walks.json"  # in the root: the paper engine's distance of each elite
REPOSITORY = Path(__file__).resolve().parent.parent
ROOT_DOCS = REPOSITORY / "docs" / "results"  # the figures folder of docs/results.md


@dataclass
class RecordingTask:
    """A locomotion task that also writes each evaluated batch to <out>/evaluations."""

    task: LocomotionTask
    out: Path
    counter: int

    @property
    def nca(self) -> NCAConfig:
        return self.task.nca

    @property
    def lowest_fitness(self) -> float:
        return self.task.lowest_fitness

    def to_config(self) -> dict:
        return self.task.to_config()

    def evaluate(self, genomes, backend):
        result = self.task.evaluate(genomes, backend)
        folder = self.out / "evaluations"
        folder.mkdir(exist_ok=True)
        np.savez_compressed(folder / f"{self.counter:04d}.npz", grids=result.grids,
                            fitness=result.fitness, distance=result.details["distance"])
        self.counter += 1
        return result


def finished_steps(out: Path) -> int:
    """Generations (iterations) a run folder's checkpoint has finished; 0 without one."""
    path = out / "checkpoint.npz"
    if not path.is_file():
        return 0
    with np.load(path, allow_pickle=False) as archive:
        state = json.loads(str(archive["state"]))
    return int(state.get("generation", state.get("iteration", 0)))


def run_all(args: argparse.Namespace) -> None:
    nca = NCAConfig(dim=3, kind="ff")
    ga = PRESETS["3d"].scaled(args.pop).with_overrides(generations=args.gens)
    me = MapElitesConfig(iterations=args.gens, batch=args.pop, emitters=args.emitters,
                         sigma=ga.sigma, descriptors=DESCRIPTORS,
                         cells=default_cells(DESCRIPTORS, (nca.grid_size,) * 3))
    with make_backend("process", workers=args.workers) as backend:
        for seed in args.seeds:
            for method in args.methods:
                out = args.root / method / f"seed_{seed}"
                # each run's starts seeded by its seed, as `mjregen evolve` seeds them
                task = LocomotionTask(nca=nca, physics=Physics(), start_seed=seed)
                resume = (out / "config.json").is_file()
                recording = RecordingTask(task, out, finished_steps(out) if resume else 0)
                start = time.perf_counter()
                common = dict(seed=seed, out=out, backend=backend,
                              resume=resume,
                              progress=not args.quiet)
                if method == "ga":
                    run_evolution(recording, ga, **common)
                else:
                    run_map_elites(recording, me, **common)
                print(f"{method} seed {seed}: {time.perf_counter() - start:.0f} s", flush=True)


def evaluations(run: Path) -> dict[str, np.ndarray]:
    """Every evaluation of a run in order: grids, fitness, distance, batch (its index)."""
    files = sorted((run / "evaluations").glob("*.npz"))
    if not files:
        raise SystemExit(f"{run} has no recorded evaluations: run the comparison first")
    parts = {"grids": [], "fitness": [], "distance": [], "batch": []}
    for k, path in enumerate(files):
        with np.load(path) as data:
            for key in ("grids", "fitness", "distance"):
                parts[key].append(data[key])
            parts["batch"].append(np.full(len(data["fitness"]), k))
    return {key: np.concatenate(value) for key, value in parts.items()}


def archive_of(found: dict[str, np.ndarray]) -> tuple[MapElites, list[float]]:
    """All evaluations placed, batch by batch, in a fresh archive of the comparison's
    descriptors and cells (each elite's distance and robot grid as extra fields; genomes are
    not recorded); with the QD score after each batch. Of a MAP-Elites run's evaluations,
    its own archive's elites."""
    grids = found["grids"]
    shape = grids.shape[1:]
    config = MapElitesConfig(iterations=1, batch=1, emitters=1, descriptors=DESCRIPTORS,
                             cells=default_cells(DESCRIPTORS, shape))
    search = MapElites(config, 1, ranges=descriptor_ranges(DESCRIPTORS, shape), seed=0,
                       qd_score_offset=-21.0, extra_fields={"distance": ((), np.float64),
                                                            "grid": (shape, np.int8)})
    measures = describe(grids, DESCRIPTORS)
    distance = np.nan_to_num(found["distance"])
    scores = []
    for batch in range(int(found["batch"].max()) + 1):
        rows = found["batch"] == batch
        search.archive.add(np.zeros((int(rows.sum()), 1), dtype=np.float32),
                           found["fitness"][rows], measures[rows], distance=distance[rows],
                           grid=grids[rows])
        scores.append(search.stats()["qd_score"])
    return search, scores


def grid_key(grid: np.ndarray) -> str:
    """The key of a robot grid in ENGINE_WALKS: its sha256 (of the int8 bytes), shortened."""
    return "grid " + hashlib.sha256(np.ascontiguousarray(grid, np.int8).tobytes()).hexdigest()[:24]


def engine_transfers(walkers: dict, root: Path, engine: Path | None) -> dict:
    """{(method, seed): how many of its walking elites the paper's engine walks at least
    ENGINE as far as recorded, or None where one is not measured}. `walkers`: (method, seed)
    -> (grids ``(n, *shape)``, recorded distances ``(n,)``); `engine`: the engine's folder, to
    walk the elites `root`/ENGINE_WALKS does not hold yet (None: read it only)."""
    path = root / ENGINE_WALKS
    if engine is not None:
        robots = [(grid_key(grid), lambda grid=grid: Robot(grid))
                  for grids, _ in walkers.values() for grid in grids]
        walk_new(path, robots, PaperEngine(engine), progress=lambda line: None)
    kept = read_kept(path)
    counts = {}
    for key, (grids, distances) in walkers.items():
        walked = [kept.get(grid_key(grid)) for grid in grids]
        counts[key] = (None if any(d is None for d in walked) else
                       int(sum(d >= ENGINE * r for d, r in zip(walked, distances))))
    return counts


def report(args: argparse.Namespace) -> None:
    from mjregen.figures import elite_gallery
    from mjregen.plotting import save_png
    from mjregen.search.archive_plots import archive_heatmap

    figures = args.docs / "quality_diversity"
    figures.mkdir(parents=True, exist_ok=True)
    found = {(m, s): evaluations(args.root / m / f"seed_{s}") for m in METHODS for s in args.seeds}
    farthest = max(float(np.nanmax(f["distance"])) for f in found.values())
    rows, curves, archives = {}, {m: {"best": [], "qd": []} for m in METHODS}, {}
    walkers = {}
    for (method, seed), data in found.items():
        archive, qd = archives[(method, seed)] = archive_of(data)
        elites = archive.archive.data()
        stats = archive.stats()
        walks = elites["distance"] >= WALKING * farthest
        walkers[(method, seed)] = (elites["grid"][walks], elites["distance"][walks])
        walking = int(np.count_nonzero(walks))
        best = np.maximum.accumulate([data["fitness"][data["batch"] == b].max()
                                      for b in range(len(qd))])
        curves[method]["best"].append(best)
        curves[method]["qd"].append(qd)
        voxels = np.count_nonzero(data["grids"].reshape(len(data["grids"]), -1), axis=1)
        rows[(method, seed)] = {"evaluations": len(data["fitness"]), "best": stats["best"],
                                "small": float(np.mean(voxels <= SMALL)),
                                "qd_score": stats["qd_score"], "coverage": stats["coverage"],
                                "walking": walking,
                                "distance": float(np.nanmax(data["distance"]))}
    for key, count in engine_transfers(walkers, args.root, args.engine).items():
        rows[key]["transfer"] = count
    per_batch = args.pop
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(11, 4), dpi=100)
    FigureCanvasAgg(figure)
    for k, (key, label) in enumerate((("best", "best fitness so far"),
                                      ("qd", "QD score of all evaluations"))):
        ax = figure.add_subplot(1, 2, k + 1)
        for method in METHODS:
            length = min(len(c) for c in curves[method][key])
            stats = bootstrap_curves(np.stack([np.asarray(c[:length]) for c in curves[method][key]]))
            x = (stats.generations + 1) * per_batch
            line, = ax.plot(x, stats.mean, label=f"{method} (n={stats.n_runs})")
            ax.fill_between(x, stats.low, stats.high, color=line.get_color(), alpha=0.25)
        ax.set(xlabel="evaluations", ylabel=label)
        ax.grid(alpha=0.3)
    save_png(figure, figures / "curves.png")
    seed0 = args.seeds[0]
    for method in METHODS:
        archive, _ = archives[(method, seed0)]
        shape = found[(method, seed0)]["grids"].shape[1:]
        archive_heatmap(archive.snapshot().fitness_grid(), DESCRIPTORS,
                        descriptor_ranges(DESCRIPTORS, shape), figures / f"heatmap_{method}.png",
                        title=f"{method}, seed {seed0}: every evaluation placed")
    elite_gallery(archives[("map-elites", seed0)][0].snapshot(), DESCRIPTORS,
                  figures / "gallery_map_elites.png", overwrite=True)
    write_markdown(args, rows, farthest)


def _shown(folder: Path) -> str:
    """`folder` as a command line in this repository gives it: relative where it is inside."""
    try:
        return str(folder.resolve().relative_to(REPOSITORY))
    except ValueError:
        return str(folder)


def _mean_row(method: str, rows: list[dict]) -> str:
    """The table row of `method`'s means over its seeds' `rows`."""
    values = {k: np.mean([r[k] for r in rows]) for k in ("best", "qd_score", "coverage",
                                                         "walking")}
    transfer = [r["transfer"] for r in rows]
    return (f"| **{method} mean** | | | {values['best']:.2f} | {values['qd_score']:.0f} | "
            f"{values['coverage']:.1%} | {values['walking']:.1f} | "
            f"{'–' if None in transfer else f'{np.mean(transfer):.1f}'} | |")


def write_markdown(args: argparse.Namespace, rows: dict, farthest: float) -> None:
    config = json.loads((args.root / "map-elites" / f"seed_{args.seeds[0]}" / "config.json").read_text())
    ga_config = json.loads((args.root / "ga" / f"seed_{args.seeds[0]}" / "config.json").read_text())
    hours = {method: sum(read_progress(args.root / method / f"seed_{seed}").elapsed
                         for seed in args.seeds) / 3600
             for method in METHODS}
    lines = [
        "# Quality diversity: the paper's GA against MAP-Elites", "",
        f"Generated by `python scripts/qd_comparison.py --root {args.root} --seeds "
        f"{' '.join(map(str, args.seeds))} --pop {args.pop} --gens {args.gens} --report --docs "
        f"{_shown(args.docs)}` from its run folders; regenerate instead of editing.", "",
        f"Both search 3D feed-forward NCAs (the paper's locomotion task and default physics) "
        f"with {args.pop} evaluations per generation (iteration) for {args.gens}: "
        f"{args.pop * args.gens} evaluations per run, seeds {', '.join(map(str, args.seeds))}. "
        f"GA: the paper's 3D settings scaled to the population ({ga_config['ga']['truncation']} "
        f"parents, {ga_config['ga']['elites']} elites, σ {ga_config['ga']['sigma']}). "
        f"MAP-Elites (ribs): {config['map_elites']['emitters']} Gaussian emitters, σ "
        f"{config['map_elites']['sigma']}, descriptors voxels × muscle fraction in "
        f"{config['map_elites']['cells'][0]} × {config['map_elites']['cells'][1]} cells. "
        f"Every evaluation of either method is placed in one archive of those cells to compare "
        f"QD score (sum of elites' fitness + 21) and coverage. A morphology walks when its "
        f"cell's elite goes at least {WALKING:.0%} of the farthest robot of the comparison "
        f"({farthest:.2f} voxel lengths); it transfers when the paper's engine walks that "
        f"elite at least {ENGINE:.0%} as far as its run recorded (`--engine DIR`, kept in "
        f"{ENGINE_WALKS} beside the runs; – where not measured). Wall time of the runs by "
        f"their own clocks "
        f"(metrics.csv), summed over the seeds: GA {hours['ga']:.2f} h, MAP-Elites "
        f"{hours['map-elites']:.2f} h.", "",
        "| method | seed | evaluations | best fitness | QD score | coverage | walking morphologies | of which transfer to the engine | farthest (voxel lengths) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for (method, seed), r in sorted(rows.items()):
        under_way = ("" if r["evaluations"] >= args.pop * args.gens
                     else f" of {args.pop * args.gens} (under way)")
        lines.append(f"| {method} | {seed} | {r['evaluations']}{under_way} | {r['best']:.2f} | "
                     f"{r['qd_score']:.0f} | {r['coverage']:.1%} | {r['walking']} | "
                     f"{'–' if r['transfer'] is None else r['transfer']} | "
                     f"{r['distance']:.2f} |")
    lines += [_mean_row(method, [rows[(method, s)] for s in args.seeds]) for method in METHODS]
    if any(r["evaluations"] < args.pop * args.gens for r in rows.values()):
        lines += ["", "Runs under way count the evaluations they have made; the curves end where "
                  "the shortest run of each method stands."]
    small = {m: np.mean([rows[(m, s)]["small"] for s in args.seeds]) for m in METHODS}
    lines += ["", f"Share of the evaluations that are small robots (at most {SMALL} voxels): "
              + ", ".join(f"{m} {small[m]:.0%}" for m in METHODS) + ". The QD score counts "
              "each filled cell's elite's fitness + 21, so with most elites near -10 it "
              "mostly counts filled cells (coverage).", "",
              "![best fitness and QD score over evaluations](quality_diversity/curves.png)", "",
              "Every evaluation of seed 0 placed in the archive, GA and MAP-Elites:", "",
              "![GA](quality_diversity/heatmap_ga.png) "
              "![MAP-Elites](quality_diversity/heatmap_map-elites.png)", "",
              "MAP-Elites' elites across the map (seed 0), in their initial pose:", "",
              "![gallery](quality_diversity/gallery_map_elites.png)", ""]
    (args.docs / "quality_diversity.md").write_text("\n".join(lines))
    print(f"wrote {args.docs / 'quality_diversity.md'}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=Path("runs") / "qd")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--pop", type=int, default=50, help="evaluations per generation")
    parser.add_argument("--gens", type=int, default=40, help="generations (iterations)")
    parser.add_argument("--emitters", type=int, default=5, help="MAP-Elites emitters")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS),
                        help="the methods to run, each seed in this order (default: both)")
    parser.add_argument("--report", action="store_true", help="write the report (no runs)")
    parser.add_argument("--docs", type=Path, default=ROOT_DOCS,
                        help="folder of the report: quality_diversity.md and its figures "
                             "(default: docs/results/, which docs/results.md includes)")
    parser.add_argument("--engine", type=Path,
                        help="with --report: the paper's engine's folder (its vxa.py), to walk "
                             f"the walking elites <root>/{ENGINE_WALKS} does not hold yet")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    if args.engine is not None and not args.report:
        parser.error("--engine goes with --report")
    if args.report and args.methods != list(METHODS):
        parser.error("--methods chooses the runs to make; a report compares both")
    if args.report:
        report(args)
        return 0
    restore = interrupt.install()  # also where the shell started this script ignoring SIGINT
    try:
        run_all(args)
    except KeyboardInterrupt:
        print("qd_comparison: interrupted; every run keeps its last finished generation: run "
              "the same command again to resume", file=sys.stderr)
        return 130
    finally:
        restore()
    return 0


if __name__ == "__main__":
    sys.exit(main())
