"""Error against run time, chaos against discretisation, and the stability of the time step.

``report`` runs the studies below (with the paper engine's line when ``--voxelyze DIR``
names its folder) and writes ``docs/accuracy.md`` with its CSVs and figure; the studies
also run alone, writing their CSV and printing a table:

``accuracy``: for each robot (a 2D sheet, a soft 5×5×5 block, a mixed 7×7×7 block, the
  paper's tripod, biped and multiped), each integrator variant and a sweep of time steps
  (multiples of each robot's stability limit, ``timestep_safety``), run the same evaluation
  as `mjregen.physics.simulate` — settle 0.05 s, then 0.1 s of actuation (4 cycles) — and
  compare the final centre of mass (voxel lengths) and the fitness with a reference run:
  Euler at 1/16 of the smallest step of the sweep. ``--full-window`` adds the paper's
  0.05 + 0.5 s for the tripod. Every step divides the settle time exactly, so all runs
  start actuating at the same instant. Variants: ``euler`` (what `simulate` runs), ``rk4``
  (MuJoCo's, on the pure-MuJoCo twin of the physics), the same with the muscle rest
  lengths sampled at the step's midpoint (``-mid``) instead of its start, and
  ``implicit``/``implicitfast`` (checked for convergence only). Writes
  ``accuracy_table.csv``, ``accuracy_orders.csv`` and ``accuracy_work_precision.png``.

``chaos``: for each paper robot over the paper's window, the spread of the distance over 20
  runs from initial positions shifted by 1e-9 voxel lengths, over 8 time-step safeties, and
  the default's difference from a run at an 8th of its step; for each shipped evolved 3D
  walker, the distances from the same shifted starts and safeties. Writes
  ``accuracy_chaos.csv`` and ``accuracy_walkers.csv``.

``skips``: the CPU time of the work the voxel plugin leaves out where a robot does not need
  it (the muscle drive, the collision stage, a hard voxel's step), against the same robot
  made to do it, and how far the motion differs. Writes ``accuracy_skips.csv``.

``stability``: for each case (stiffness ×1…×1000 of the hard material, muscle strain up to
  ±50 %, bond damping ratio 0.05…2, full 7×7×7 blocks of each material, a single voxel, a
  one-voxel tower, a clamped cantilever, a drop from 5 voxel lengths, all-muscle blocks in
  phase, blocks kicked with random 1 mm/s velocities), whether the automatic time step
  (``Scene.timestep_safety`` default) is stable, and the largest stable
  ``timestep_safety`` found by bracketing and geometric bisection; with ``--rule zeta`` the
  candidate rule safety × min(1, 1/ζ) is checked as well. Writes
  ``accuracy_stability.csv``.

A run is stable when `Simulation`'s guard passes (no NaN, no MuJoCo warning, no voxel faster
than 5 m/s) and at the end no voxel moves faster than ``END_SPEED`` (a slowly growing
instability that has not run away yet).

    python benchmarks/accuracy.py report --jobs 2 [--voxelyze DIR]
    python benchmarks/accuracy.py accuracy --jobs 2 [--full-window] [--quick]
    python benchmarks/accuracy.py chaos --jobs 2
    python benchmarks/accuracy.py skips
    python benchmarks/accuracy.py stability --jobs 2 [--rule zeta] [--quick]
        [--timestep-rule network]
    python benchmarks/accuracy.py plot     # redraw the PNG from the CSV

CPU time is the process CPU time of the stepping (compile excluded), one process per run;
the paper engine's, its process's CPU time.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import multiprocessing
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mjregen import physics as physics_module
from mjregen.grid import Material, Robot
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.tasks.fitness import VOXEL_COST
from mjregen.tasks.starts import KEPT
from mjregen.validation.integration import (
    END_SPEED,
    SETTLE,
    WALK,
    Run,
    evaluate,
)

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
SAFETIES = (2.0, 1.5, 1.0, 0.75, 0.5, 0.25)  # accuracy sweep, × the paper rule dt_p
FULL_SAFETIES = (1.0, 0.75, 0.5)  # the tripod over the paper's full 0.55 s window
REFERENCE_DIVISOR = 16  # reference dt = smallest dt of the sweep / 16


# ---------------------------------------------------------------------------- evaluation

def paper_rule_dt(robot: Robot, physics: Physics) -> float:
    """s: the paper engine's time step (timestep_safety 1) for `robot`."""
    return compile_robot(robot, physics=physics.replace(timestep_safety=1.0)).timestep


def dividing_dt(target: float, unit: float = SETTLE) -> float:
    """The largest dt <= `target` that divides `unit` (s) an integer number of times."""
    return unit / math.ceil(unit / target - 1e-9)


def preset(name: str) -> Physics:
    """"default" = `Physics()`; otherwise `mjregen.physics.<name>_physics()` (e.g. paper)."""
    return Physics() if name == "default" else getattr(physics_module, f"{name}_physics")()


BASE = {"physics": Physics()}  # the preset every study starts from (set by main)


# ---------------------------------------------------------------------------- robots

def sheet_2d() -> Robot:
    """5×5 2D sheet of mixed materials (the speed benchmark's), seed 0."""
    rng = np.random.default_rng(0)
    return Robot.from_body(rng.choice([1, 2, 3, 4], size=(5, 5)).astype(np.int8))


def mixed_block(n: int = 7, seed: int = 0) -> Robot:
    """n×n×n block of soft and ± muscle voxels (the speed benchmark's 7×7×7), seeded."""
    rng = np.random.default_rng(seed)
    return Robot.from_body(rng.choice([1, 3, 4], size=(n, n, n)).astype(np.int8))


def paper_robot(name: str) -> Robot:
    return Robot.load(ROOT / "assets" / "robots" / "paper" / f"{name}.npy")


def accuracy_robots() -> dict[str, Robot]:
    return {"sheet_2d": sheet_2d(), "soft_block_5x5x5": Robot.box((5,) * 3, Material.SOFT),
            "block_7x7x7": mixed_block(), "tripod": paper_robot("tripod"),
            "biped": paper_robot("biped"), "multiped": paper_robot("multiped")}


# the paper engine's step fractions (of its own stability rule; the paper's 0.9) for its
# work-precision line, and its reference's
PAPER_DT_FRACTION = 0.9
ENGINE_FRACTIONS = (1.0, 0.9, 0.675, 0.45, 0.225)
ENGINE_REFERENCE_FRACTION = 0.9 * 0.25 / REFERENCE_DIVISOR


def _engine_job(item: tuple) -> tuple:
    from mjregen.validation.engine import PaperEngine

    folder, name, grid, fraction = item
    out = PaperEngine(folder).run_window(grid, dt_fraction=fraction, stop=SETTLE + WALK,
                                         measure_from=SETTLE)
    return name, fraction, out


def engine_rows(folder: Path, robots: dict[str, Robot], n_jobs: int) -> list[dict]:
    """Accuracy rows of the paper engine on each 3D robot of `robots`: its distance over
    the short window at each of ENGINE_FRACTIONS against its own run at
    ENGINE_REFERENCE_FRACTION (the engine reports only the distance, so only the fitness
    error is filled)."""
    items = [(folder, name, robot.grid, fraction) for name, robot in robots.items()
             if robot.dim == 3 for fraction in (*ENGINE_FRACTIONS, ENGINE_REFERENCE_FRACTION)]
    with multiprocessing.get_context("fork").Pool(n_jobs) as pool:
        done = pool.map(_engine_job, items)
    runs = {(name, fraction): out for name, fraction, out in done}
    rows = []
    for name in dict.fromkeys(n for n, _ in runs):
        ref = runs[(name, ENGINE_REFERENCE_FRACTION)]
        for fraction in ENGINE_FRACTIONS:
            out = runs[(name, fraction)]
            stable = math.isfinite(out["distance"]) and abs(out["distance"]) < 1e3
            error = abs(out["distance"] - ref["distance"])
            rows.append({"robot": name, "window": "short", "integrator": "paper engine",
                         "safety": fraction, "dt": "", "steps": "", "stable": stable,
                         "cpu_s": round(out["cpu_s"], 4), "com_error_L": "",
                         "fitness": round(out["distance"], 6),
                         "fitness_error": f"{error:.4g}" if stable else "",
                         "fitness_error_pct": f"{100 * error / max(abs(ref['distance']), 1e-9):.4g}"
                         if stable else "",
                         "ref_dt": ENGINE_REFERENCE_FRACTION, "ref_cpu_s": round(ref["cpu_s"], 3)})
    return rows


