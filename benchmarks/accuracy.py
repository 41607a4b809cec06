"""Error against run time of the integrators, and numerical stability on stiff and extreme cases.

Two studies, each written to ``docs/`` as CSV plus a Markdown table on stdout:

``accuracy``: for each robot (2D sheet, the paper's tripod with hard voxels, a 7×7×7 mixed
  block, the paper's evolved multiped), each integrator variant and a sweep of time steps
  (multiples of the paper engine's rule dt_p = 0.9 / (2π sqrt(k/m)), i.e. ``timestep_safety``
  1), run the same evaluation as `mjregen.physics.simulate` — settle, then actuate — and
  compare the final centre of mass (voxel lengths) and the fitness with a reference run:
  Euler at 1/16 of the smallest step of the sweep. The window is shortened to settle 0.05 s + 0.1 s of
  actuation (4 cycles), so that the references stay affordable; ``--full-window`` adds the
  paper's 0.05 + 0.5 s for the tripod, to show how chaotic contact dynamics limit
  convergence over long windows. Every step divides the settle time exactly, so all runs
  start actuating at the same instant. Variants: ``euler``, ``rk4`` (MuJoCo's), the same
  with the muscle rest lengths sampled at the step's midpoint (``-mid``) instead of its
  start, and ``implicit``/``implicitfast`` (checked for convergence only).
  Writes ``accuracy_table.csv``, ``accuracy_orders.csv`` and ``accuracy_work_precision.png``.

``stability``: for each case (stiffness ×1…×1000 of the hard material, muscle strain up to
  ±50 %, bond damping ratio 0.05…2, full 7×7×7 blocks of each material, a single voxel, a
  one-voxel tower, a clamped cantilever, a drop from 5 voxel lengths, all-muscle blocks in
  phase, blocks kicked with random 1 mm/s velocities), whether the automatic time step (``Scene.timestep_safety`` default) is stable, and
  the largest stable ``timestep_safety`` found by bracketing and geometric bisection; with
  ``--rule zeta`` the candidate rule safety × min(1, 1/ζ) is checked as well.
  Writes ``accuracy_stability.csv``.

A run is stable when `Simulation`'s guard passes (no NaN, no MuJoCo warning, no voxel faster
than 5 m/s) and at the end no voxel moves faster than ``END_SPEED`` (a slowly growing
instability that has not run away yet).

    /work/venv/bin/python benchmarks/accuracy.py accuracy --jobs 2 [--full-window] [--quick]
    /work/venv/bin/python benchmarks/accuracy.py stability --jobs 2 [--rule zeta] [--quick]
        [--timestep-rule network]
    /work/venv/bin/python benchmarks/accuracy.py plot     # redraw the PNG from the CSV

CPU time is the process CPU time of the stepping (compile excluded), one process per run.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import multiprocessing
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import mujoco
import numpy as np

from mjregen import physics as physics_module
from mjregen.fitness import VOXEL_COST
from mjregen.grid import Material, Robot
from mjregen.physics import MujocoPipeline, Physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}
END_SPEED = 2.0  # m/s: no voxel may move faster than this at the end of a stable run
SETTLE, WALK = 0.05, 0.1  # s, the shortened accuracy window
SAFETIES = (2.0, 1.5, 1.0, 0.75, 0.5, 0.25)  # accuracy sweep, × the paper rule dt_p
FULL_SAFETIES = (1.0, 0.75, 0.5)  # the tripod over the paper's full 0.55 s window
REFERENCE_DIVISOR = 16  # reference dt = smallest dt of the sweep / 16


# ---------------------------------------------------------------------------- evaluation

class MidpointSimulation(Simulation):
    """`Simulation` whose muscle rest lengths are sampled at the middle of each step."""

    def strains(self, t: float) -> tuple[float, float]:
        return super().strains(t + 0.5 * self.model.opt.timestep)


@dataclass(frozen=True)
class Run:
    """One evaluation: settle `settle` s, actuate `measured` s.

    dt: s, or None for the physics' automatic time step; integrator: a key of INTEGRATORS
    with an optional "-mid" suffix, or None for the pipeline's (the voxel pipeline: Euler);
    kick: m/s (rad/s), standard
    deviation of random initial velocities of every dof (seed 0), to excite every mode.
    """

    robot: Robot
    physics: Physics = field(default_factory=Physics)
    settle: float = SETTLE
    measured: float = WALK
    dt: float | None = None
    integrator: str | None = None
    elevation: float = 0.0
    clamped: tuple = ()
    kick: float = 0.0


# the largest self-collision envelope of MuJoCo's spheres that no grid neighbour reaches
# (they cannot exclude by bond hops): contact from 1.25 L
TWIN_COLLISION_RADIUS = 0.625


def mujoco_twin(physics: Physics) -> Physics:
    """The pure-MuJoCo pipeline nearest a voxel-pipeline `physics`: MuJoCo's tendons (the
    voxel plugin's tendon bonds) and "point" contacts (the engine floor's nearest) with the
    floor's spring and damper, the same bond model and time-step rule, the self-collision
    radius (at most `TWIN_COLLISION_RADIUS` where the plugin excludes by bond hops) and
    MuJoCo's viscosity for the drag (the plugin's "stokes" drag law)."""
    voxel = physics.pipeline
    radius = voxel.collision_radius
    if voxel.collision_hops > 0:
        radius = min(radius, TWIN_COLLISION_RADIUS)
    return physics.replace(pipeline=MujocoPipeline(
        contact_shape="point", bond_model=voxel.bond_model,
        contact_stiffness=voxel.floor_stiffness, contact_damping=voxel.floor_damping,
        collision_radius=radius, timestep_rule=voxel.timestep_rule))


def evaluate(run: Run) -> dict:
    """Run `run` like `mjregen.physics.simulate`; returns a dict of the outcome.

    Keys: stable, reason, dt, steps, cpu (s of stepping), com_start/com_end ((3,) m),
    distance (voxel lengths, planar COM displacement after the settle), fitness, max_speed
    (m/s, fastest voxel at the end).
    """
    name = run.integrator or getattr(run.physics.pipeline, "integrator", "euler")
    # the voxel plugin starts the muscles at the scene's settle time
    physics = run.physics.replace(settle_time=run.settle)
    if name != "euler" and physics.pipeline.name == "voxel":
        # Euler runs what `simulate` runs (the voxel plugin: beam bonds, engine floor, native
        # stepper); the other integrators run MuJoCo's own tendons and contacts, the engine
        # floor's nearest ("point"), with the muscles driven from Python (so "-mid" applies)
        physics = mujoco_twin(physics)
    compiled = compile_robot(run.robot, physics=physics, elevation=run.elevation,
                             clamped=run.clamped)
    model = compiled.model
    midpoint = name.endswith("-mid")
    model.opt.integrator = INTEGRATORS[name.removesuffix("-mid")]
    if run.dt is not None:
        model.opt.timestep = run.dt
    dt = float(model.opt.timestep)
    cls = MidpointSimulation if midpoint else Simulation
    sim = cls(model, physics=physics, muscles=compiled.muscles, actuation_start=run.settle,
              plugin_instance=compiled.plugin_instance)
    if run.kick:
        sim.data.qvel[:] = np.random.default_rng(0).normal(0.0, run.kick, model.nv)
    n_settle, n_measure = round(run.settle / dt), round(run.measured / dt)
    cpu0 = time.process_time()
    reason = sim.run(n_settle)
    start = sim.com()
    if not reason:
        reason = sim.run(n_measure)
    cpu = time.process_time() - cpu0
    end = sim.com()
    speed = max_voxel_speed(model, sim.data)
    if not reason and not speed <= END_SPEED:
        reason = f"voxel speed {speed:.3g} m/s > {END_SPEED} m/s at the end"
    L = run.physics.scene.voxel_size
    planar = [0, 1] if run.robot.dim == 3 else [0]
    distance = float(np.linalg.norm(end[planar] - start[planar])) / L
    fitness = distance - VOXEL_COST * run.robot.n_voxels if run.robot.dim == 3 else distance
    return {"stable": not reason, "reason": reason, "dt": dt, "steps": sim.steps, "cpu": cpu,
            "com_start": start, "com_end": end, "distance": distance, "fitness": fitness,
            "max_speed": speed}


def max_voxel_speed(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """m/s: the largest translational joint speed (free joints' linear part, slides)."""
    if not np.all(np.isfinite(data.qvel)):
        return math.inf
    speeds = [0.0]
    for j in range(model.njnt):
        adr = model.jnt_dofadr[j]
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            speeds.append(float(np.linalg.norm(data.qvel[adr:adr + 3])))
        elif model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
            speeds.append(abs(float(data.qvel[adr])))
    return max(speeds)


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
    return {"sheet_2d": sheet_2d(), "tripod": paper_robot("tripod"),
            "block_7x7x7": mixed_block(), "multiped": paper_robot("multiped")}


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
        for name in ("com_start", "com_end"):
            item[name] = np.array(item[name])
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


def convergence_orders(rows: list[dict]) -> list[dict]:
    """Least-squares slope of log(error) against log(dt) per robot, window, integrator."""
    out = []
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        if row["com_error_L"] != "":
            groups.setdefault((row["robot"], row["window"], row["integrator"]), []).append(row)
    for (robot, window, variant), group in sorted(groups.items()):
        dts = np.log([r["dt"] for r in group])
        entry = {"robot": robot, "window": window, "integrator": variant, "points": len(group)}
        for column, label in (("com_error_L", "com_order"), ("fitness_error", "fitness_order")):
            errors = np.array([float(r[column]) for r in group])
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
    styles = {"euler": ("C0", "o", "-"), "rk4": ("C1", "s", "-"),
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
                default = [r for r in pts if float(r["safety"]) == 0.75]
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
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Work–precision: settle 0.05 s + 0.1 s walking; ★ = default dt "
                 "(safety 0.75), reference Euler at dt_min/16", fontsize=9)
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


def block(n: int, code: int) -> Robot:
    return Robot.from_body(np.full((n, n, n), code, dtype=np.int8))


@dataclass(frozen=True)
class Case:
    name: str
    run: Run  # with dt None: the automatic step at the physics' timestep_safety

    def at(self, safety: float) -> Run:
        return replace(self.run, physics=self.run.physics.replace(timestep_safety=safety))


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
                      Run(block(4, 2), Physics(materials=scaled_hard(1000), scene=paper.scene,
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
            cases.append(Case(f"block 7^3 {code.name.lower()}", Run(block(7, code), paper,
                                                                    **short)))
    for code in (Material.SOFT, Material.HARD):
        cases.append(Case(f"single voxel {code.name.lower()}",
                          Run(Robot.from_body(np.full((1, 1, 1), code, np.int8)), paper, **short)))
    cases.append(Case("tower 1x1x7 hard", Run(Robot.from_body(np.full((1, 1, 7), 2, np.int8)),
                                              paper, **short)))
    cases.append(Case("tower 1x1x7 muscle+ 50%", Run(
        Robot.from_body(np.full((1, 1, 7), 3, np.int8)),
        Physics(materials=muscle_strain(0.5), scene=replace(paper.scene, waveform="symmetric"),
                pipeline=paper.pipeline),
        **short)))
    cases.append(Case("cantilever 10 hard clamped", Run(
        Robot.from_body(np.full((10, 1, 1), 2, np.int8)), paper, elevation=5e-3,
        clamped=((1, 1, 1),), **short)))
    cases.append(Case("cantilever 10 soft clamped", Run(
        Robot.from_body(np.full((10, 1, 1), 1, np.int8)), paper, elevation=5e-3,
        clamped=((1, 1, 1),), **short)))
    cases.append(Case("tripod dropped 5 L", Run(tripod, paper, elevation=5e-3, **short)))
    cases.append(Case("hard block 4^3 dropped 5 L", Run(block(4, 2), paper, elevation=5e-3,
                                                        **short)))
    cases.append(Case("muscle+ block 4^3 50% symmetric", Run(
        block(4, 3), Physics(materials=muscle_strain(0.5),
                             scene=replace(paper.scene, waveform="symmetric"),
                             pipeline=paper.pipeline), **short)))
    # resting blocks are symmetric and stay unexcited; kicked ones show the network's limit
    for code in (Material.SOFT, Material.HARD):
        cases.append(Case(f"block 4^3 {code.name.lower()} kicked 1 mm/s", Run(
            block(4, code), paper, kick=1e-3, **short)))
    cases.append(Case("mixed block 5^3 kicked 1 mm/s", Run(zeta_robot, paper, kick=1e-3,
                                                          **short)))
    cases.append(Case("biped", Run(paper_robot("biped"), paper, **short)))
    cases.append(Case("2D sheet", Run(sheet_2d(), paper, settle=0.2, measured=0.1)))
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


# ---------------------------------------------------------------------------- main

def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", choices=["accuracy", "stability", "plot"])
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
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    BASE["physics"] = preset(args.preset)
    suffix = "" if args.preset == "default" else f"_{args.preset}"
    if args.timestep_rule:
        BASE["physics"] = BASE["physics"].replace(timestep_rule=args.timestep_rule)
        suffix += f"_{args.timestep_rule}"
    if args.study == "accuracy":
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
    elif args.study == "stability":
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
    else:
        rows = read_csv(args.out / f"accuracy_table{suffix}.csv")
        plot_work_precision(rows, args.out / f"accuracy_work_precision{suffix}.png")


if __name__ == "__main__":
    sys.exit(main())
