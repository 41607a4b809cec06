#!/usr/bin/env python3
"""Write docs/results.md and its figures (docs/results/*.png) from the results runs.

Reads the evolution runs under --root (default records/paper, the records in git that
docs/results.md is made from; runs/results for the runs of `scripts/paper_experiments.py`:
<root>/<condition>/seed_<n>), the regrowth runs (<root>/regen_<walker>_<net>/seed_<n>, their
recovery.json) and the shipped assets
(assets/nca/manifest.json, assets/robots/walkers/walkers.json), and writes:

  fitness_2d.png, fitness_3d.png   mean best fitness over runs with bootstrapped 95 % CIs,
                                   feed-forward vs LSTM (`mjregen.search.stats`)
  growth_<asset>.png               growth sequence of every shipped NCA
  gallery_<asset>.png              one rendered frame of every shipped robot (headless), and
                                   gallery_best_<condition>.png of each condition's best robot
  best_3d_walker.mp4               the best robot of all 3D runs walking, in slow motion
  results.md                       settings vs the paper, curves, tables, the regrowth table
                                   beside the paper's Table 1, the GA against MAP-Elites
                                   (results/quality_diversity.md, included), measured facts for
                                   discussion

Each condition's best robot walked in the paper's engine, and how many finished runs end on
a robot that transfers, are read from --root's transfer.json when it is there (`python
benchmarks/transfer.py --voxelyze DIR --best-of ROOT --each-run ROOT --json
ROOT/transfer.json`; the engine is not shipped). The Table 1 runs (ROOT/table1/<robot>_<net>/
seed_<n>, `mjregen.experiments.table1`) and the grow-regrow runs (ROOT/grow_regrow_*/seed_<n>,
judged beside the 3D growth-only runs by `mjregen.experiments.self_regrowth`) are shown with
their robots' walks in the engine where ROOT keeps them (`benchmarks/transfer.py --table1 ROOT
--grow-regrow ROOT`).

It works on whatever exists: a condition without runs gets a "not run" line. The paper's
Table 1 is parsed from the paper's LaTeX (--paper, default $MJREGEN_PAPER or ./paper; a
verbatim copy of the table in this file otherwise). Prose of your own goes into
<out>_discussion.md beside --out (docs/results_discussion.md), which is included verbatim
when it exists; the figures go into a folder named as --out without .md (docs/results/).

With --table1 only the paper's robots regrown (assets/regen/manifest.json beside the paper's
Table 1) are written, with the similarity curves of the regrowth runs given to
--regrowth-runs: docs/table1.md.

Examples:
  python scripts/results_report.py
  python scripts/results_report.py --root runs/results --no-render
  python scripts/results_report.py --table1 --regrowth-runs runs/table1/* --out docs/table1.md
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from mjregen.errors import MjregenError
from mjregen.experiments import paper as ex
from mjregen.validation.transfer import ENGINE, FINER_STEP, KEEP, read_measurements

ROOT = Path(__file__).resolve().parents[1]
RECORDS = ROOT / "records" / "paper"  # the runs docs/results.md reports, kept in git
PAPER_GLOB = Path(os.environ.get("MJREGEN_PAPER", "paper"))  # a folder with the paper's LaTeX
# The paper's Table 1, verbatim (used when its LaTeX is not on this machine).
TABLE_1_LATEX = r"""
    Morphology (Network) & Similarity & Original & Damaged & Regrown\\
    \hline
    Biped (feed forward) & $98\%$ (718/729) & 40.4  & 27.2($67\%$) & 35.1($86\%$) \\
    Tripod (feed forward) & $99\%$ (728/729) &44.5 & 1.63($3.6\%$) & 20.3($45\%$) \\
    Multiped (recurrent) &$91\%$ (667/729)& 42.7 & 5.36($12\%$) & 9.6($22\%$) \\