# ---------------------------------------------------------------------------- accuracy

ACCURACY_FIELDS = ["robot", "window", "integrator", "safety", "dt", "steps", "stable", "cpu_s",
                   "com_error_L", "fitness", "fitness_error", "fitness_error_pct", "ref_dt",
                   "ref_cpu_s"]


def accuracy_jobs(*, variants: tuple[str, ...], full_window: bool, quick: bool) -> list[tuple]:
    """(key, Run) pairs: the sweep and the references."""
    jobs = []
    robots = accuracy_robots()
    if quick:
        robots = {"sheet_2d": robots["sheet_2d"]}
    windows = [("short", SETTLE, WALK)]
    for name, robot in robots.items():
        physics = BASE["physics"]
        dt_p = paper_rule_dt(robot, physics)
        wins = windows + ([("full", SETTLE, 0.5)] if full_window and name == "tripod" else [])
        for window, settle, measured in wins:
            safeties = SAFETIES if window == "short" else FULL_SAFETIES
            dts = {s: dividing_dt(s * dt_p) for s in safeties}
            ref_dt = dividing_dt(min(dts.values()) / REFERENCE_DIVISOR)
            base = Run(robot=robot, physics=physics, settle=settle, measured=measured)
            jobs.append(((name, window, "reference", 0.0), replace(base, dt=ref_dt,
                                                                  integrator="euler")))
            for variant in variants:
                if window == "full" and variant not in ("euler", "rk4"):
                    continue
                if variant.startswith("implicit") and robot.n_voxels > 100:
                    continue  # convergence check only, on the two small robots
                for s, dt in dts.items():
                    jobs.append(((name, window, variant, s), replace(base, dt=dt,
                                                                     integrator=variant)))
    return jobs


def _evaluate_job(job: tuple) -> tuple:
    key, run = job
    return key, evaluate(run)


def run_jobs(jobs: list[tuple], n_jobs: int, cost=None, log: Path | None = None) -> dict:
    """Evaluate (key, Run) jobs in `n_jobs` processes, most expensive first.

    Each result is also appended to `log` (JSON lines) as it arrives, so that an interrupted
    sweep keeps what it finished (`load_log`).
    """
    if cost is not None:
        jobs = sorted(jobs, key=cost, reverse=True)
    results = {}

    def keep(key: tuple, out: dict) -> None:
        results[key] = out
        print(key, _brief(out), flush=True)
        if log is not None:
            with open(log, "a") as handle:
                handle.write(json.dumps({"key": list(key), **{
                    k: (v.tolist() if isinstance(v, np.ndarray) else v)
                    for k, v in out.items()}}) + "\n")

    if n_jobs <= 1:
        for job in jobs:
            keep(*_evaluate_job(job))
        return results
    with multiprocessing.get_context("fork").Pool(n_jobs) as pool:
        for key, out in pool.imap_unordered(_evaluate_job, jobs):
            keep(key, out)
    return results


def load_log(path: Path) -> dict:
    """Results of `run_jobs` read back from its JSON-lines log (later lines win)."""
    results = {}
    for line in Path(path).read_text().splitlines():
        item = json.loads(line)
        key = tuple(item.pop("key"))
        item["com_end"] = np.array(item["com_end"])
        results[key] = item
    return results


def _brief(out: dict) -> str:
    return (f"stable={out['stable']} dt={out['dt']:.3g} steps={out['steps']} "
            f"cpu={out['cpu']:.2f}s fitness={out['fitness']:.4f} {out['reason']}")


def _run_cost(job: tuple) -> float:
    key, run = job
    steps = (run.settle + run.measured) / (run.dt or 1e-5)
    factor = 4.0 if (run.integrator or "").startswith("rk4") else 1.0
    return steps * factor * run.robot.n_voxels


def accuracy_rows(results: dict) -> list[dict]:
    """Table rows: each sweep run against its reference."""
    rows = []
    for (name, window, variant, s), out in sorted(results.items(), key=lambda kv: (
            kv[0][0], kv[0][1], kv[0][2], -kv[0][3])):
        if variant == "reference":
            continue
        ref = results.get((name, window, "reference", 0.0))
        if ref is None:
            continue  # an interrupted sweep: no reference, no errors
        L = 1e-3
        row = {"robot": name, "window": window, "integrator": variant, "safety": s,
               "dt": out["dt"], "steps": out["steps"], "stable": out["stable"],
               "cpu_s": round(out["cpu"], 4), "ref_dt": ref["dt"],
               "ref_cpu_s": round(ref["cpu"], 3), "fitness": round(out["fitness"], 6)}
        if out["stable"]:
            error = float(np.linalg.norm(out["com_end"] - ref["com_end"])) / L
            ferr = abs(out["fitness"] - ref["fitness"])
            row.update(com_error_L=f"{error:.4g}", fitness_error=f"{ferr:.4g}",
                       fitness_error_pct=f"{100 * ferr / max(abs(ref['distance']), 1e-9):.4g}")
        else:
            row.update(com_error_L="", fitness_error="", fitness_error_pct="")
        rows.append(row)
    return rows


def twins_against_themselves(rows: list[dict]) -> list[dict]:
    """The rows of the variants that run the pure-MuJoCo twin (all but "euler" and the
    paper engine) measured against the twin's own run at its smallest stable step: the
    reference run is the voxel pipeline's, a different model, so against it they would show
    the models' difference, not their integration error. Their COM error is left blank
    (the rows keep only the fitness); the smallest step's own error is 0. Applying it again
    changes nothing."""
    out, finest = [], {}
    robots = accuracy_robots()

    def distance(row: dict) -> float:  # the fitness without its voxel cost (3D)
        robot = robots[row["robot"]]
        return float(row["fitness"]) + (VOXEL_COST * robot.n_voxels if robot.dim == 3 else 0.0)

    for row in rows:
        if row["integrator"] in ("euler", "paper engine"):
            continue
        key = (row["robot"], row["window"], row["integrator"])
        if str(row["stable"]) == "True" and (key not in finest or float(row["safety"])
                                             < float(finest[key]["safety"])):
            finest[key] = row
    for row in rows:
        key = (row["robot"], row["window"], row["integrator"])
        if key not in finest:
            out.append(row)
            continue
        ref = finest[key]
        row = dict(row, com_error_L="", ref_dt=ref["dt"], ref_cpu_s=ref["cpu_s"])
        if str(row["stable"]) == "True":
            error = abs(float(row["fitness"]) - float(ref["fitness"]))
            row.update(fitness_error=f"{error:.4g}",
                       fitness_error_pct=f"{100 * error / max(abs(distance(ref)), 1e-9):.4g}")
        out.append(row)
    return out


def convergence_orders(rows: list[dict]) -> list[dict]:
    """Least-squares slope of log(error) against log(step) per robot, window, integrator
    (the step as its multiple of the stability rule: the safety, the engine's fraction)."""
    out = []
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        if row["com_error_L"] != "" or row["fitness_error"] not in ("", None):
            groups.setdefault((row["robot"], row["window"], row["integrator"]), []).append(row)
    for (robot, window, variant), group in sorted(groups.items()):
        dts = np.log([float(r["safety"]) for r in group])  # ∝ the step, for each code
        entry = {"robot": robot, "window": window, "integrator": variant, "points": len(group)}
        for column, label in (("com_error_L", "com_order"), ("fitness_error", "fitness_order")):
            errors = np.array([float(r[column]) if r[column] not in ("", None) else 0.0
                               for r in group])
            ok = errors > 0
            entry[label] = (f"{np.polyfit(dts[ok], np.log(errors[ok]), 1)[0]:.2f}"
                            if ok.sum() >= 2 else "")
        out.append(entry)
    return out


def write_csv(path: Path, rows: list[dict], fields: list[str] | None = None) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fields = fields or list(rows[0])
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def markdown(rows: list[dict], fields: list[str]) -> str:
    lines = ["| " + " | ".join(fields) + " |", "|" + "---|" * len(fields)]
    lines += ["| " + " | ".join(str(r.get(f, "")) for f in fields) + " |" for r in rows]
    return "\n".join(lines)