"""
_ROW = re.compile(r"^\s*(\w+) \(([\w ]+)\)\s*&\s*\$?([\d.]+)\\%\$?\s*\((\d+)/(\d+)\)\s*&\s*([\d.]+)\s*&"
                  r"\s*([\d.]+)\s*\(\$([\d.]+)\\%\$\)\s*&\s*([\d.]+)\s*\(\$([\d.]+)\\%\$\)", re.MULTILINE)
NAMES = {"ff": "feed-forward", "lstm": "LSTM"}
DISTANCE_RESOLUTION = 0.005  # voxel lengths: a distance below it is a robot at rest
PAPER_ROBOTS = ROOT / "assets" / "robots" / "paper"


def parse_table_1(latex: str) -> list[dict]:
    """Rows of the paper's Table 1: robot, network, similarity (cells of grid_cells), and
    distances (voxel lengths) of the original, damaged and regrown robot with percentages."""
    rows = []
    for m in _ROW.finditer(latex):
        rows.append({"robot": m[1], "network": m[2], "similarity_percent": float(m[3]),
                     "similarity": int(m[4]), "grid_cells": int(m[5]), "original": float(m[6]),
                     "damaged": float(m[7]), "damaged_percent": float(m[8]),
                     "regrown": float(m[9]), "regrown_percent": float(m[10])})
    return rows


def paper_table_1(paper: Path | None) -> tuple[list[dict], str]:
    """(rows, where they came from): the LaTeX file when it has the table, else the copy."""
    candidates = [paper] if paper is not None else sorted(PAPER_GLOB.glob("*.txt"))
    for path in candidates:
        if path is not None and path.is_file():
            rows = parse_table_1(path.read_text(errors="replace"))
            if rows:
                return rows, f"parsed from the paper's LaTeX ({path.name})"
    return parse_table_1(TABLE_1_LATEX), "from the copy of the paper's LaTeX table in scripts/results_report.py"


def fmt(value: float | None, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return f"{value:.{digits}g}"


def fmt_distance(value: float | None, digits: int = 3) -> str:
    """A distance in voxel lengths to `digits` significant digits; below
    `DISTANCE_RESOLUTION` it is a robot at rest (numerical noise) and shows as 0."""
    if value is not None and math.isfinite(value) and abs(value) < DISTANCE_RESOLUTION:
        return "0"
    return fmt(value, digits)


def percent(value: float | None) -> str:
    """A percentage to whole percent ("–" when missing)."""
    return fmt(value, 99) if value is None or not math.isfinite(value) else f"{value:.0f}"


def _spread(spread, spec: str, unit: str = "") -> str:
    """A `mjregen.experiments.table1.Spread` as "mean (low–high)`unit`" ("mean`unit`" for
    one value, "–" for none), each number formatted by `spec`."""
    if spread.n == 0:
        return "–"
    if spread.n == 1 or spread.low == spread.high:
        return format(spread.mean, spec) + unit
    return f"{spread.mean:{spec}} ({spread.low:{spec}}–{spread.high:{spec}}){unit}"


def _git() -> str:
    try:
        done = subprocess.run(["git", "rev-parse", "--short", "HEAD"], check=False, cwd=ROOT,
                              capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"
    return done.stdout.strip() or "unknown"


def _rel(path: Path, start: Path) -> str:
    try:
        return str(path.resolve().relative_to(start.resolve()))
    except ValueError:
        return str(path)


def _best_distance(run: ex.RunInfo) -> float:
    from mjregen.growth.checkpoint import load_nca

    npz = run.best_files()[0]
    if not npz.is_file():
        return math.nan
    return float(load_nca(npz)[1].get("distance", math.nan))


REWALK_STARTS = 10  # symmetry-broken starts a run's best robot is walked from today


def _rewalked(run: ex.RunInfo) -> float:
    """Voxel lengths: the run's best robot walked today (default physics, for its run's
    times: `RunInfo.robot_physics`) from starts 0 .. REWALK_STARTS - 1, the mean (`mjregen
    walk ROBOT --starts 10`, with a sheet's --settle 1 --duration 0.25); NaN without it or
    when a start is unstable."""
    from mjregen.grid import Robot
    from mjregen.physics.simulation import simulate_starts

    npy = run.best_files()[1]
    if not npy.is_file():
        return math.nan
    return float(np.mean([r.distance for r in simulate_starts(
        Robot.load(npy), physics=run.robot_physics, starts=range(REWALK_STARTS))]))


TRANSFER_FILE = "transfer.json"  # in the results root: `benchmarks/transfer.py --best-of ROOT`


def _engine_cell(measured: dict | None) -> str:
    """A best robot's walk in the paper's engine and whether it transfers, or why not."""
    if measured is None:
        return "not measured"
    engine = measured.get("engine")
    verdict = "transfers" if measured.get("transfers") else "does not transfer"
    return f"{fmt_distance(engine, 4) if engine is not None else 'n/a'} ({verdict})"


def _metric_sum(run: ex.RunInfo, column: str) -> int:
    import csv

    with (run.path / "metrics.csv").open() as handle:
        return sum(int(float(r[column])) for r in csv.DictReader(handle))


def _finished_or_all(runs: list[ex.RunInfo]) -> tuple[list[ex.RunInfo], list[ex.RunInfo]]:
    """(runs a condition's curve and comparison use, runs left out): its finished runs and
    those still under way when any has finished (a run under way would cut every curve to
    its generations), else all of them and none."""
    finished = [r for r in runs if r.complete]
    if not finished:
        return runs, []
    return finished, [r for r in runs if not r.complete]


def _under_way(runs: list[ex.RunInfo]) -> str:
    """"seed 3 at generation 260 of 300, ..." for runs left out while under way."""
    return ", ".join(f"seed {r.seed} at generation {r.generations_done} of "
                     f"{r.generations_planned}" for r in runs)


def _network_comparison(dim: int, ff: list, lstm: list, left_out: int = 0) -> str:
    """One sentence comparing the feed-forward and LSTM runs' best fitness at the last
    generation all of them reached, by exact tests (`mjregen.search.compare`), with n and
    what n allows; `left_out` runs still under way are named as not counted."""
    from mjregen.search.compare import compare_groups

    g = min(len(r.best) for r in ff + lstm) - 1
    paper = "LSTM slightly better" if dim == 2 else "feed-forward better"
    comparison = compare_groups([r.best[g] for r in ff], [r.best[g] for r in lstm])
    verdict = ("a difference at the 5 % level" if comparison.p_mann_whitney < 0.05 else
               "no difference this n can show" if comparison.smallest_p >= 0.05 else
               "no difference at the 5 % level")
    counted = f"; {left_out} runs under way not counted" if left_out else ""
    return (f"{dim}D, best fitness at generation {g} (the last all runs reached{counted}): "
            f"{comparison.sentence(('feed-forward', 'LSTM'))}: {verdict}; the paper found "
            f"{paper} ({ex.CONDITIONS[f'{dim}d_ff'].paper_runs} runs per condition).")


def _damage_name(damage: str) -> str:
    """A grow-regrow damage (`--cut`) in words."""
    return {"paper": "the paper's cut, grid x-indices 0–3",
            "half": "each robot's own lower half across its longest extent"}.get(
                damage, f"the half-space `{damage}`")


def _evaluation_cell(task: dict, dim: int) -> str:
    """The settings table's evaluation column of a run's stored task: body, settle and walk
    times against the paper's, and its physics against today's defaults."""
    from mjregen.physics import PAPER_TIMES, Physics, paper_physics
    from mjregen.tasks.locomotion import LocomotionTask

    physics = task.get("physics", {})
    settle = physics.get("scene", {}).get("settle_time") if isinstance(physics, dict) else None
    paper_settle, paper_walk = PAPER_TIMES[dim]
    settle_s = paper_settle if settle is None else settle
    walk_s = paper_walk if task.get("duration") is None else task["duration"]
    same = (settle_s, walk_s) == (paper_settle, paper_walk)
    body = ("one-layer sheets on the floor (the paper's 2D robots); "
            if task.get("body") == "sheet" else "")
    rest = (LocomotionTask.from_config(task).robot_physics.scene.rest_threshold
            if task.get("task") == "locomotion" else 0.0)
    ends = f", ending once at rest (`settle_rest` {rest:g})" if rest else ""
    timing = (f"{body}settle {fmt(settle_s)} s{ends} + walk {fmt(walk_s)} s"
              + (" (the paper's)" if same else ""))
    stored = Physics.from_dict(physics) if isinstance(physics, dict) and physics else None
    if stored == Physics().replace(settle_time=settle):
        default = "today's default physics (= `paper_physics()`)"
    elif stored == Physics().replace(settle_time=settle, start_shift=0.0):
        default = ("today's default physics from the exact start (before the start "
                   "shift; docs/transfer.md)")
    elif stored == paper_physics().replace(settle_time=settle, bond_element="tendons"):
        default = "`paper_physics()` with tendon bonds (`--bonds tendons`)"
    else:
        default = "physics differ from today's defaults (see the run's config.json)"
    return f"{timing}; {default}"


class Report:
    """Collects the sections of results.md and the facts for the discussion."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args
        self.doc_dir = args.out.parent
        self.figures = args.figures
        self.figures.mkdir(parents=True, exist_ok=True)
        self.lines: list[str] = []
        self.facts: list[str] = []
        self.runs = ex.list_runs(args.root)
        self.stats: dict[str, object] = {}
        self.transfer = read_measurements(args.root / TRANSFER_FILE)

    def add(self, *lines: str) -> None:
        self.lines.extend(lines)

    def _measured(self, run: ex.RunInfo) -> dict | None:
        """The transfer measurement of `run`'s best robot in ``transfer.json``, if any."""
        return self.transfer.get(ex.robot_name(self.args.root, run))

    def _compare_networks(self, dim: int, names: list[str]) -> None:
        """The facts comparing the feed-forward and LSTM runs of `names`: by fitness, and by
        their best robots' walks in the paper's engine where every one was measured."""
        (ff, ff_out), (lstm, lstm_out) = (_finished_or_all(self.runs[n]) for n in names)
        self.facts.append(_network_comparison(dim, ff, lstm, left_out=len(ff_out) + len(lstm_out)))
        engine = self._engine_comparison(dim, ff, lstm)
        if engine:
            self.facts.append(engine)

    def _engine_comparison(self, dim: int, ff: list[ex.RunInfo], lstm: list[ex.RunInfo]
                           ) -> str | None:
        """One sentence comparing the networks by what transfers: the paper engine's
        distance of each finished run's best robot (``transfer.json``), by exact tests; None
        unless every finished run of both networks has been measured there."""
        from mjregen.search.compare import compare_groups

        groups = [[self._measured(r) for r in runs if r.complete] for runs in (ff, lstm)]
        if not all(groups) or any(m is None or m.get("engine") is None
                                  for group in groups for m in group):
            return None
        comparison = compare_groups(*([m["engine"] for m in group] for group in groups))
        verdict = ("a difference at the 5 % level" if comparison.p_mann_whitney < 0.05 else
                   "no difference this n can show" if comparison.smallest_p >= 0.05 else
                   "no difference at the 5 % level")
        return (f"{dim}D, each finished run's best robot walked in the paper's engine (voxel "
                f"lengths; what transfers, not the fitness an artefact can win): "
                f"{comparison.sentence(('feed-forward', 'LSTM'))}: {verdict}.")

    def _transfer_count(self, runs: list[ex.RunInfo]) -> str:
        """How many finished runs' best robots transfer, of those measured in
        ``transfer.json`` (`benchmarks/transfer.py --each-run`)."""
        finished = [r for r in runs if r.complete]
        measured = [m for m in map(self._measured, finished) if m is not None]
        if not measured:
            return "not measured"
        yes = sum(bool(m.get("transfers")) for m in measured)
        return f"{yes} of {len(measured)}" + (f" measured ({len(finished)} finished)"
                                              if len(measured) < len(finished) else "")

    def image(self, path: Path, alt: str) -> str:
        return f"![{alt}]({_rel(path, self.doc_dir)})"

    # --- sections -----------------------------------------------------------------------

    def header(self) -> None:
        self.add(f"# {self.args.title}", "",
                 f"Generated by `python scripts/results_report.py` on "
                 f"{datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')} at commit {_git()} from "
                 f"`{_rel(self.args.root, ROOT)}` and `{_rel(self.args.assets, ROOT)}`. Every number, plot and "
                 "table below is written by that script; regenerate instead of editing.", "")

    def reproduce(self) -> None:
        if Path(self.args.root) != ex.DEFAULT_ROOT:
            self._reproduce_root()
            return
        self.add("## How to reproduce", "",
                 "At the paper's scale (about 300 CPU-hours; resumable, run it again after a kill):",
                 "```bash",
                 "python scripts/paper_experiments.py --scale paper --workers $(nproc)",
                 "python scripts/ship_assets.py --best --walkers --overwrite --replace-default",
                 f"python scripts/results_report.py --root {ex.DEFAULT_ROOT}",
                 "```",
                 "At a reduced scale (`--scale quick`, about 75 minutes on two cores); the "
                 "settings table below says at which scale each condition here ran:",
                 "```bash",
                 "python scripts/paper_experiments.py --scale quick --workers 2",
                 "python scripts/ship_assets.py --best --walkers --overwrite --replace-default",
                 f"python scripts/results_report.py --root {ex.DEFAULT_ROOT}",
                 "```",
                 "`python scripts/paper_experiments.py --scale paper --dry-run` prints every "
                 "`mjregen evolve` / `mjregen regen` command it runs (each writes the same run "
                 "folder as the script).", "")

    def _reproduce_root(self) -> None:
        """How to reproduce the runs under another root than the default: one
        `paper_experiments.py` line per condition with its number of runs."""
        root = _rel(Path(self.args.root), ROOT)
        self.add("## How to reproduce", "",
                 f"The runs under `{root}`, one line per condition (each runs its runs one "
                 "after the other and resumes each where its checkpoint stopped; records/"
                 "README.md says how to restore and continue them from the records in git):",
                 "```bash",
                 *(f"python scripts/paper_experiments.py --root {root} --only {name} "
                   f"--runs {1 + max(r.seed for r in runs)} --workers 1"
                   for name, runs in self.runs.items()),
                 f"python benchmarks/transfer.py --voxelyze DIR --best-of {root} --each-run "
                 f"{root} --json {root}/{TRANSFER_FILE}",
                 f"python scripts/ship_assets.py --root {root} --best --voxelyze DIR --overwrite",
                 f"python scripts/results_report.py --root {root}",
                 "```",
                 "`--dry-run` prints every `mjregen evolve` command a line runs (each writes "
                 "the same run folder as the script); DIR is the paper's engine (not shipped), "
                 "which the transfer check needs."
                 + (" records/README.md gives the commands of the regrowth and grow-regrow "
                    "runs." if ex.list_regen_runs(self.args.root) else ""), "")

    def settings(self) -> None:
        self.add("## Settings: what was run, against the paper", "",
                 "| condition | paper: pop × gens × runs | here: pop × gens (finished) × runs | "
                 "evaluations here / paper | truncation, elites, σ here (paper) | scale | evaluation "
                 "| wall time |",
                 "|---|---|---|---|---|---|---|---|")
        for name, condition in ex.CONDITIONS.items():
            paper = condition.paper_ga
            paper_evals = paper.population * paper.generations * condition.paper_runs
            runs = self.runs.get(name)
            if not runs:
                self.add(f"| {name} | {paper.population} × {paper.generations} × "
                         f"{condition.paper_runs} | not run | – | – ({paper.truncation}, "
                         f"{paper.elites}, {paper.sigma:g}) | – | – | – |")
                continue
            ga = runs[0].config["ga"]
            done = sorted({r.generations_done for r in runs})
            evals = sum(r.generations_done for r in runs) * ga["population"]
            evaluation = _evaluation_cell(runs[0].config["task"], condition.dim)
            hours = f"{sum(r.elapsed for r in runs) / 3600:.2g}"
            self.add(f"| {name} | {paper.population} × {paper.generations} × {condition.paper_runs} | "
                     f"{ga['population']} × {ga['generations']} ({'/'.join(map(str, done))}) × {len(runs)} | "
                     f"{evals} / {paper_evals} ({100 * evals / paper_evals:.2g} %) | "
                     f"{ga['truncation']}, {ga['elites']}, {ga['sigma']:g} ({paper.truncation}, "
                     f"{paper.elites}, {paper.sigma:g}) | {ex.scale_of(runs[0].config)} | "
                     f"{evaluation} | {hours} h |")
            self.facts.append(f"{name}: {evals} evaluations, {100 * evals / paper_evals:.2g} % of "
                              f"the paper's {paper_evals}, in {hours} h of wall time.")
        self.add("", "The paper's evaluation: 2D 0.25 s of walking (10 cycles at 40 Hz), 3D 0.5 s "
                 "(20 cycles), after our settle of 1.0 s (2D) / 0.05 s (3D); 3D fitness = "
                 "distance − 0.0583 × voxels. Physics: as the evaluation column says, stored in each "
                 "run's config.json (docs/fidelity.md compares it with the paper's engine). Truncation "
                 "and elites keep the paper's share of the population (20 %; 2D: one elite). Wall "
                 "time: the generations' own, summed over the runs (metrics.csv), on the machine "
                 "each ran on.", "")

    def curves(self) -> None:
        from mjregen.search.stats import bootstrap_curves, plot_panels

        self.add("## Fitness over generations", "",
                 "Mean over runs of each run's best fitness per generation, shaded: bootstrapped "
                 "95 % CI of the mean (10,000 resamples), runs cut to the shortest; where some "
                 "of a condition's runs have finished, its curve, its table row and the "
                 "comparison of the networks count those only (the runs under way are named "
                 "in the row). The paper "
                 "reports the same statistic (its Fig. 3b and 4b). With two or three runs such a "
                 "band is little more than their range: the networks are compared below by exact "
                 "tests, with the smallest p their n allows. Fitness here is what each run "
                 "recorded, from the start its evaluations used (runs before the start shift: "
                 "the exact start). The best run's robot is walked today from symmetry-broken "
                 "starts, and in the paper's engine by `python benchmarks/transfer.py "
                 f"--voxelyze DIR --best-of ROOT --each-run ROOT --json ROOT/{TRANSFER_FILE}` "
                 "(3D grids: 3D robots and 2D sheets; the engine is not shipped, so the report "
                 "reads the measurements kept beside the runs, and says 'not measured' where "
                 "none is kept for that robot; `--each-run` measures every finished run's best "
                 "robot); the transfer check: fresh starts, turned copies and a walk at "
                 f"{FINER_STEP:g} of the time step keep at least {KEEP:.0%} of its distance and "
                 f"the engine walks it at least {ENGINE:.0%} as far (docs/transfer.md).",
                 "")
        for dim in (2, 3):
            names = [f"{dim}d_{k}" for k in ex.NETS]
            groups = {}
            for name in names:
                runs = self.runs.get(name)
                if not runs:
                    self.add(f"- {name}: not run.")
                    continue
                shown, _ = _finished_or_all(runs)
                length = min(len(r.best) for r in shown)
                stats = bootstrap_curves(np.stack([r.best[:length] for r in shown]))
                groups[NAMES[name.split("_")[1]]] = stats
                self.stats[name] = stats
            if not groups:
                self.add(f"- {dim}D: no runs, no plot.", "")
                continue
            path = self.figures / f"fitness_{dim}d.png"
            plot_panels({f"best fitness ({dim}D)": groups}, path)
            self.add("", self.image(path, f"{dim}D fitness curves"), "",
                     "| condition | runs | generations | final best fitness of each run (mean) | best run: "
                     "fitness, distance (voxel lengths), seed, generation | its robot today: "
                     f"distance from {REWALK_STARTS} symmetry-broken starts | in the paper's "
                     "engine (transfer check) | finished runs whose best robot transfers | "
                     "unstable / failed evaluations |",
                     "|---|---|---|---|---|---|---|---|---|")
            for name in names:
                runs = self.runs.get(name)
                if not runs:
                    self.add(f"| {name} | not run | | | | | | | |")
                    continue
                self.add(self._condition_row(name, runs))
            self.add("")
            if len(groups) == 2:
                self._compare_networks(dim, names)

    def _condition_row(self, name: str, runs: list[ex.RunInfo]) -> str:
        """A condition's row of the fitness table (its curve's statistics in `self.stats`)."""
        stats = self.stats[name]
        shown, left_out = _finished_or_all(runs)
        top = ex.best_run(shown)
        unstable = sum(_metric_sum(r, "unstable") for r in shown)
        failed = sum(_metric_sum(r, "failed") for r in shown)
        finals = ", ".join(f"{r.best[len(stats.mean) - 1]:.4g}" for r in shown)
        count = f"{len(shown)} (under way: {_under_way(left_out)})" if left_out else len(shown)
        return (f"| {name} | {count} | {len(stats.mean)} | {finals} "
                f"({stats.mean[-1]:.4g}) | {top.best_fitness:.4g}, "
                f"{fmt_distance(_best_distance(top), 4)}, seed {top.seed}, "
                f"gen {top.best_generation} | {fmt_distance(_rewalked(top), 4)} | "
                f"{_engine_cell(self._measured(top))} | "
                f"{self._transfer_count(runs)} | {unstable} / {failed} |")

    def shipped(self) -> list[tuple[str, Path, Path | None]]:
        """Shipped NCAs: table and growth figures; returns (name, robot file, nca file) to draw."""
        from mjregen.figures import growth_figure
        from mjregen.growth.checkpoint import load_nca

        manifest_path = self.args.assets / "nca" / "manifest.json"
        manifest = json.loads(manifest_path.read_text()) if manifest_path.is_file() else {}
        real = {k: v for k, v in manifest.items() if not v.get("placeholder", False)}
        self.add("## Shipped NCAs", "")
        drawn: list[tuple[str, Path, Path | None]] = []
        placeholders = sorted(k for k, v in manifest.items() if v.get("placeholder", False))
        if placeholders:
            self.add(f"Placeholders in the manifest (not results): {', '.join(placeholders)}.", "")
        if not real:
            self.add("No evolved NCA is shipped yet: run `python scripts/ship_assets.py --best`.", "")
            return drawn
        self.add(f"From `{_rel(manifest_path, ROOT)}`: each was grown and simulated again by "
                 "`scripts/ship_assets.py` with the code at its commit, and `tests/test_assets.py` "
                 "checks that today's code reproduces the fitness.", "",
                 "| file | condition | scale | run, generation | fitness | distance (voxel lengths) | "
                 "voxels (soft/hard/+/−) | pieces |", "|---|---|---|---|---|---|---|---|")
        for key, entry in real.items():
            r = entry["robot"]
            source = entry["source"]
            self.add(f"| {key} | {entry['condition']} | {entry.get('scale')} | "
                     f"{source['run']} gen {source['generation']} | {entry['fitness']:.4g} | "
                     f"{fmt_distance(entry['distance'], 4)} | {r['voxels']} ({r['soft']}/{r['hard']}/"
                     f"{r['muscle_plus']}/{r['muscle_minus']}) | {r.get('pieces', '–')} |")
        self.add("", "Growth sequences (10 NCA steps, then the paper's cleaning):", "")
        for key, entry in real.items():
            if "same_as" in entry:
                continue
            npz = self.args.assets / "nca" / entry["file"]
            nca, _ = load_nca(npz)
            growth = nca.grow()
            states = np.concatenate([growth.states[0], growth.robot().grid[None]])
            path = self.figures / f"growth_{npz.stem}.png"
            growth_figure(states, path, overwrite=True,
                          titles=[f"step {k}" for k in range(len(states) - 1)] + ["cleaned"])
            self.add(f"**{key}**", "", self.image(path, f"growth of {key}"), "")
            drawn.append((npz.stem, npz.with_suffix(".npy"), npz))
        return drawn

    def walkers(self) -> list[tuple[str, Path, Path | None]]:
        index = self.args.assets / "robots" / "walkers" / "walkers.json"
        self.add("## Walkers of the regrowth experiment", "")
        if not index.is_file():
            self.add("Not shipped yet (`python scripts/ship_assets.py --walkers`).", "")
            return []
        data = json.loads(index.read_text())
        self.add(f"The shipped walkers (`{_rel(index, ROOT)}`), whatever root this page reports; "
                 "their source is the run each came from. " + data.get("diversity", ""), "",
                 "| walker | source | fitness | distance | voxels | soft/hard/+/− | feet | l × w × h |",
                 "|---|---|---|---|---|---|---|---|")
        drawn = []
        for w in data["walkers"]:
            f, m = w["features"], w["materials"]
            source = w.get("run") or f"{w['condition']} seed {w['seed']}"
            self.add(f"| {w['name']} | {source} gen {w['generation']} | "
                     f"{w['fitness']:.4g} | {fmt_distance(w['distance'], 4)} | {w['voxels']} | "
                     f"{m['soft']}/{m['hard']}/{m['muscle_plus']}/{m['muscle_minus']} | "
                     f"{f['feet']:.0f} | {f['length']:.0f} × {f['width']:.0f} × {f['height']:.0f} |")
            drawn.append((w["name"], index.parent / w["robot_file"], None))
        self.add("")
        return drawn

    def best_of_conditions(self) -> list[tuple[str, Path, Path | None]]:
        """(name, robot file, NCA file) of each condition's best robot (its best run's best
        generation), to draw beside the shipped ones."""
        found = []
        for name, runs in self.runs.items():
            npz, npy = ex.best_run(_finished_or_all(runs)[0]).best_files()
            if npy.is_file():
                found.append((f"best_{name}", npy, npz))
        return found

    def gallery(self, robots: list[tuple[str, Path, Path | None]]) -> None:
        self.add("## Gallery", "")
        if not robots:
            self.add("Nothing shipped or evolved to draw.", "")
            return
        if self.args.no_render:
            self.add("Not rendered (`--no-render`).", "")
            return
        from PIL import Image

        from mjregen.grid import Robot
        from mjregen.physics.compile import compile_robot
        from mjregen.render import RobotRenderer, View

        cells = []
        for name, npy, _ in robots:
            robot = Robot.load(npy)
            if robot.is_empty:
                continue
            path = self.figures / f"gallery_{name}.png"
            with RobotRenderer(compile_robot(robot), view=View(width=320, height=240)) as renderer:
                Image.fromarray(renderer.render()).save(path, format="PNG")
            cells.append(f"{self.image(path, name)}<br>{name}, {robot.n_voxels} voxels")
        self.add("Each robot in its initial pose (before the settle), in the paper's colours: "
                 "light blue soft, dark blue hard, red muscle +, green muscle −; "
                 "`best_<condition>` is the condition's best robot of the runs under the "
                 "results root.", "",
                 "| " + " | ".join(cells) + " |", "|" + "---|" * len(cells), "")

    def best_walker_video(self) -> None:
        """The farthest 3D walker that transfers (`best_transferring`; without
        measurements: the best robot of all 3D runs) walking, in slow motion:
        best_3d_walker.mp4."""
        self.add("## The best 3D walker", "")
        runs = [run for name, group in self.runs.items() if name.startswith("3d_")
                for run in _finished_or_all(group)[0]]
        if not runs:
            self.add("No 3D runs.", "")
            return
        found = self.best_transferring("3d_")
        top = ex.best_run(runs) if found is None else found[0]
        npy = top.best_files()[1]
        label = (f"the best robot of {top.path.parent.name} seed {top.seed}, generation "
                 f"{top.best_generation} (fitness {top.best_fitness:.4g}"
                 + (f"; the farthest 3D walker that transfers, {fmt_distance(found[1]['engine'], 4)}"
                    " voxel lengths in the paper's engine)" if found else ")"))
        if self.args.no_render or not npy.is_file():
            self.add(f"Not rendered ({'`--no-render`' if npy.is_file() else 'no robot file'}): "
                     f"{label}.", "")
            return
        from mjregen.grid import Robot
        from mjregen.physics.compile import compile_robot
        from mjregen.render import record_walk
        from mjregen.video import write_video

        compiled = compile_robot(Robot.load(npy))
        walk = record_walk(compiled)
        path = write_video(compiled, walk.qpos, self.figures / "best_3d_walker.mp4",
                           overwrite=True, progress=False)
        self.add(f"[Video]({_rel(path, self.doc_dir)}) of {label}: its walk from start 0 "
                 "(seed 0) with today's default physics, settle included, 10 times slower than "
                 "real time" + ("" if walk.stable else f"; it became unstable ({walk.reason})")
                 + ".", "")

    def regeneration(self) -> None:
        rows, source = paper_table_1(self.args.paper)
        self.add("## Regeneration and locomotion recovery", "",
                 "Each walker's grown CA state is cut like the paper's robots (grid x-indices 0–3 "
                 "of 9 emptied, alpha zeroed), a second NCA evolved for similarity (cells equal to "
                 "the original, of 729) regrows it for 10 steps, and the original, damaged and "
                 "regrown robots walk with the same physics (the paper: 0.5 s).", "")
        found = ex.list_regen_runs(self.args.root)
        if not found:
            self.add(f"Ours, of the walkers evolved here: not run on `{_rel(self.args.root, ROOT)}` "
                     f"(`python scripts/paper_experiments.py --root {_rel(self.args.root, ROOT)} "
                     "--only regen`). Table 1 below regrows the paper's own robots.", "")
        else:
            self.add("**Ours**", "",
                     "| walker (regrowth network) | similarity | robot cells matching | voxels orig./dam./regr. | "
                     "original | damaged (% of original) | regrown (% of original) | generations |",
                     "|---|---|---|---|---|---|---|---|")
            withdrawn = self.withdrawn_walkers()
            for walker, net, folder in found:
                r = json.loads((folder / "recovery.json").read_text())
                run = ex.read_run(folder)
                pct = r["percent_of_original"]
                sim = r["similarity"]["regrown"]
                label = f"{walker}, withdrawn" if walker in withdrawn else walker
                self.add(f"| {label} ({NAMES.get(net, net)}) | {100 * sim / r['grid_cells']:.0f} % "
                         f"({sim}/{r['grid_cells']}; damaged {r['similarity']['damaged']}) | "
                         f"{100 * r['robot_similarity']['regrown']:.1f} % | "
                         f"{r['voxels']['original']}/{r['voxels']['damaged']}/{r['voxels']['regrown']} | "
                         f"{fmt_distance(r['distance']['original'], 3)} | "
                         f"{fmt_distance(r['distance']['damaged'], 3)} "
                         f"({percent(pct['damaged'])} %) | {fmt_distance(r['distance']['regrown'], 3)} "
                         f"({percent(pct['regrown'])} %) | {run.generations_done} × pop "
                         f"{run.config['ga']['population']} |")
                if walker in withdrawn:
                    continue
                self.facts.append(
                    f"Regrowth of {walker} ({NAMES.get(net, net)}): {sim}/{r['grid_cells']} cells; "
                    f"damaged walks {percent(pct['damaged'])} % and regrown "
                    f"{percent(pct['regrown'])} % of the original's {fmt_distance(r['distance']['original'], 3)} "
                    "voxel lengths.")
            durations = sorted({json.loads((f / "recovery.json").read_text())["duration"]
                                for _, _, f in found})
            self.add("", f"Distances in voxel lengths over {'/'.join(f'{d:g}' for d in durations)} s "
                     "of walking (unstable runs show –).", "")
            for name, why in withdrawn.items():
                self.add(f"{name} is withdrawn: {why}", "")
        self.table1_runs(rows)
        self.paper_robot_regrowth()
        self.add(f"**The paper's Table 1** ({source}; Voxelyze, robots of its own evolutions, "
                 "regrowth GA 1000 × 1000)", "",
                 "| robot (network) | similarity | original | damaged (% of original) | regrown (% of original) |",
                 "|---|---|---|---|---|")
        for row in rows:
            self.add(f"| {row['robot']} ({row['network']}) | {row['similarity_percent']:g} % "
                     f"({row['similarity']}/{row['grid_cells']}) | {row['original']:g} | "
                     f"{row['damaged']:g} ({row['damaged_percent']:g} %) | {row['regrown']:g} "
                     f"({row['regrown_percent']:g} %) |")
        self.add("")
        self.paper_rows = rows

    def table1_runs(self, paper_rows: list[dict]) -> None:
        """Table 1 from the regrowth runs under <root>/table1 (`mjregen.experiments.table1`):
        each row's mean and range over its seeds, here and in the paper's engine."""
        from mjregen.experiments.table1 import (ENGINE_FILE, all_run_folders, list_table1_runs,
                                                read_engine_distances, runs_under_way,
                                                table1_rows)

        rows = table1_rows(list_table1_runs(self.args.root))
        under_way = runs_under_way(self.args.root)
        if not rows and not under_way:
            return
        measured = read_engine_distances(self.args.root)
        paper = {(r["robot"].lower(), r["network"]): r for r in paper_rows}
        self.add("**Table 1 at the paper's scale** (the regrowth runs under "
                 f"`{_rel(Path(self.args.root) / 'table1', ROOT)}`, one row per robot, regrowth "
                 "network and start; mean (range) over the row's finished runs; the paper: its "
                 "Table 1, one run of its best network per robot)", "")
        if rows:
            self.add("| robot (regrowth network) | start | runs (GA, wall time) | similarity (of 729) / "
                     "paper | original: ours / engine / paper | damaged, % of original: ours / "
                     "engine / paper | regrown, % of original: ours | engine | paper |",
                     "|---|---|---|---|---|---|---|---|---|")
        for row in rows:
            theirs = paper.get((row.robot, "recurrent" if row.net == "lstm" else "feed forward"))
            self._table1_row(row, theirs, measured)
        folders = all_run_folders(self.args.root)
        hours = sum(ex.read_run(folder).elapsed for folder in folders) / 3600
        self.facts.append(f"Table 1 at the paper's scale: {len(folders)} runs, those that grow "
                          f"a robot from its seed and those under way included, {hours:.2g} h "
                          "of wall time.")
        self.add("", "Distances in voxel lengths over 0.5 s, from the fitness's start (ours) and "
                 "in the paper's engine as its code runs it (`python benchmarks/transfer.py "
                 f"--voxelyze DIR --table1 ROOT`, kept in ROOT/{ENGINE_FILE}; – where not "
                 "measured). Start: the CA state regrown from (\"saved\": the biped's as the "
                 "paper's code saved it; \"alpha 1\": the grid alone; \"grown\": the state an "
                 "NCA evolved to grow the robot from its seed grew, `--damage seed`). Wall "
                 "time: the generations' own, summed over the row's runs (metrics.csv), each "
                 "run one process on one core.", "")
        if under_way:
            self.add("Under way, not counted: " + ", ".join(
                f"{_rel(run.folder, Path(self.args.root))} (generation {run.generations} of "
                f"{run.planned})" for run in under_way) + ".", "")
        self.grown_starts()

    def grown_starts(self) -> None:
        """Where a "grown" start could be had: each run that grows a robot from the paper's
        seed (`mjregen.experiments.table1.seed_growth_runs`), and what it grew."""
        from mjregen.experiments.table1 import grows_exactly, seed_growth_runs

        runs = seed_growth_runs(self.args.root)
        if not runs:
            return
        self.add("Grown starts: a \"grown\" row regrows the CA state that an NCA evolved to grow "
                 "the robot from the paper's seed (`mjregen regen --paper ROBOT --damage seed`, "
                 "the same GA) grows, and is run only where that NCA grows every cell as the "
                 "robot has it (otherwise the state grown is another robot's).", "")
        for run in runs:
            what = (f"- {run.robot.capitalize()}, grown from the seed ("
                    f"{NAMES.get(run.net, run.net)} NCA, {run.population} × ")
            if run.recovery is None:
                self.add(what + f"{run.planned}): under way, generation {run.generations}.")
                continue
            cells, grid = run.recovery["similarity"]["regrown"], run.recovery["grid_cells"]
            self.add(what + f"{run.generations}, {run.elapsed / 3600:.2g} h): {cells} of "
                     f"{grid} cells" + (": exact, the start of the grown row." if
                                        grows_exactly(run) else
                                        f", {grid - cells} wrong: no grown state of it, no "
                                        "grown row."))
            self.facts.append(f"{run.robot.capitalize()} grown from the paper's seed "
                              f"(n = 1 run, {NAMES.get(run.net, run.net)}): {cells} of {grid} "
                              "cells" + ("" if grows_exactly(run) else
                                         ", so no grown start of it can be had") + ".")
        self.add("")

    def _table1_row(self, row, theirs: dict | None, measured: dict) -> None:
        """One row of `table1_runs` and its fact; `theirs`: the paper's row for the robot and
        network (None where the paper has none)."""
        root = self.args.root
        net = NAMES.get(row.net, row.net)
        paper = (lambda text: f" / {text}") if theirs else (lambda text: "")
        ga = ", ".join(sorted({f"{r.population} × {r.generations}" for r in row.runs}))
        similarity = _spread(row.similarity(), ".0f")
        ours = {role: (_spread(row.distance(role), ".3g"),
                       _spread(row.percent(role), ".0f", " %") if role != "original" else "")
                for role in ("original", "damaged", "regrown")}
        engine = {role: (_spread(row.engine_distance(root, measured, role), ".3g"),
                         _spread(row.engine_percent(root, measured, role), ".0f", " %"))
                  for role in ("original", "damaged", "regrown")}
        self.add(f"| {row.robot.capitalize()} ({net}) | {row.start} | {len(row.runs)} ({ga}, "
                 f"{row.hours:.2g} h) | "
                 f"{similarity}{paper(theirs and theirs['similarity'])} | "
                 f"{ours['original'][0]} / {engine['original'][0]}"
                 f"{paper(theirs and format(theirs['original'], 'g'))} | "
                 f"{ours['damaged'][1]} / {engine['damaged'][1]}"
                 f"{paper(theirs and format(theirs['damaged_percent'], 'g') + ' %')} | "
                 f"{ours['regrown'][0]}, {ours['regrown'][1]} | "
                 f"{engine['regrown'][0]}, {engine['regrown'][1]} | "
                 + (f"{theirs['regrown']:g}, {theirs['regrown_percent']:g} %" if theirs else "–")
                 + " |")
        self.facts.append(
            f"Table 1, {row.robot} regrown by {net} NCAs from the {row.start} state "
            f"(n = {len(row.runs)} run{'s' * (len(row.runs) != 1)}): {similarity} of "
            f"{row.grid_cells} cells; the regrown "
            "robot walks "
            f"{ours['regrown'][1]} of the original here and {engine['regrown'][1]} in the "
            "paper's engine"
            + (f" (the paper: {theirs['regrown_percent']:g} %, one run)." if theirs else "."))

    def table1_header(self) -> None:
        self.add("# Table 1 at the paper's regrowth scale", "",
                 f"Generated by `python scripts/results_report.py --table1` on "
                 f"{datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')} at commit {_git()} from "
                 f"`{_rel(self.args.assets, ROOT)}/regen/manifest.json`"
                 + (" and the regrowth runs' metrics.csv" if self.args.regrowth_runs else "")
                 + ". Regenerate instead of editing.", "",
                 "Each row: `mjregen regen --paper ROBOT --net NET --gens 1001 --seed 0` (the "
                 "paper's regeneration GA: population 1000, top 200, 200 elites, σ 0.1, and the "
                 "1001 generations of its code's `range(1001)`; rows of a smaller GA add "
                 "`--pop 200 --gens 201`, a twenty-fifth of that work, with the same shares of "
                 "top and elites), shipped with "
                 "`scripts/ship_regrowth.py`, which replays it: the damaged CA state regrown by "
                 "the best NCA, then the original, damaged and regrown robots walked with "
                 "today's default physics (the paper engine's laws, docs/fidelity.md).", "")

    def regrowth_curves(self) -> None:
        """Best similarity per generation of each regrowth run (--regrowth-runs)."""
        from mjregen.plotting import line_axes, save_png

        runs = [Path(r) for r in self.args.regrowth_runs if (Path(r) / "metrics.csv").is_file()]
        if not runs:
            return
        figure, ax = line_axes(xlabel="generation", ylabel="cells equal to the original (of 729)",
                               title="regrowth: best similarity per generation")
        for run in runs:
            best = ex.read_run(run).best
            ax.plot(range(len(best)), best, label=run.name)
        path = self.figures / "table1_similarity.png"
        save_png(figure, path)
        self.add(self.image(path, "best similarity per generation of each regrowth run"), "")

    def paper_robot_regrowth(self) -> None:
        """Table 1 side by side: the paper's robots regrown by the shipped regrowth NCAs
        (assets/regen/manifest.json: each replayed by scripts/ship_regrowth.py and by
        tests/test_assets.py with today's default physics) and the paper's numbers."""
        path = self.args.assets / "regen" / "manifest.json"
        entries = [e for e in (json.loads(path.read_text()).values() if path.is_file() else [])
                   if (PAPER_ROBOTS / f"{e['robot']}.npy").is_file()]
        if not entries:
            return
        paper = {(r["robot"].lower(), r["network"]): r for r in paper_table_1(self.args.paper)[0]}
        self.add("**Table 1: the paper's robots regrown** (ours: the shipped regrowth NCAs of "
                 "`assets/regen/manifest.json`, the paper's cut, today's default physics; the "
                 "paper: its Table 1)", "",
                 "| robot (regrowth network) | start | GA | similarity ours / paper | original "
                 "ours / paper | damaged ours / paper | regrown ours / paper |",
                 "|---|---|---|---|---|---|---|")
        for e in sorted(entries, key=lambda e: (e["robot"], e["net"])):
            dist, pct = e["distance"], e["percent_of_original"]
            theirs = paper.get((e["robot"], "recurrent" if e["net"] == "lstm" else "feed forward"))
            other = (lambda key, pkey: f" / {theirs[key]:g} ({theirs[pkey]:g} %)") if theirs else (lambda *_: "")
            ga = e["ga"]
            self.add(f"| {e['robot'].capitalize()} ({NAMES.get(e['net'], e['net'])}) | {e['start']} | "
                     f"{ga['population']} × {e['generations_run']} | {e['similarity']}/{e['grid_cells']}"
                     + (f" / {theirs['similarity']}/{theirs['grid_cells']}" if theirs else "") + " | "
                     f"{fmt_distance(dist['original'], 3)}"
                     + (f" / {theirs['original']:g}" if theirs else "") + " | "
                     f"{fmt_distance(dist['damaged'], 3)} ({percent(pct['damaged'])} %)"
                     + other("damaged", "damaged_percent") + " | "
                     f"{fmt_distance(dist['regrown'], 3)} ({percent(pct['regrown'])} %)"
                     + other("regrown", "regrown_percent") + " |")
            self.facts.append(
                f"The paper's {e['robot']} regrown by the shipped {NAMES.get(e['net'], e['net'])} "
                f"NCA: {e['similarity']}/{e['grid_cells']} cells; damaged walks "
                f"{percent(pct['damaged'])} %, regrown {percent(pct['regrown'])} % of its "
                f"{fmt_distance(dist['original'], 3)} voxel lengths here.")
        self.add("", "Start: the CA state regrown from (\"saved\": the biped's as the paper's "
                 "code saved it; \"alpha 1\": the grid alone, as only the tripod's and "
                 "multiped's grids were published). GA: population × generations run.", "")

    def withdrawn_walkers(self) -> dict[str, str]:
        """Walkers no longer shipped (assets' walkers.json "withdrawn"): name -> why."""
        index = self.args.assets / "robots" / "walkers" / "walkers.json"
        if not index.is_file():
            return {}
        return {w["name"]: w["why"] for w in json.loads(index.read_text()).get("withdrawn", [])}

    def self_regrowth(self) -> None:
        """One NCA that grows and regrows (`mjregen evolve --task grow-regrow`): the best NCA
        of each run under <root>/grow_regrow_<name>/seed_<n>, beside the growth-only 3D runs
        of the same network and evaluations judged after the same damage, compared by exact
        tests; a table per grow-regrow condition."""
        from mjregen.experiments.engine_walks import read_kept
        from mjregen.experiments.self_regrowth import ENGINE_FILE, run_damage

        self.add("## One NCA that grows and regrows", "")
        folders = sorted(Path(self.args.root).glob("grow_regrow_*/seed_*"))
        runs = [r for r in (ex.read_run(f) for f in folders if (f / "config.json").is_file())
                if r.generations_done]
        if not runs:
            self.add("Not run (`mjregen evolve --task grow-regrow --regrown-weight 0.5 "
                     "--cell-cost 0 --dim 3 --net ff --preset 3d --out "
                     "runs/paper/grow_regrow_walk_ff/seed_0`).", "")
            return
        self.add("The paper needed two networks, one that grows a walker and one that regrows "
                 "it. Here one NCA is evolved for both (`--task grow-regrow`: fitness = "
                 "locomotion fitness − cell cost × cells wrongly regrown after its damage, "
                 "from its own grown CA state, memory included; with a regrown weight w > 0 the "
                 "locomotion fitness is (1 − w) × the grown robot's + w × the regrown robot's, "
                 "`--regrown-weight`). The damage (`--cut`) is the paper's cut (grid x-indices "
                 "0–3 erased) or each robot's own lower half across its longest extent "
                 "(`half`, which for a robot across x 1–7 is the paper's cut). Each run's best "
                 "NCA grows its robot, which is damaged (its damage and 8 random half-space "
                 "cuts) and regrown by the same NCA; the original, damaged and regrown robots "
                 "of its damage walk as in Table 1, here and in the paper's engine. Below "
                 "them, the finished growth-only runs of the same network and the same "
                 "evaluations (`3d_<net>`), whose best NCA is judged after the same damage: "
                 "what a growth-only NCA regrows.", "")
        measured = read_kept(Path(self.args.root) / ENGINE_FILE)
        cuts: list[str] = []
        for condition in sorted({r.condition for r in runs}):
            mine = [r for r in runs if r.condition == condition]
            damage = run_damage(mine[0])
            net = mine[0].config["task"]["nca"]["kind"]
            alone = [r for r in self.runs.get(f"3d_{net}", []) if r.complete]
            self.add(f"**{condition}** (damage: {_damage_name(damage)})", "",
                     "| run | GA (pop × gens done), wall time | cell cost, regrown weight | "
                     "fitness | similarity after the damage (of 729) | after random cuts: mean (min) | "
                     "original / damaged / regrown (% of original) | in the paper's engine |",
                     "|---|---|---|---|---|---|---|---|")
            reports = {}
            for run in mine + alone:
                reports[run.path] = report = self._self_regrowth_row(run, damage, measured)
            cuts = [k for k in report.similarity if k != damage]
            self.add("")
            self._self_regrowth_comparison(condition, [r for r in mine if r.complete], alone,
                                           reports)
            self.facts.append(f"{condition}: {len(mine)} run{'s' * (len(mine) != 1)} "
                              f"({sum(r.complete for r in mine)} finished), "
                              f"{sum(r.elapsed for r in mine) / 3600:.2g} h of wall time.")
        self.add("Random cuts: " + ", ".join(f"`{k}`" for k in cuts) + ". Distances in "
                 "voxel lengths over 0.5 s from the fitness's start (ours: start 0 of each "
                 "run's own start seed, as its fitness walked) and as the paper's "
                 "code runs its engine (`python benchmarks/transfer.py --voxelyze DIR "
                 f"--grow-regrow ROOT`, kept in ROOT/{ENGINE_FILE}; – where not measured).", "")

    def _nca_and_walk(self, run: ex.RunInfo) -> tuple:
        """(best NCA, physics, duration, start seed) of a run, for `self_regrowth_report`:
        its robots walk as its fitness did."""
        from mjregen.growth.checkpoint import load_nca
        from mjregen.tasks.locomotion import LocomotionTask

        task = LocomotionTask.from_config({**run.config["task"], "task": "locomotion"})
        return load_nca(run.best_files()[0])[0], task.physics, task.duration, task.start_seed

    def _self_regrowth_row(self, run: ex.RunInfo, damage: str, measured: dict):
        """A run's row of the grow-regrow table, its NCA judged after `damage`; returns the
        `SelfRegrowthReport`."""
        from mjregen.experiments.self_regrowth import engine_key, self_regrowth_report

        nca, physics, duration, start_seed = self._nca_and_walk(run)
        report = self_regrowth_report(nca, physics=physics, duration=duration, damage=damage,
                                      start_seed=start_seed)
        task = run.config["task"]
        distance = report.recovery.distance
        cuts = [v for k, v in report.similarity.items() if k != damage]
        weights = (f"{task['cell_cost']:g}, {task.get('regrown_weight', 0.0):g}"
                   if task.get("task") == "grow-regrow" else "growth only")
        under_way = "" if run.complete else f" (under way, of {run.generations_planned})"
        engine = [measured.get(engine_key(self.args.root, run, role, damage))
                  for role in ("original", "damaged", "regrown")]

        def walks(values: list) -> str:
            if values[0] is None:
                return "–"
            shares = [f"{fmt_distance(v, 3)}" + (f" ({100 * v / values[0]:.0f} %)"
                                                  if v is not None and values[0] else "")
                      for v in values[1:]]
            return " / ".join([fmt_distance(values[0], 3), *shares])
        self.add(f"| {run.condition} seed {run.seed} | {run.config['ga']['population']} × "
                 f"{run.generations_done}{under_way}, {run.elapsed / 3600:.2g} h | {weights} | {run.best_fitness:.4g} | "
                 f"{report.similarity[damage]} | {np.mean(cuts):.1f} ({min(cuts)}) | "
                 f"{walks([distance[r] for r in ('original', 'damaged', 'regrown')])} | "
                 f"{walks(engine)} |")
        return report

    def _self_regrowth_comparison(self, condition: str, runs: list[ex.RunInfo],
                                  alone: list[ex.RunInfo], reports: dict) -> None:
        """The finished runs of a grow-regrow `condition` against the growth-only runs of
        its network: the grown robot's and the regrown robot's distance, by exact tests
        (`mjregen.search.compare`)."""
        from mjregen.search.compare import compare_groups

        if not runs or not alone:
            self.add(f"{condition}: no comparison yet; it needs finished runs of it and "
                     "finished growth-only runs of its network.", "")
            return
        for role, what in (("original", "the grown robot's distance (what walking the "
                                        "regrown robot too costs)"),
                           ("regrown", "the regrown robot's distance after the damage "
                                       "(what it gains)")):
            groups = [[reports[r.path].recovery.distance[role] for r in group]
                      for group in (runs, alone)]
            comparison = compare_groups(*groups)
            verdict = ("a difference at the 5 % level" if comparison.p_mann_whitney < 0.05
                       else "no difference this n can show" if comparison.smallest_p >= 0.05
                       else "no difference at the 5 % level")
            sentence = (f"One NCA that grows and regrows ({condition}) against growth-only "
                        f"NCAs of the same evaluations, {what}: "
                        f"{comparison.sentence(('grow-regrow', 'growth-only'))}: {verdict}.")
            self.add(f"- {sentence}")
            self.facts.append(sentence)
        self.add("")

    def quality_diversity(self) -> None:
        """The GA against MAP-Elites on this root's runs: the page `scripts/qd_comparison.py
        --report --docs FIGURES` wrote into this report's figures folder
        (FIGURES/quality_diversity.md), its headings one level down and its figures' links
        made relative to this page."""
        path = self.figures / "quality_diversity.md"
        if not path.is_file():
            root, figures = _rel(Path(self.args.root), ROOT), _rel(self.figures, ROOT)
            self.add("## Quality diversity: GA against MAP-Elites", "",
                     f"Not run on `{root}` (`python scripts/qd_comparison.py --root {root}/qd "
                     "--seeds 0 1 2 --pop 100 --gens 300 --workers 1`, the paper's 30,000 "
                     f"evaluations per run; then the same with `--report --docs {figures}`).",
                     "")
            return
        folder = _rel(self.figures, self.doc_dir)
        body = [line.replace("](quality_diversity/", f"]({folder}/quality_diversity/")
                for line in path.read_text().strip().splitlines()]
        rest = [("#" + line if line.startswith("#") else line) for line in body[1:]]
        self.add("## " + body[0].lstrip("# "), "", *(rest[1:] if rest[:1] == [""] else rest), "")

    def repeated_evolutions(self) -> None:
        """The comparison's GA runs that are this root's 3D feed-forward runs evolved again
        (the same GA, task and seed; `scripts/qd_comparison.py` seeds them as `mjregen
        evolve` does): their best fitness per generation, as far as both have run, must be
        the same (the same seed gives the same evolution, on another day). One fact each."""
        from mjregen.tasks.locomotion import LocomotionTask

        root = Path(self.args.root)
        for again in sorted((root / "qd" / "ga").glob("seed_*")):
            first = root / "3d_ff" / again.name
            if not ((again / "config.json").is_file() and (first / "config.json").is_file()):
                continue
            runs = [ex.read_run(folder) for folder in (first, again)]
            tasks = [LocomotionTask.from_config(run.config["task"]) for run in runs]
            if (runs[0].config["ga"] != runs[1].config["ga"] or runs[0].seed != runs[1].seed
                    or tasks[0] != tasks[1]):
                continue
            n = min(run.generations_done for run in runs)
            if n == 0:
                continue
            same = np.array_equal(runs[0].best[:n], runs[1].best[:n])
            self.facts.append(
                f"qd/ga/{again.name} evolves 3d_ff/{again.name} again (the same GA, task and "
                f"seed, run on another day): the best fitness of its generations 0-{n - 1} is "
                + ("the same as the first run's in every digit metrics.csv keeps."
                   if same else "NOT the same as the first run's: the evolution did not "
                   "repeat."))

    def best_transferring(self, prefix: str) -> tuple[ex.RunInfo, dict] | None:
        """(run, its ``transfer.json`` measurement): of the finished runs of the conditions
        whose names start with `prefix`, the one whose best robot transfers and walks
        farthest in mjregen (the measurement's ``distance``: mean of its fresh starts); None
        when none is measured to transfer."""
        found = [(m["distance"], -r.seed, r.condition, r, m) for name, runs in self.runs.items()
                 if name.startswith(prefix) for r in runs if r.complete
                 for m in [self._measured(r)] if m is not None and m.get("transfers")]
        return max(found, key=lambda f: f[:3])[3:] if found else None

    def _farthest_3d_fact(self, low: float, high: float) -> None:
        """The farthest 3D walker beside the paper's Table 1 walkers (`low`-`high` voxel
        lengths): the farthest that transfers when the runs' robots were measured, else the
        best runs' robots walked again."""
        table = (f"of what the paper's walkers in Table 1 went ({low:g}–{high:g} in its "
                 "engine)")
        found = self.best_transferring("3d_")
        if found is not None:
            run, m = found
            self.facts.append(
                f"Farthest 3D walker whose robot transfers ({run.condition} seed {run.seed}, "
                f"generation {run.best_generation}): {fmt_distance(m['distance'], 4)} voxel "
                f"lengths in 0.5 s from fresh starts, {fmt_distance(m['engine'], 4)} in the "
                f"paper's engine, {100 * m['engine'] / high:.0f}–{100 * m['engine'] / low:.0f} "
                f"% {table}.")
            return
        tops = {n: ex.best_run(_finished_or_all(self.runs[n])[0]) for n in ("3d_ff", "3d_lstm")
                if n in self.runs}
        best3d = [(_rewalked(top), n, _best_distance(top)) for n, top in tops.items()]
        best3d = [b for b in best3d if math.isfinite(b[0])]
        if best3d:
            best = max(best3d)
            self.facts.append(
                f"Farthest 3D walker of the best runs ({best[1]}): {fmt_distance(best[0], 4)} voxel "
                f"lengths in 0.5 s from {REWALK_STARTS} symmetry-broken starts (its run recorded "
                f"{fmt_distance(best[2], 4)} from the start it scored), "
                f"{100 * best[0] / high:.0f}–{100 * best[0] / low:.0f} % {table}; not measured "
                "in the paper's engine.")

    def discussion(self) -> None:
        self.add("## Discussion", "", "Measured facts (written by the script):", "")
        rows = getattr(self, "paper_rows", [])
        if rows:
            self._farthest_3d_fact(min(r["original"] for r in rows),
                                   max(r["original"] for r in rows))
        best2d = [(_best_distance(ex.best_run(self.runs[n])), n) for n in ("2d_ff", "2d_lstm")
                  if n in self.runs]
        best2d = [b for b in best2d if math.isfinite(b[0])]
        if best2d:
            best = max(best2d)
            self.facts.append(f"Farthest 2D walker of the best runs: {fmt_distance(best[0], 4)} voxel "
                              f"lengths in 0.25 s ({best[1]}); the paper gives no 2D distances.")
        missing = [n for n in ex.CONDITIONS if n not in self.runs]
        if missing:
            self.facts.append(f"Not run: {', '.join(missing)}.")
        self.add(*[f"- {fact}" for fact in self.facts] or ["- No runs yet."])
        self.add("", "Caveats that hold for every number here: the runs are fewer than the paper's, "
                 "and those below its scale shorter (settings table), so their curves compare "
                 "early evolution, not converged results; the physics is MuJoCo, not the paper's Voxelyze, so distances "
                 "are comparable only as far as docs/fidelity.md shows; the regrowth walkers are "
                 "our own evolved robots, not the paper's Biped, Tripod and Multiped.", "")
        extra = self.doc_dir / f"{self.args.out.stem}_discussion.md"
        if extra.is_file():
            self.add(f"### Interpretation (from {extra.name})", "", extra.read_text().strip(), "")
        else:
            self.add(f"(Interpretation: write it in `{_rel(extra, ROOT)}`; this script includes "
                     "that file here verbatim.)", "")

    def write(self) -> Path:
        from mjregen.fileio import atomic_open

        with atomic_open(self.args.out, "w") as handle:
            handle.write("\n".join(self.lines).rstrip() + "\n")
        return self.args.out


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description="Write docs/results.md and docs/results/*.png "
                                     "from the results runs and the shipped assets.")
    parser.add_argument("--root", type=Path, default=RECORDS,
                        help=f"results folder (default {_rel(RECORDS, ROOT)}, the records of "
                             f"docs/results.md; scripts/paper_experiments.py runs into "
                             f"{ex.DEFAULT_ROOT})")
    parser.add_argument("--assets", type=Path, default=ROOT / "assets", help="assets folder")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "results.md",
                        help="the Markdown file (default docs/results.md)")
    parser.add_argument("--figures", type=Path,
                        help="PNG folder (default: beside --out, named as it without .md)")
    parser.add_argument("--paper", type=Path, help="the paper's LaTeX (default: the .txt in $MJREGEN_PAPER or ./paper)")
    parser.add_argument("--title", default="Results: evolution and regeneration",
                        help="the page's title")
    parser.add_argument("--no-render", action="store_true", help="skip the rendered gallery")
    parser.add_argument("--table1", action="store_true",
                        help="write only the paper's robots regrown beside its Table 1")
    parser.add_argument("--regrowth-runs", nargs="*", default=[], metavar="RUN",
                        help="with --table1: regrowth run folders whose curves to plot")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    args.figures = args.figures or args.out.parent / args.out.stem
    try:
        if not (args.no_render or args.table1):
            from mjregen.render import select_gl_backend

            select_gl_backend()  # sets MUJOCO_GL before anything imports mujoco
        report = Report(args)
        if args.table1:
            report.table1_header()
            report.paper_robot_regrowth()
            report.regrowth_curves()
            print(f"wrote {report.write()}")
            return 0
        report.header()
        report.reproduce()
        report.settings()
        report.curves()
        robots = report.shipped()
        robots += report.walkers()
        report.gallery(robots + report.best_of_conditions())
        report.best_walker_video()
        report.regeneration()
        report.self_regrowth()
        report.quality_diversity()
        report.repeated_evolutions()
        report.discussion()
        path = report.write()
    except (MjregenError, OSError, ValueError) as error:
        print(f"results_report: error: {error}", file=sys.stderr)
        return 1
    print(f"wrote {path} and {args.figures}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