def plot_work_precision(rows: list[dict], path: Path) -> None:
    """Error (COM and fitness) against CPU time, log–log, one line per integrator."""
    import matplotlib
    import matplotlib.ticker
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    robots = list(dict.fromkeys(r["robot"] for r in rows if r["window"] == "short"))
    fig, axes = plt.subplots(2, len(robots), figsize=(3.2 * len(robots), 5.6), squeeze=False)
    styles = {"paper engine": ("k", "D", "-"), "euler": ("C0", "o", "-"), "rk4": ("C1", "s", "-"),
              "euler-mid": ("C0", "o", "--"), "rk4-mid": ("C1", "s", "--"),
              "implicit": ("C2", "^", ":"), "implicitfast": ("C3", "v", ":")}
    for col, robot in enumerate(robots):
        for row_i, (column, label) in enumerate((("com_error_L", "final COM error (L)"),
                                                 ("fitness_error", "fitness error (L)"))):
            ax = axes[row_i][col]
            for variant, (colour, marker, line) in styles.items():
                pts = [r for r in rows if r["robot"] == robot and r["window"] == "short"
                       and r["integrator"] == variant and r[column] not in ("", None)]
                if not pts:
                    continue
                pts.sort(key=lambda r: float(r["cpu_s"]))
                ax.loglog([float(r["cpu_s"]) for r in pts], [float(r[column]) for r in pts],
                          color=colour, marker=marker, linestyle=line, markersize=4,
                          label=variant)
                default_safety = PAPER_DT_FRACTION if variant == "paper engine" else 0.75
                default = [r for r in pts if float(r["safety"]) == default_safety]
                if default:
                    ax.plot(float(default[0]["cpu_s"]), float(default[0][column]), "k*",
                            markersize=9, zorder=5)
            ax.set_title(robot if row_i == 0 else "", fontsize=9)
            ax.set_xlabel("CPU s per evaluation" if row_i == 1 else "", fontsize=8)
            if col == 0:
                ax.set_ylabel(label, fontsize=8)
            ax.tick_params(labelsize=7)
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.grid(True, which="major", alpha=0.3)
    axes[1][0].legend(fontsize=7)
    fig.suptitle("Work–precision: settle 0.05 s + 0.1 s walking; ★ = default step (safety "
                 "0.75; the engine's DtFrac 0.9), reference: the same code at a 16th of "
                 "its smallest step", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def read_csv(path: Path) -> list[dict]:
    with open(path) as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        for key in ("dt", "safety", "cpu_s", "ref_dt", "ref_cpu_s"):
            if key in row and row[key] != "":
                row[key] = float(row[key])
    return rows


# ---------------------------------------------------------------------------- stability

def scaled_hard(factor: float) -> dict:
    """Paper materials with the hard modulus × `factor`."""
    materials = dict(BASE["physics"].materials)
    hard = materials[Material.HARD]
    materials[Material.HARD] = replace(hard, youngs_modulus=hard.youngs_modulus * factor)
    return materials


def muscle_strain(amplitude: float) -> dict:
    materials = dict(BASE["physics"].materials)
    for code in (Material.MUSCLE_PLUS, Material.MUSCLE_MINUS):
        materials[code] = replace(materials[code], strain_amplitude=amplitude)
    return materials


@dataclass(frozen=True)
class Case:
    name: str
    run: Run  # with dt None: the automatic step at the physics' timestep_safety

    def at(self, safety: float) -> Run:
        return replace(self.run, physics=self.run.physics.replace(timestep_safety=safety))


def _shape_cases(tripod: Robot, zeta_robot: Robot, paper: Physics, short: dict) -> list[Case]:
    """The stability study's cases of extreme shapes, starts and motions (`short` window)."""
    shapes = []
    for code in (Material.SOFT, Material.HARD):
        shapes.append(Case(f"single voxel {code.name.lower()}",
                          Run(Robot.box((1, 1, 1), code), paper, **short)))
    shapes.append(Case("tower 1x1x7 hard", Run(Robot.box((1, 1, 7), 2),
                                              paper, **short)))
    shapes.append(Case("tower 1x1x7 muscle+ 50%", Run(
        Robot.box((1, 1, 7), 3),
        Physics(materials=muscle_strain(0.5), scene=replace(paper.scene, waveform="symmetric"),
                pipeline=paper.pipeline),
        **short)))
    shapes.append(Case("cantilever 10 hard clamped", Run(
        Robot.box((10, 1, 1), 2), paper, elevation=5e-3,
        clamped=((1, 1, 1),), **short)))
    shapes.append(Case("cantilever 10 soft clamped", Run(
        Robot.box((10, 1, 1), 1), paper, elevation=5e-3,
        clamped=((1, 1, 1),), **short)))
    shapes.append(Case("tripod dropped 5 L", Run(tripod, paper, elevation=5e-3, **short)))
    shapes.append(Case("hard block 4^3 dropped 5 L", Run(Robot.box((4,) * 3, 2), paper, elevation=5e-3,
                                                        **short)))
    shapes.append(Case("muscle+ block 4^3 50% symmetric", Run(
        Robot.box((4,) * 3, 3), Physics(materials=muscle_strain(0.5),
                             scene=replace(paper.scene, waveform="symmetric"),
                             pipeline=paper.pipeline), **short)))
    # resting blocks are symmetric and stay unexcited; kicked ones show the network's limit
    for code in (Material.SOFT, Material.HARD):
        shapes.append(Case(f"block 4^3 {code.name.lower()} kicked 1 mm/s", Run(
            Robot.box((4,) * 3, code), paper, kick=1e-3, **short)))
    shapes.append(Case("mixed block 5^3 kicked 1 mm/s", Run(zeta_robot, paper, kick=1e-3,
                                                          **short)))
    shapes.append(Case("biped", Run(paper_robot("biped"), paper, **short)))
    shapes.append(Case("2D sheet", Run(sheet_2d(), paper, settle=0.2, measured=0.1)))
    return shapes


def stability_cases(quick: bool = False) -> list[Case]:
    """The stiff and extreme cases of the stability study."""
    tripod = paper_robot("tripod")
    paper = BASE["physics"]
    zeta_robot = mixed_block(5, seed=1)
    short = dict(settle=0.05, measured=0.1)
    stiff = dict(settle=0.02, measured=0.03)  # many steps at ×1000: keep the window short
    cases = []
    for factor in (1, 10, 100, 1000):
        cases.append(Case(f"tripod hard E x{factor}",
                          Run(tripod, Physics(materials=scaled_hard(factor), scene=paper.scene,
                                              pipeline=paper.pipeline), **stiff)))
    cases.append(Case("hard block 4^3 E x1000",
                      Run(Robot.box((4,) * 3, 2), Physics(materials=scaled_hard(1000), scene=paper.scene,
                                               pipeline=paper.pipeline), **stiff)))
    for amplitude, waveform in ((0.14, "contract"), (0.3, "contract"), (0.5, "contract"),
                                (0.5, "symmetric")):
        cases.append(Case(f"tripod strain {amplitude:g} {waveform}",
                          Run(tripod, Physics(materials=muscle_strain(amplitude),
                                              scene=replace(paper.scene, waveform=waveform),
                                              pipeline=paper.pipeline),
                              **short)))
    for zeta in (0.05, 0.1, 0.25, 0.5, 1.0, 1.5, 2.0):
        cases.append(Case(f"mixed block 5^3 zeta {zeta:g}",
                          Run(zeta_robot, paper.replace(bond_damping_ratio=zeta),
                              **short)))
        cases.append(Case(f"tripod zeta {zeta:g}",
                          Run(tripod, paper.replace(bond_damping_ratio=zeta), **short)))
    for code in Material:
        if code != Material.EMPTY:
            cases.append(Case(f"block 7^3 {code.name.lower()}", Run(Robot.box((7,) * 3, code), paper,
                                                                    **short)))
    cases += _shape_cases(tripod, zeta_robot, paper, short)
    if quick:
        cases = [c for c in cases if c.run.robot.n_voxels <= 16]
    return cases


def zeta_rule(case: Case, safety: float) -> float:
    """Candidate rule: the automatic step × min(1, 1/ζ)."""
    return safety * min(1.0, 1.0 / case.run.physics.scene.bond_damping_ratio)


def stability_search(case: Case, *, low: float = 0.05, high: float = 16.0,
                     iterations: int = 4, rule: str = "") -> dict:
    """Largest stable timestep_safety of `case` (geometric bracketing + bisection).

    Starts at the default safety; doubles while stable (up to `high`) or halves while
    unstable (down to `low`), then bisects the bracket geometrically `iterations` times
    (a ratio of 2**(1/16) ≈ 4 %).
    """
    t0 = time.process_time()
    default = case.run.physics.scene.timestep_safety
    memo: dict[float, dict] = {}

    def stable(s: float) -> bool:
        if s not in memo:
            memo[s] = evaluate(case.at(s))
        return memo[s]["stable"]

    default_ok = stable(default)
    s = default
    if default_ok:
        while s * 2 <= high and stable(s * 2):
            s *= 2
        lo, hi = s, s * 2
    else:
        while s / 2 >= low and not stable(s / 2):
            s /= 2
        lo, hi = s / 2, s
    if lo >= low and hi <= high:
        for _ in range(iterations):
            mid = math.sqrt(lo * hi)
            lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    first = memo[default]
    row = {"case": case.name, "voxels": case.run.robot.n_voxels,
           "zeta": case.run.physics.scene.bond_damping_ratio,
           "default_safety": default, "default_dt": f"{first['dt']:.3g}",
           "default_stable": default_ok, "default_reason": first["reason"],
           "max_stable_safety": f"{lo:.3g}" if lo >= low else f"<{low}",
           "first_unstable_safety": f"{hi:.3g}" if hi <= high else f">{high}",
           "margin": f"{lo / default:.2f}", "runs": len(memo),
           "cpu_s": round(time.process_time() - t0, 1)}
    if rule == "zeta":
        s_rule = zeta_rule(case, default)
        out = memo.get(s_rule) or evaluate(case.at(s_rule))
        row.update(rule_safety=f"{s_rule:.3g}", rule_stable=out["stable"],
                   rule_margin=f"{lo / s_rule:.2f}")
    return row


def _stability_job(args: tuple) -> dict:
    case, rule = args
    return stability_search(case, rule=rule)


STABILITY_FIELDS = ["case", "voxels", "zeta", "default_safety", "default_dt", "default_stable",
                    "max_stable_safety", "first_unstable_safety", "margin", "rule_safety",
                    "rule_stable", "rule_margin", "runs", "cpu_s", "default_reason"]


# ---------------------------------------------------------------------------- chaos

PERTURBATIONS = (1e-9, 1e-6, 1e-4)  # voxel lengths: standard deviations of initial shifts
PERTURBED_RUNS = 20  # per size and robot
CHAOS_SAFETIES = (0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85)
HALVINGS = 5  # the step ladder: the default step halved 1 … HALVINGS times
ENGINE_STEP = 2.0257e-5  # s, the paper engine's step with hard voxels
# friction stop rules on the ladder: the engine's (the default), the energy rule, and the
# engine's with its step fixed (a stop threshold that does not depend on the step)
LADDERS = {"momentum": {"friction_stop": "momentum"}, "energy": {"friction_stop": "energy"},
           "fixed": {"friction_stop": "momentum", "friction_stop_time": ENGINE_STEP}}
LIMIT_LADDERS = ("momentum", "energy")  # the ladders whose short steps estimate the limit
CONVERGED_FROM = 3  # the ladder's steps from this halving on estimate the limit
CHAOS_FIELDS = ["robot", "default", *(f"shift_{p:g}_std" for p in PERTURBATIONS),
                "safeties_median", "safeties_min", "safeties_max",
                *(f"ladder_{r}" for r in LADDERS), "converged", "converged_spread",
                "default_error"]


def start_and_step_jobs(name: str, robot: Robot) -> list[tuple]:
    """(key, Run) of the paper's window (0.05 + 0.5 s) for `robot`: the default;
    PERTURBED_RUNS runs from initial positions shifted by each of PERTURBATIONS; one run
    per CHAOS_SAFETIES."""
    physics = BASE["physics"]
    base = Run(robot=robot, physics=physics, settle=SETTLE, measured=0.5)
    jobs = [((name, "default", 0), base)]
    jobs += [((name, f"shift {size:g}", k), replace(base, perturb=size, seed=k))
             for size in PERTURBATIONS for k in range(1, PERTURBED_RUNS + 1)]
    jobs += [((name, "safety", s), replace(base, physics=physics.replace(
        timestep_safety=s))) for s in CHAOS_SAFETIES]
    return jobs


def chaos_jobs() -> list[tuple]:
    """(key, Run) for each paper robot: `start_and_step_jobs`, and the step ladder, the
    default step halved 0 … HALVINGS times, with each friction stop rule of LADDERS (the
    default's rung 0 is the default run)."""
    jobs = []
    for name in ("tripod", "biped", "multiped"):
        robot = paper_robot(name)
        physics = BASE["physics"]
        base = Run(robot=robot, physics=physics, settle=SETTLE, measured=0.5)
        safety = physics.scene.timestep_safety
        jobs += start_and_step_jobs(name, robot)
        for rule, changes in LADDERS.items():
            start = 1 if physics.replace(**changes) == physics else 0
            for k in range(start, HALVINGS + 1):
                jobs.append(((name, f"ladder {rule}", k), replace(base, physics=physics.replace(
                    timestep_safety=safety / 2 ** k, **changes))))
    return jobs


def stable_distances(results: dict, name: str, kind: str) -> dict:
    """{run number: distance} of `name`'s stable runs of `kind` ("default", "shift 1e-09",
    "safety", "ladder momentum", ...) in `results`."""
    return {key[2]: out["distance"] for key, out in results.items()
            if key[0] == name and key[1] == kind and out["stable"]}


def chaos_rows(results: dict) -> list[dict]:
    """Per robot (voxel lengths): the default distance; the standard deviation of the
    distance over the starts shifted by each size; the spread over the time-step safeties;
    the step ladder of each friction rule; the limit they converge to (mean of the
    LIMIT_LADDERS' steps from CONVERGED_FROM halvings on) and their spread; the default's
    difference from that limit."""
    rows = []
    physics = BASE["physics"]
    for name in dict.fromkeys(key[0] for key in results):
        def runs(kind: str) -> dict:
            return stable_distances(results, name, kind)
        default = results[(name, "default", 0)]["distance"]
        steps = np.array(list(runs("safety").values()))
        row = {"robot": name, "default": round(default, 4)}
        for size in PERTURBATIONS:
            shifted = np.array(list(runs(f"shift {size:g}").values()))
            row[f"shift_{size:g}_std"] = f"{shifted.std(ddof=1):.2g}"
        row.update(safeties_median=round(float(np.median(steps)), 3),
                   safeties_min=round(float(steps.min()), 3),
                   safeties_max=round(float(steps.max()), 3))
        tail = []
        for rule, changes in LADDERS.items():
            ladder = runs(f"ladder {rule}")
            if physics.replace(**changes) == physics:
                ladder[0] = default
            row[f"ladder_{rule}"] = " ".join(f"{ladder[k]:.3f}" for k in sorted(ladder))
            if rule in LIMIT_LADDERS:
                tail += [ladder[k] for k in sorted(ladder) if k >= CONVERGED_FROM]
        converged = float(np.mean(tail))
        row.update(converged=round(converged, 3),
                   converged_spread=round(float(np.ptp(tail)), 3),
                   default_error=round(abs(default - converged), 3))
        rows.append(row)
    return rows


# the shipped evolved 3D walkers (the GA's own robots, where the start may matter more than
# for the paper's): the default walkers of each network and the regrowth experiment's others,
# and the best robot of 3d_ff seed 1 (a mirror-symmetric plate, kept in records/)
EVOLVED_WALKERS = {
    "walker_3d_ff": ROOT / "assets" / "nca" / "walker_3d_ff.npy",
    "3d_ff_seed_1": ROOT / "records" / "results" / "3d_ff" / "seed_1" / "best" / "gen_0269.npy",
    "walker_3d_lstm": ROOT / "assets" / "nca" / "walker_3d_lstm.npy",  # = walkers/walker_1
    "mirror_walker_3d": ROOT / "assets" / "robots" / "mirror_walker_3d.npy",  # once walker_2
    "walker_3": ROOT / "assets" / "robots" / "walkers" / "walker_3.npy",
}
WALKER_FIELDS = ["robot", "voxels", "mirror", "default",
                 *(f"shift_{p:g}_{stat}" for p in PERTURBATIONS for stat in ("mean", "min", "max")),
                 "safeties_median", "safeties_min", "safeties_max"]


def walker_rows(results: dict, robots: dict[str, Robot]) -> list[dict]:
    """Per walker of `robots` (voxel lengths): the default distance, the mean and range of
    the distances from the starts shifted by each size, the range over the safeties."""
    rows = []
    for name, robot in robots.items():
        def runs(kind: str) -> np.ndarray:
            return np.array(list(stable_distances(results, name, kind).values()))
        row = {"robot": name, "voxels": robot.n_voxels,
               "mirror": ", ".join(robot.mirror_axes()) or "none",
               "default": round(results[(name, "default", 0)]["distance"], 4)}
        for size in PERTURBATIONS:
            shifted = runs(f"shift {size:g}")
            row.update({f"shift_{size:g}_mean": round(float(shifted.mean()), 3),
                        f"shift_{size:g}_min": round(float(shifted.min()), 3),
                        f"shift_{size:g}_max": round(float(shifted.max()), 3)})
        steps = runs("safety")
        row.update(safeties_median=round(float(np.median(steps)), 3),
                   safeties_min=round(float(steps.min()), 3),
                   safeties_max=round(float(steps.max()), 3))
        rows.append(row)
    return rows


def chaos_studies(n_jobs: int) -> tuple[list[dict], list[dict]]:
    """The paper robots' chaos rows and the evolved walkers' rows, from one pool of runs."""
    walkers = {name: Robot.load(path) for name, path in EVOLVED_WALKERS.items()}
    jobs = chaos_jobs() + [job for name, robot in walkers.items()
                           for job in start_and_step_jobs(name, robot)]
    results = run_jobs(jobs, n_jobs, cost=_run_cost)
    paper = {key: out for key, out in results.items() if key[0] not in walkers}
    return chaos_rows(paper), walker_rows(results, walkers)


# ---------------------------------------------------------------------------- skips

SKIP_ROUNDS = 5
SKIP_FIELDS = ["skip", "robot", "with_cpu_s", "without_cpu_s", "saved", "max_qpos_difference"]


def _timed_run(robot: Robot, physics: Physics, settle_only: bool = False
               ) -> tuple[float, np.ndarray]:
    """(CPU s of the stepping, final qpos) of `evaluate` over the paper window (or its
    settle only)."""
    settle, measured = physics.scene.timing(robot.dim)
    out = evaluate(Run(robot, physics, settle=settle, measured=0.0 if settle_only else measured))
    if not out["stable"]:
        raise RuntimeError(f"unstable skip run: {out['reason']}")
    return out["cpu"], out["qpos"]


def skip_cases() -> list[tuple[str, str, Robot, Physics, Robot, Physics, bool]]:
    """(skip, robot, the robot and physics with the work done, and without it, whether the
    motion compares over the settle only): what a scene leaves out, against the same scene
    made to do it."""
    physics = BASE["physics"]
    multiped = paper_robot("multiped")
    soft_grid = multiped.grid.copy()
    soft_grid[soft_grid >= Material.MUSCLE_PLUS] = Material.SOFT
    small = Robot.from_body(np.array([[[1, 3], [4, 1]], [[3, 1], [1, 4]]], dtype=np.int8))
    soft = Robot.box((7,) * 3, Material.SOFT)
    one_hard = soft.grid.copy()
    one_hard[tuple(np.argwhere(one_hard)[0])] = Material.HARD
    return [
        ("muscle drive without muscles (muscles vs the same voxels soft; motion compared "
         "over the settle, where the muscles rest)", "multiped",
         multiped, physics, Robot(soft_grid), physics, True),
        ("collision stage where no pair can collide (collisions on vs off)", "2x2x2 block",
         small, physics, small, physics.replace(collision_radius=0.0), False),
        ("collision stage where pairs can collide (on vs off)", "multiped",
         multiped, physics, multiped, physics.replace(collision_radius=0.0), False),
        ("hard voxels' step without hard voxels (one hard voxel vs none)", "7x7x7 soft",
         Robot(one_hard), physics, soft, physics, False),
    ]


def skip_rows() -> list[dict]:
    """CPU s (medians of SKIP_ROUNDS, interleaved) with and without each skipped work, and
    how far the final positions differ (m, quaternion units; the cases that change the
    robot differ by their physics)."""
    rows = []
    for skip, name, robot_with, physics_with, robot_without, physics_without, settle_only \
            in skip_cases():
        runs = {"with": [], "without": []}
        for _ in range(SKIP_ROUNDS):
            runs["with"].append(_timed_run(robot_with, physics_with))
            runs["without"].append(_timed_run(robot_without, physics_without))
        cpu_with = float(np.median([c for c, _ in runs["with"]]))
        cpu_without = float(np.median([c for c, _ in runs["without"]]))
        q_with, q_without = runs["with"][0][1], runs["without"][0][1]
        if settle_only:
            q_with = _timed_run(robot_with, physics_with, settle_only=True)[1]
            q_without = _timed_run(robot_without, physics_without, settle_only=True)[1]
        difference = (float(np.max(np.abs(q_with - q_without))) if q_with.shape == q_without.shape
                      else math.nan)
        rows.append({"skip": skip, "robot": name, "with_cpu_s": round(cpu_with, 4),
                     "without_cpu_s": round(cpu_without, 4),
                     "saved": f"{1 - cpu_without / cpu_with:.0%}",
                     "max_qpos_difference": f"{difference:.2g}"})
    return rows


# ---------------------------------------------------------------------------- report

def _default_rows(rows: list[dict], variant: str, safety: float) -> dict[str, dict]:
    return {r["robot"]: r for r in rows if r["integrator"] == variant and r["window"] == "short"
            and float(r["safety"]) == safety}


def walker_section(walkers: list[dict]) -> str:
    """The report's paragraph on the evolved walkers' starts (`walker_rows`)."""
    first = PERTURBATIONS[0]
    lines = ["| walker | voxels | mirror plane of the body | exact start | "
             + " | ".join(f"shifted {p:g} L: mean (min–max)" for p in PERTURBATIONS)
             + " | 8 safeties: median (min–max) |", "|---" * (5 + len(PERTURBATIONS)) + "|"]
    fragile, mirrored = [], []
    for w in walkers:
        shifts = " | ".join(f"{w[f'shift_{p:g}_mean']} ({w[f'shift_{p:g}_min']}–"
                            f"{w[f'shift_{p:g}_max']})" for p in PERTURBATIONS)
        lines.append(f"| {w['robot']} | {w['voxels']} | {w['mirror']} | {w['default']} | "
                     f"{shifts} | {w['safeties_median']} ({w['safeties_min']}–"
                     f"{w['safeties_max']}) |")
        kept = float(w[f"shift_{first:g}_mean"]) / float(w["default"])
        if kept < KEPT:
            fragile.append(f"{w['robot']} ({100 * kept:.0f} %)")
            if w["mirror"] != "none":
                mirrored.append(w["robot"])
    mirror_note = (f" A body with a mirror plane ({', '.join(mirrored)}) keeps its mirror "
                   "symmetry from it to rounding (nothing in the physics breaks it) and loses "
                   "that motion once a shift of a rounding's size does."
                   if mirrored else "")
    verdict = (f"Walkers that keep less than {100 * KEPT:.0f} % of their exact start's "
               f"distance from starts shifted by {first:g} L: {', '.join(fragile)}. They were "
               "evolved when the GA scored every robot from the exact start, so it could "
               f"select a gait that only that start produces.{mirror_note} Every evaluation "
               "now starts shifted (1e-4 L, docs/transfer.md), and `mjregen walk ROBOT "
               f"--shifted-starts {PERTURBED_RUNS}` compares a robot's exact start with "
               "shifted ones." if fragile else
               f"Every walker keeps at least {100 * KEPT:.0f} % of its default distance from "
               f"starts shifted by {first:g} L.")
    return (f"### The shipped evolved walkers\nThe same {PERTURBED_RUNS} shifted starts per "
            f"size ({', '.join(f'{p:g}' for p in PERTURBATIONS)} voxel lengths) and the 8 "
            "safeties for each shipped evolved 3D walker (`assets/nca/`, "
            "`assets/robots/walkers/`) and the best robot of 3d_ff seed 1 "
            "(`records/results/3d_ff/seed_1`), over the paper's window; distances in voxel "
            "lengths:\n\n" + "\n".join(lines) + "\n\n" + verdict)


def report_text(accuracy: list[dict], orders: list[dict], stability: list[dict],
                chaos: list[dict], walkers: list[dict], skips: list[dict],
                minutes: float | None,
                engine: bool) -> str:
    """docs/accuracy.md from the studies' rows; `minutes`: the wall time of a run of every
    study, None when some were taken from their CSVs."""
    return "".join([_work_precision_section(accuracy, orders, minutes, engine),
                    _chaos_section(chaos), walker_section(walkers), "\n\n",
                    _skips_section(skips), _stability_section(stability)])


def _defaults_table(accuracy: list[dict]) -> tuple[str, str]:
    """The table of each robot at the default step, mjregen beside the engine, and the
    sentence comparing them."""
    ours = _default_rows(accuracy, "euler", 0.75)
    theirs = _default_rows(accuracy, "paper engine", PAPER_DT_FRACTION)
    lines = ["| robot | voxels | mjregen: dt | CPU s | fitness error (L) | error % | "
             "paper engine: CPU s | fitness error (L) | error % |", "|---" * 9 + "|"]
    robots = accuracy_robots()
    for name, row in ours.items():
        engine_row = theirs.get(name, {})
        lines.append(f"| {name} | {robots[name].n_voxels} | {float(row['dt']):.3g} | "
                     f"{float(row['cpu_s']):.3f} | {row['fitness_error']} | "
                     f"{row['fitness_error_pct']} | {engine_row.get('cpu_s', '—')} | "
                     f"{engine_row.get('fitness_error', '—')} | "
                     f"{engine_row.get('fitness_error_pct', '—')} |")
    defaults = "\n".join(lines)
    shared = [name for name in ours if name in theirs]
    cpu_ratios = [float(ours[n]["cpu_s"]) / float(theirs[n]["cpu_s"]) for n in shared]
    def error(row: dict) -> float:
        return float(row["fitness_error"]) if row.get("fitness_error") not in ("", None) \
            else math.inf

    smaller = sum(error(ours[n]) <= error(theirs[n]) for n in shared)
    compared = (f"On the robots both run, mjregen's default step costs "
                f"{min(cpu_ratios):.2f}–{max(cpu_ratios):.2f} of the engine's CPU time at its "
                f"default step over this window, and its fitness error (each against its own "
                f"reference) is no larger than the engine's on {smaller} of {len(shared)}."
                ) if shared else ""
    return defaults, compared


def _work_precision_section(accuracy: list[dict], orders: list[dict], minutes: float | None,
                            engine: bool) -> str:
    """The report's head and its section "Work against precision"."""
    timing = (f"{minutes:.0f} min here" if minutes is not None
              else "about 20 min here for every study")
    defaults, compared = _defaults_table(accuracy)
    order_lines = ["| robot | integrator | points | COM order | fitness order |",
                   "|---|---|---|---|---|"]
    order_lines += [f"| {o['robot']} | {o['integrator']} | {o['points']} | {o['com_order']} | "
                    f"{o['fitness_order']} |" for o in orders
                    if o["integrator"] in ("euler", "rk4", "paper engine")]
    engine_note = ("The paper's engine runs the same robots over the same window at step "
                   f"fractions {', '.join(f'{f:g}' for f in ENGINE_FRACTIONS)} of its own "
                   f"stability rule (the paper's {PAPER_DT_FRACTION}), against itself at "
                   f"{ENGINE_REFERENCE_FRACTION:.3g}; it reports only the distance, so its "
                   "line is in the fitness panels.") if engine else \
        "(The paper engine's line needs `--voxelyze DIR`.)"
    return f"""# Error against run time, and stability of the time step

Generated by `python benchmarks/accuracy.py report --jobs 2 --voxelyze DIR` ({timing}), DIR
the paper engine's folder (its `vxa.py`, as for benchmarks/speed.py). The physics is the default, `Physics()` (the voxel plugin with the paper engine's laws,
docs/fidelity.md), stepped as `simulate` steps it (semi-implicit Euler in the plugin's
native stepper); "rk4" is the pure-MuJoCo pipeline's twin of it (MuJoCo's tendons and
contacts, `mujoco_twin`), the only one that takes other integrators.

## Work against precision
Window: settle 0.05 s, then 0.1 s of walking (four muscle cycles). Steps: multiples
{', '.join(f'{s:g}' for s in SAFETIES)} of each robot's stability limit (`timestep_safety`;
the default is 0.75), each dividing the settle exactly; the reference is the same code at
a {REFERENCE_DIVISOR}th of the smallest step. Errors: the final centre of mass's distance
from the reference's and the fitness's difference, in voxel lengths; "rk4" runs another
model (the twin), so its fitness is compared with its own run at its smallest stable step.
{engine_note}

![work-precision](accuracy_work_precision.png)

At the default step:

{defaults}

{compared}

Convergence orders (least-squares slope of log error against log step over the stable
steps; Euler is first order, RK4 here runs contacts and a per-step muscle command):

{chr(10).join(order_lines)}

"""


def _chaos_table(chaos: list[dict]) -> tuple[list[str], list[str]]:
    """The chaos studies' table (lines) and one sentence per robot."""
    chaos_lines = ["| robot | default | std over shifted starts: "
                   + ", ".join(f"{p:g} L" for p in PERTURBATIONS)
                   + " | 8 safeties: median (range) | "
                   + " | ".join(f"step halved 0 … {HALVINGS} times, {r} rule"
                                for r in LADDERS)
                   + " | limit (spread) | default − limit |",
                   "|---" * (6 + len(LADDERS)) + "|"]
    sentences = []
    for c in chaos:
        shifts = ", ".join(c[f"shift_{p:g}_std"] for p in PERTURBATIONS)
        ladders = " | ".join(c[f"ladder_{r}"] for r in LADDERS)
        chaos_lines.append(
            f"| {c['robot']} | {c['default']} | {shifts} | {c['safeties_median']} "
            f"({c['safeties_min']}–{c['safeties_max']}) | {ladders} | {c['converged']} "
            f"({c['converged_spread']}) | {c['default_error']} |")
        error, limit = float(c["default_error"]), float(c["converged"])
        sentences.append(
            f"- **{c['robot']}**: at the default step its distance is {float(c['default']):.2f}, "
            f"{100 * error / limit:.1f} % from the {limit:.2f} that shorter steps converge to "
            f"(to {float(c['converged_spread']):.2g}); differences of fitness below about "
            f"{max(error, float(c['safeties_max']) - float(c['safeties_min'])):.2g} voxel "
            "lengths between such robots are the time step's, not the robots'.")
    return chaos_lines, sentences


def _chaos_section(chaos: list[dict]) -> str:
    """The section "How much of a fitness is physics" (the chaos studies' rows)."""
    chaos_lines, sentences = _chaos_table(chaos)
    from mjregen.validation.reference import REFERENCE

    fidelity_lines = ["| rule | " + " | ".join(c["robot"] for c in chaos) + " |",
                      "|---|" + "---|" * len(chaos)]
    ratios: dict[str, list[float]] = {}
    for rule in LADDERS:
        cells = []
        for c in chaos:
            ladder = [float(x) for x in c[f"ladder_{rule}"].split()]
            pair = (ladder[0] / REFERENCE[c["robot"]]["distance"],
                    ladder[CONVERGED_FROM] / REFERENCE[c["robot"]]["distance"])
            ratios.setdefault(rule, []).extend(pair)
            cells.append(f"{pair[0]:.2f} / {pair[1]:.2f}")
        fidelity_lines.append(f"| {rule} | " + " | ".join(cells) + " |")
    engine_band = f"{min(ratios['momentum']):.2f}–{max(ratios['momentum']):.2f}"
    fixed_low = min(ratios["fixed"])
    first = [float(c[f"shift_{PERTURBATIONS[0]:g}_std"]) for c in chaos]
    low, high = min(first), max(first)
    top = max(float(c[f"shift_{PERTURBATIONS[-1]:g}_std"]) for c in chaos)
    return f"""## How much of a fitness is physics
The paper's window (0.05 + 0.5 s), each paper robot: the default run; {PERTURBED_RUNS} runs
from starts whose voxels are shifted by normal random amounts of each of
{', '.join(f'{p:g}' for p in PERTURBATIONS)} voxel lengths; the 8 time-step safeties
{', '.join(f'{s:g}' for s in CHAOS_SAFETIES)}; and a ladder of ever shorter steps, the
default halved up to {HALVINGS} times, with each friction stop rule: "momentum" (the
engine's and the default: a sliding voxel stops when the step's friction impulse
μ_k N dt reaches its momentum), "energy" (when the step's friction work would exceed its
kinetic energy) and "fixed" (the momentum rule over a fixed {ENGINE_STEP:.3g} s, the
engine's step, instead of the step: `friction_stop_time`, a stop threshold that does not
depend on the step). Distances in voxel lengths:

{chr(10).join(chaos_lines)}

{chr(10).join(sentences)}

A start shifted by {PERTURBATIONS[0]:g} voxel lengths moves the distance by {low:.1g}–{high:.1g}
(an amplification of {low / PERTURBATIONS[0]:.0f}–{high / PERTURBATIONS[0]:.0f}), one shifted by
{PERTURBATIONS[-1]:g} by up to {top:.2g}: the paper robots' walks respond to their start, but a
rounding stays far below the time step's effect, which is what moves a fitness.
A contact's stick or slip is decided within a step (a sliding voxel stops when the step's friction impulse reaches its momentum, a threshold
speed proportional to the step), so a longer step can flip one such event and with it a
stride; as the step shrinks the momentum and energy rules converge to the same limit (the
ladder), Coulomb friction with sticking, whose threshold speed goes to zero with the step.
The fixed rule keeps a finite threshold: at the engine's step it is the engine's rule, at
shorter steps it stops every voxel slower than μ_k (N/m)·{ENGINE_STEP:.3g} s at once, a
stickier law that walks elsewhere (its ladder). Against the paper engine's own distances
(its recordings), each rule's distance ratio at the default step and at an 8th of it:

{chr(10).join(fidelity_lines)}

The engine's rule stays within {engine_band} of the engine at both steps; the fixed rule
falls to {fixed_low:.2f} at the shorter one. So the default keeps the engine's rule.
Selection in an evolution compares robots at one step, so what matters is whether their
differences exceed the step's effect above.

"""


def _skips_section(skips: list[dict]) -> str:
    """The section "What a scene leaves out"."""
    skip_lines = ["| what is left out | robot | CPU s with the work | without | saved | "
                  "largest final qpos difference |", "|---|---|---|---|---|---|"]
    skip_lines += [f"| {r['skip']} | {r['robot']} | {r['with_cpu_s']} | {r['without_cpu_s']} | "
                   f"{r['saved']} | {r['max_qpos_difference']} |" for r in skips]
    return f"""## What a scene leaves out
The voxel plugin does only the work a robot needs: no muscle drive without muscles; no
collision stage where no two surface voxels are more than `collision_hops` bonds apart (no
pair could ever collide); and the step is its own bond network's, so a robot without hard
voxels never takes a hard voxel's step (the engine's rule takes its stiffest material's
step whatever the network: one hard voxel in a soft block would cost it 2.2 times the
steps). CPU s of the paper window (medians of {SKIP_ROUNDS} interleaved runs) with the
work and without, and how far the end states differ (m and quaternion units):

{chr(10).join(skip_lines)}

The collision stage of a robot where no pair can collide changes nothing and costs nothing
measurable (it is not run); where pairs can collide it cost {skips[2]['saved']} here (these
CPU times vary by several per cent between runs on this shared machine). Resting muscles
move as soft voxels do (to rounding: their bonds come first in the bond order); one hard
voxel in a soft block shortens its step only by what that voxel's bonds need. The tests
check each (tests/physics/test_engine_floor.py, tests/physics/test_timestep.py, tests/physics/test_physics_mechanics.py).

"""


def _stability_section(stability: list[dict]) -> str:
    """The section "Stability"."""
    stable = [r for r in stability if str(r["default_stable"]) == "True"]
    margins = [float(r["margin"]) for r in stability if r["margin"] not in ("", None)]
    stability_lines = ["| case | voxels | ζ | default dt | stable at the default | largest "
                       "stable safety | margin |", "|---|---|---|---|---|---|---|"]
    stability_lines += [f"| {r['case']} | {r['voxels']} | {r['zeta']} | {r['default_dt']} | "
                        f"{r['default_stable']} | {r['max_stable_safety']} | {r['margin']} |"
                        for r in stability]
    return f"""## Stability
Every case at its default step, and the largest stable `timestep_safety` found by
bracketing and bisection (a run is stable when no state is NaN, MuJoCo does not warn and
no voxel runs faster than 5 m/s, ending below {END_SPEED} m/s): {len(stable)} of
{len(stability)} stable at the default; margins (largest stable / default safety)
{min(margins):.2f}–{max(margins):.2f}.

{chr(10).join(stability_lines)}
"""


def write_report(out: Path, n_jobs: int, voxelyze: Path | None, reuse: bool = False) -> None:
    """Run the accuracy (with the paper engine), chaos and stability studies and write
    docs/accuracy.md with their CSVs and figure; `reuse`: take each study whose CSV is in
    `out` from it and run the others."""
    wall0 = time.perf_counter()
    reused = []

    def kept(name: str) -> list[dict] | None:
        path = out / name
        if reuse and path.exists():
            reused.append(name)
            return read_csv(path)
        return None

    rows = kept("accuracy_table.csv")
    if rows is None:
        results = run_jobs(accuracy_jobs(variants=("euler", "rk4"), full_window=False,
                                         quick=False), n_jobs, cost=_run_cost)
        rows = accuracy_rows(results)
        if voxelyze is not None:
            rows += engine_rows(voxelyze, accuracy_robots(), n_jobs)
    rows = twins_against_themselves(rows)
    write_csv(out / "accuracy_table.csv", rows, ACCURACY_FIELDS)
    orders = convergence_orders(rows)
    write_csv(out / "accuracy_orders.csv", orders)
    plot_work_precision(rows, out / "accuracy_work_precision.png")
    stability = kept("accuracy_stability.csv")
    if stability is None:
        cases = stability_cases()
        with multiprocessing.get_context("fork").Pool(n_jobs) as pool:
            stability = pool.map(_stability_job, [(c, "") for c in cases])
        write_csv(out / "accuracy_stability.csv", stability, STABILITY_FIELDS)
    chaos, walkers = kept("accuracy_chaos.csv"), kept("accuracy_walkers.csv")
    if chaos is None or walkers is None:
        chaos, walkers = chaos_studies(n_jobs)
        write_csv(out / "accuracy_chaos.csv", chaos, CHAOS_FIELDS)
        write_csv(out / "accuracy_walkers.csv", walkers, WALKER_FIELDS)
    skips = kept("accuracy_skips.csv")
    if skips is None:
        skips = skip_rows()
        write_csv(out / "accuracy_skips.csv", skips, SKIP_FIELDS)
    minutes = None if reused else (time.perf_counter() - wall0) / 60
    engine = any(r["integrator"] == "paper engine" for r in rows)
    (out / "accuracy.md").write_text(report_text(rows, orders, stability, chaos, walkers,
                                                 skips, minutes, engine))


# ---------------------------------------------------------------------------- main

def _parser() -> argparse.ArgumentParser:
    """The command line of this script."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", choices=["report", "accuracy", "stability", "chaos", "skips",
                                          "plot"])
    parser.add_argument("--voxelyze", type=Path, default=None,
                        help="report: the paper engine's folder (its vxa.py), for its line")
    parser.add_argument("--reuse", action="store_true",
                        help="report: take each study whose CSV is in OUT from it, run the "
                        "others")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes")
    parser.add_argument("--out", type=Path, default=DOCS, help="folder for CSV/PNG")
    parser.add_argument("--full-window", action="store_true",
                        help="also the tripod over the paper's 0.05 + 0.5 s")
    parser.add_argument("--variants", default="euler,rk4,euler-mid,rk4-mid,implicit,"
                        "implicitfast")
    parser.add_argument("--rule", default="", choices=["", "zeta"])
    parser.add_argument("--preset", default="default",
                        help="physics every case starts from: default = Physics(), or NAME "
                        "for mjregen.physics.NAME_physics() (e.g. paper)")
    parser.add_argument("--timestep-rule", default="", choices=["", "network", "stiffest_bond"],
                        help="the pipeline's timestep_rule in every case (default: the "
                        "preset's); "
                        "the output files get the rule as a suffix")
    parser.add_argument("--robots", default="", help="accuracy: comma-separated subset")
    parser.add_argument("--quick", action="store_true", help="small robots only")
    parser.add_argument("--from-log", action="store_true",
                        help="accuracy: rebuild the tables from OUT/accuracy_runs.jsonl")
    return parser


def _accuracy_study(args: argparse.Namespace, suffix: str) -> None:
    """The accuracy study alone: its runs (or its log), tables and figure into OUT."""
    jobs = accuracy_jobs(variants=tuple(args.variants.split(",")),
                         full_window=args.full_window, quick=args.quick)
    if args.robots:
        jobs = [job for job in jobs if job[0][0] in args.robots.split(",")]
    log = args.out / f"accuracy_runs{suffix}.jsonl"
    if args.from_log:
        results = load_log(log)
    else:
        log.unlink(missing_ok=True)
        results = run_jobs(jobs, args.jobs, cost=_run_cost, log=log)
    rows = accuracy_rows(results)
    write_csv(args.out / f"accuracy_table{suffix}.csv", rows, ACCURACY_FIELDS)
    orders = convergence_orders(rows)
    write_csv(args.out / f"accuracy_orders{suffix}.csv", orders)
    plot_work_precision(rows, args.out / f"accuracy_work_precision{suffix}.png")
    print(markdown(rows, ACCURACY_FIELDS))
    print(markdown(orders, list(orders[0])))


def _stability_study(args: argparse.Namespace, suffix: str) -> None:
    """The stability study alone, its cases on `args.jobs` processes, its table into OUT."""
    cases = stability_cases(quick=args.quick)
    tasks = sorted(((c, args.rule) for c in cases),
                   key=lambda t: -t[0].run.robot.n_voxels
                   * math.sqrt(max(m.youngs_modulus for m in t[0].run.physics.materials
                                   .values())))
    rows = []
    if args.jobs <= 1:
        for task in tasks:
            rows.append(_stability_job(task))
            print(rows[-1], flush=True)
    else:
        with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
            for row in pool.imap_unordered(_stability_job, tasks):
                rows.append(row)
                print(row, flush=True)
    order = {c.name: i for i, c in enumerate(cases)}
    rows.sort(key=lambda r: order[r["case"]])
    write_csv(args.out / f"accuracy_stability{suffix}.csv", rows, STABILITY_FIELDS)
    print(markdown(rows, STABILITY_FIELDS[:-1]))


def main(argv: list[str] | None = None) -> None:
    parser = _parser()
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    BASE["physics"] = preset(args.preset)
    suffix = "" if args.preset == "default" else f"_{args.preset}"
    if args.timestep_rule:
        BASE["physics"] = BASE["physics"].replace(timestep_rule=args.timestep_rule)
        suffix += f"_{args.timestep_rule}"
    if args.study == "report":
        write_report(args.out, args.jobs, args.voxelyze, reuse=args.reuse)
        print(args.out / "accuracy.md")
    elif args.study == "skips":
        rows = skip_rows()
        write_csv(args.out / f"accuracy_skips{suffix}.csv", rows, SKIP_FIELDS)
        print(markdown(rows, SKIP_FIELDS))
    elif args.study == "chaos":
        rows, walkers = chaos_studies(args.jobs)
        write_csv(args.out / f"accuracy_chaos{suffix}.csv", rows, CHAOS_FIELDS)
        write_csv(args.out / f"accuracy_walkers{suffix}.csv", walkers, WALKER_FIELDS)
        print(markdown(rows, CHAOS_FIELDS))
        print(markdown(walkers, WALKER_FIELDS))
    elif args.study == "accuracy":
        _accuracy_study(args, suffix)
    elif args.study == "stability":
        _stability_study(args, suffix)
    else:
        rows = read_csv(args.out / f"accuracy_table{suffix}.csv")
        plot_work_precision(rows, args.out / f"accuracy_work_precision{suffix}.png")


if __name__ == "__main__":
    sys.exit(main())
