"""Fidelity: re-run the paper engine's reference cases in mjregen and compare.

Runs every case of `mjregen.validation.reference` with the chosen physics and prints a table
(measure, reference, mjregen, ratio); `--json` writes the numbers.

    python benchmarks/fidelity.py [--physics default|paper|sphere|box] [--bonds B]
        [--timestep-rule R] [--scene key=value ...] [--friction x]
        [--cases tripod,drop_voxel] [--json F]

`--physics`, `--bonds` and `--timestep-rule` choose the physics as every mjregen command does
(`mjregen.cli.common.physics_from_args`); `--scene` then overrides fields of the scene or of
the pipeline (JSON values:
`--scene bond_damping_ratio=0.5`, `--scene beam_law='"tendons"'`;
`--scene 'pipeline="mujoco"'` first switches to the pure-MuJoCo pipeline with its
defaults), and `--friction 1.0` sets every material's friction.

`--doc docs/fidelity.md --reference DIR [--jobs 2] [--no-plots]` writes the whole report:
the before (`benchmarks/fidelity_before.json`, the audit that opened the work), the paper
robots and small cases with the default physics, each of the engine's laws added to the
earlier rules and taken back from today's, the per-voxel divergence, and overlay plots
(`docs/fidelity_*.png`). DIR (or $MJREGEN_REFERENCE) holds the paper engine's recordings.

`--write-paths assets/reference` writes the engine's COM paths of the three paper robots
(1 ms samples, from the recordings) to `engine_robot_paths.npz` there: the package's copy,
which `mjregen.validation.reference` compares paths and headings with.

`--spread 0.5,0.55,...` instead walks each paper robot once per time-step safety (slightly
different integrations of the same physics: the gaits are chaotic) and prints the
distances, their median and range, and the median's ratio to the engine's distance
(`--jobs 2` runs them on two processes).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import time
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.cli.common import add_physics_choice
from mjregen.cli.common import physics_from_args as command_physics
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.validation.reference import (
    CASES,
    ENGINE_PATHS,
    REFERENCE,
    ROBOT_FILES,
    CaseResult,
    load_csv,
)

ROOT = Path(__file__).resolve().parent.parent
# the paper engine's recordings (not shipped: 7.5 MB); --reference or $MJREGEN_REFERENCE
DEFAULT_REFERENCE = Path(os.environ.get("MJREGEN_REFERENCE", "reference"))
UNITS = {"distance": (1.0, "vox"), "sag_max_t": (1e3, "ms"), "stop_after": (1e3, "ms")}


def physics_from_args(args: argparse.Namespace) -> Physics:
    """The command's physics (`mjregen.cli.common.physics_from_args`), then --friction (the
    static coefficient; kinetic capped at it) and --scene."""
    physics = command_physics(args)
    if args.friction is not None:
        physics = Physics(materials={
            m: dataclasses.replace(p, friction=args.friction, kinetic_friction=None
                                   if p.kinetic_friction is None
                                   else min(p.kinetic_friction, args.friction))
            for m, p in physics.materials.items()}, scene=physics.scene,
            pipeline=physics.pipeline)
    changes = {}
    for item in args.scene:
        key, _, value = item.partition("=")
        changes[key] = json.loads(value)
    return physics.replace(**changes) if changes else physics


def rows(result: CaseResult) -> list[tuple[str, str, float, float, str]]:
    """(case, measure, reference, mjregen, unit) in display units."""
    out = []
    for measure, reference in REFERENCE.get(result.name, {}).items():
        scale, unit = UNITS.get(measure, (1e3, "mm"))
        out.append((result.name, measure, reference * scale,
                    result.measures.get(measure, math.nan) * scale, unit))
    if "z_settled" in result.measures:
        for measure in ("z_settled", "z_mean"):
            out.append((result.name, measure, math.nan, result.measures[measure] * 1e3, "mm"))
    return out


def reference_robot(reference: Path, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(t, com (n, 3)) of a paper robot from the reference trajectories."""
    data = load_csv(reference / f"{ROBOT_FILES[name]}.csv.gz")
    return data["t"], np.stack([data["com_x"], data["com_y"], data["com_z"]], axis=1)


def write_engine_paths(reference: Path, folder: Path) -> Path:
    """The engine's COM path of each paper robot, every 1 ms from 0 to the end of the walk
    (linear interpolation of its 0.1 ms samples), as `ENGINE_PATHS` in `folder`."""
    arrays = {}
    for name in ROBOT_FILES:
        t, com = reference_robot(reference, name)
        grid = np.round(np.arange(0.0, t[-1] + 1e-9, 1e-3), 6)
        arrays[f"{name}_t"] = grid
        arrays[f"{name}_com"] = np.stack([np.interp(grid, t, com[:, k]) for k in range(3)], 1)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / ENGINE_PATHS
    np.savez_compressed(path, **arrays)
    return path


def plot(result: CaseResult, reference: Path, out: Path) -> Path | None:
    """Overlay of mjregen and reference for one case, as a small PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name = result.name
    if name in ROBOT_FILES:
        t_ref, com_ref = reference_robot(reference, name)
        t, com = result.traces["com"]
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(8, 3.2))
        for label, tt, cc, style in (("paper engine", t_ref, com_ref, "k-"),
                                     ("mjregen", t, com, "r-")):
            k = int(np.argmin(np.abs(tt - 0.05)))
            ax1.plot((cc[:, 0] - cc[k, 0]) * 1e3, (cc[:, 1] - cc[k, 1]) * 1e3, style, lw=1,
                     label=label)
            ax1.plot(0, 0, "bo", ms=3)
            ax2.plot(tt, cc[:, 2] * 1e3, style, lw=0.6, label=label)
        ax1.set(xlabel="x (vox)", ylabel="y (vox)", title=f"{name}: COM path from 0.05 s")
        ax1.set_aspect("equal", adjustable="datalim")
        ax2.set(xlabel="t (s)", ylabel="COM z (mm)", title="COM height")
        ax1.legend(fontsize=7)
    else:
        label, (t, values) = next(iter(result.traces.items()))
        fig, ax = plt.subplots(figsize=(5, 3))
        ref_file = reference / f"{name}.csv.gz"
        voxels = reference / f"{name}_voxels.csv.gz"
        if name in ("drop_voxel", "drop_block") and ref_file.exists():
            data = load_csv(ref_file)
            ax.plot(data["t"], data["com_z"] * 1e3, "k-", lw=1, label="paper engine")
        elif name.startswith("slide_bar") and ref_file.exists():
            data = load_csv(ref_file)
            ax.plot(data["t"], (data["com_x"] - data["com_x"][0]) * 1e3, "k-", lw=1,
                    label="paper engine")
        elif name == "cantilever" and voxels.exists():
            data = load_csv(voxels)
            tip = data["ix"] == data["ix"].max()
            ax.plot(data["t"][tip], (data["z"][tip][0] - data["z"][tip]) * 1e3, "k-", lw=1,
                    label="paper engine")
        elif name == "bar_red_green" and voxels.exists():
            data = load_csv(voxels)
            a, b = data["ix"] == 0, data["ix"] == 1
            d = np.linalg.norm(np.stack([data[k][b] - data[k][a] for k in "xyz"], 1), axis=1)
            ax.plot(data["t"][a], d * 1e3, "k-", lw=1, label="paper engine")
        ax.plot(t, values * 1e3, "r-", lw=1, label="mjregen")
        ax.set(xlabel="t (s)", ylabel=f"{label} (mm)", title=name)
        ax.legend(fontsize=7)
    fig.tight_layout()
    path = out / f"fidelity_{name.replace('.', '_')}.png"
    fig.savefig(path, dpi=72)
    plt.close(fig)
    return path


def _walk(item: tuple[str, Physics, float]) -> tuple[str, float, float, float]:
    """(robot, safety, distance in voxel lengths, heading in degrees) of one walk."""
    from mjregen.physics.simulation import simulate

    name, physics, safety = item
    robot = Robot(np.load(ROOT / "assets" / "robots" / "paper" / f"{name}.npy"))
    result = simulate(robot, physics=physics.replace(timestep_safety=safety))
    return name, safety, result.distance, result.heading


STARTS = 10  # symmetry-broken starts of each paper robot in the report


def _walk_from(item: tuple[str, int]) -> tuple[str, float, float]:
    """(robot, distance in voxel lengths, heading in degrees) of a paper robot's walk from
    start `item[1]` (the default physics)."""
    from mjregen.physics.simulation import simulate

    name, start = item
    robot = Robot(np.load(ROOT / "assets" / "robots" / "paper" / f"{name}.npy"))
    result = simulate(robot, start=start)
    return name, result.distance, result.heading


def spread(physics: Physics, safeties: list[float], jobs: int) -> str:
    """Markdown table: each paper robot's distance at each safety, median, range, ratio."""
    import multiprocessing

    items = [(name, physics, s) for name in ROBOT_FILES for s in safeties]
    with multiprocessing.get_context("fork").Pool(jobs) as pool:
        walked = pool.map(_walk, items)
    lines = ["| robot | " + " | ".join(f"{s:g}" for s in safeties)
             + " | median | range | engine | median / engine |",
             "|---" * (len(safeties) + 6) + "|"]
    for name in ROBOT_FILES:
        distances = [d for n, _, d, _ in walked if n == name]
        median = float(np.median(distances))
        engine = REFERENCE[name]["distance"]
        lines.append(f"| {name} | " + " | ".join(f"{d:.1f}" for d in distances)
                     + f" | {median:.1f} | {min(distances):.1f}–{max(distances):.1f} | "
                     f"{engine:.2f} | {median / engine:.2f} |")
    return "\n".join(lines)


def markdown_table(all_rows: list[tuple]) -> str:
    lines = ["| case | measure | paper engine | mjregen | ratio |", "|---|---|---|---|---|"]
    for case, measure, ref, ours, unit in all_rows:
        ratio = f"{ours / ref:.2f}" if ref and math.isfinite(ref) and ref != 0 else ""
        ref_text = f"{ref:.4g} {unit}" if math.isfinite(ref) else "—"
        lines.append(f"| {case} | {measure} | {ref_text} | {ours:.4g} {unit} | {ratio} |")
    return "\n".join(lines)


# The laws mjregen took from the paper's engine (evosoro's Voxelyze) for physics format 4:
# name, what the engine does, its setting, the rule before (formats 1-3)
CHANGES = [
    ("beam law", "the engine's beam element (`CVXS_BondInternal`): a linear axial spring "
     "E·L (the tendon bundle's law stiffened in tension) and torsion G·J/L with J = L⁴/6, "
     "G = E/2(1+ν) (the shear-rigid bonds had taken G = E for it, 5.4 times stiffer)",
     {"beam_law": "engine"}, {"beam_law": "tendons"}),
    ("beam damping", "the engine's dampers (`AddDampForces`): c = 2ζ sqrt(m k) per force "
     "row and half of it per moment row, ζ = 0.5 (its BondDampingZ 1, halved); before, "
     "C = βK on every row with ζ = 0.4",
     {"beam_damping": "engine", "bond_damping_ratio": 0.5},
     {"beam_damping": "stiffness_proportional", "bond_damping_ratio": 0.4}),
    ("friction stop", "the engine's floor (`CalcFloorEffect`): a sliding voxel stops when "
     "the step's friction impulse μ_k N dt reaches its momentum m|v|; a voxel without "
     "horizontal speed is at rest (static friction); before, when the step's friction work "
     "exceeded its kinetic energy",
     {"friction_stop": "momentum"}, {"friction_stop": "energy"}),
    ("self-collision", "the engine's (`CVXS_BondCollision`, `CalcL1Bonds`): surface voxels "
     "more than 3 bonds apart repel as spheres of diameter 1.5 L with an undamped spring "
     "E·L; before, spheres of 1.25 L (Voxelyze 2's envelope) between voxels that are not "
     "grid neighbours, with the floor's spring 2·E·L and damper",
     {"collision_radius": 0.75, "collision_stiffness": 1.0, "collision_damping": 0.0,
      "collision_hops": 3},
     {"collision_radius": 0.625, "collision_stiffness": 2.0, "collision_damping": 0.8,
      "collision_hops": 0}),
    ("drag", "the engine's slow damping (`CalcTotalForce`, `EulerStep`): −2ζ sqrt(m E L)·v "
     "with each voxel's own modulus and −2·10ζ sqrt(I E L³)·ω on its rotation (c/I = "
     "155 s⁻¹ soft); before, the soft voxel's drag for all and a cube's Stokes rotational "
     "drag (c/I = 12.6 s⁻¹)",
     {"drag_law": "engine"}, {"drag_law": "stokes"}),
]
SAFETIES = (0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85)
SMALL = ("drop_voxel", "drop_block", "slide_bar_v0.2", "slide_bar_v0.1", "bar_red_green",
         "cantilever")
# the small-case measures the ablation table shows
ABLATION_MEASURES = (("drop_voxel", "rebound"), ("drop_block", "first_apex_z"),
                     ("slide_bar_v0.2", "stop_after"), ("cantilever", "sag_end"))
BEFORE = ROOT / "benchmarks" / "fidelity_before.json"


def variants() -> list[tuple[str, Physics]]:
    """(label, physics): the rules before, each law added alone, today's, each law taken
    back alone."""
    earlier = {k: v for _, _, _, old in CHANGES for k, v in old.items()}
    before = Physics().replace(**earlier)
    out = [("before (all earlier rules)", before)]
    out += [(f"before + {name}", before.replace(**new)) for name, _, new, _ in CHANGES]
    out.append(("**now (all the engine's laws)**", Physics()))
    out += [(f"now − {name}", Physics().replace(**old)) for name, _, _, old in CHANGES]
    return out


def _measure(item: tuple[int, str, Physics]) -> tuple[int, str, CaseResult]:
    index, case, physics = item
    return index, case, CASES[case](physics)


def heading_off(heading: float, name: str) -> float:
    """Degrees from the engine's heading of robot `name`, in (-180, 180]."""
    return (heading - REFERENCE[name]["heading"] + 180.0) % 360.0 - 180.0


def robots_table_now(now: dict, spread: list, starts: list) -> str:
    names = list(ROBOT_FILES)
    head = "| | " + " | ".join(names) + " |\n|---|" + "---|" * len(names)
    lines = [head]

    def row(label: str, cells: list[str]) -> None:
        lines.append(f"| {label} | " + " | ".join(cells) + " |")

    row("distance, paper engine / mjregen (voxel lengths)",
        [f"{REFERENCE[n]['distance']:.2f} / {now[n]['distance']:.2f} "
         f"(**{now[n]['distance'] / REFERENCE[n]['distance']:.2f}**)" for n in names])
    medians, ranges = {}, {}
    for n in names:
        d = [dist for name, _, dist, _ in spread if name == n]
        h = [heading for name, _, _, heading in spread if name == n]
        medians[n] = float(np.median(d)) / REFERENCE[n]["distance"]
        ranges[n] = (min(d), max(d), min(h), max(h))
    row(f"median over {len(SAFETIES)} time-step safeties (range)",
        [f"{medians[n]:.2f} ({ranges[n][0]:.1f}–{ranges[n][1]:.1f})" for n in names])
    row("heading, paper / mjregen (range over the safeties), degrees",
        [f"{REFERENCE[n]['heading']:+.0f} / **{now[n]['heading']:+.0f}** "
         f"({ranges[n][2]:+.0f} to {ranges[n][3]:+.0f})" for n in names])
    row(f"over {STARTS} symmetry-broken starts: mean distance (ratio), mean heading (range), "
        "degrees",
        [_starts_cell(n, [(d, h) for name, d, h in starts if name == n]) for n in names])
    row("planar COM path, RMS difference",
        [f"**{now[n]['com_rms'] * 1e3:.1f} mm**" for n in names])
    row("airborne fraction, paper / mjregen",
        [f"{REFERENCE[n]['airborne']:.3f} / {now[n]['airborne']:.3f}" for n in names])
    return "\n".join(lines)


def _starts_cell(name: str, walks: list[tuple[float, float]]) -> str:
    distances, headings = np.array(walks).T
    return (f"{distances.mean():.2f} (**{distances.mean() / REFERENCE[name]['distance']:.2f}**), "
            f"**{headings.mean():+.1f}** ({headings.min():+.0f} to {headings.max():+.0f})")


def robots_table_before(before: dict) -> str:
    names = list(ROBOT_FILES)
    robots = before["robots"]
    lines = ["| | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    lines.append("| distance, paper engine / mjregen (voxel lengths) | " + " | ".join(
        f"{robots[n]['engine']:.2f} / {robots[n]['mjregen']:.2f} ({robots[n]['ratio']:.2f})"
        for n in names) + " |")
    lines.append("| median over 8 time-step safeties | " + " | ".join(
        f"{robots[n]['median_ratio']:.2f}" for n in names) + " |")
    lines.append("| heading, paper / mjregen, degrees | " + " | ".join(
        f"{robots[n]['heading_engine']:+d} / {robots[n]['heading_mjregen']}" for n in names)
        + " |")
    lines.append("| planar COM path, RMS difference | " + " | ".join(
        f"{robots[n]['com_rms_mm']:.1f} mm" for n in names) + " |")
    lines.append("| airborne fraction, paper / mjregen | " + " | ".join(
        f"{robots[n]['airborne_engine']:.3f} / {robots[n]['airborne_mjregen']:.3f}"
        for n in names) + " |")
    return "\n".join(lines)


def ablation_table(labels: list[str], measured: dict) -> str:
    names = list(ROBOT_FILES)
    head = ("| physics | " + " | ".join(f"{n}: distance ratio, heading off, COM RMS"
                                          for n in names)
            + " | " + " | ".join(f"{c} {m}" for c, m in ABLATION_MEASURES) + " |")
    lines = [head, "|---" * (1 + len(names) + len(ABLATION_MEASURES)) + "|"]
    for index, label in enumerate(labels):
        cells = []
        for n in names:
            m = measured[index][n]
            if not math.isfinite(m["distance"]):
                cells.append("unstable")
                continue
            cells.append(f"{m['distance'] / REFERENCE[n]['distance']:.2f}, "
                         f"{heading_off(m['heading'], n):+.0f}°, {m['com_rms'] * 1e3:.1f} mm")
        for case, measure in ABLATION_MEASURES:
            value = measured[index][case][measure]
            cells.append(f"{value / REFERENCE[case][measure]:.2f}")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


DIVERGENCE_TIMES = (0.005, 0.015, 0.03, 0.05, 0.1)  # s
CHAOS_SAFETY = 0.7  # another time step of the same physics (the default's safety is 0.75)
ENGINE_LONE_VOXEL_STEP = 1.4324e-6  # s, the engine's step for one voxel (its reference)


def divergence_rows(reference: Path, before: Physics) -> str:
    """RMS voxel-position difference (voxel lengths, each run from its own initial COM) at
    DIVERGENCE_TIMES: mjregen before and now against the engine, and now against itself at
    another time step (how fast two runs of the same physics part)."""
    from divergence import engine_voxels, matching_order, mjregen_voxels

    def rms(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        a, b = a - a[0].mean(axis=0), b - b[0].mean(axis=0)
        return np.sqrt(np.mean(np.sum((a - b) ** 2, axis=2), axis=1)) / 1e-3

    lines = ["| robot | compared | " + " | ".join(f"{t * 1e3:g} ms" for t in DIVERGENCE_TIMES)
             + " |", "|---|---|" + "---|" * len(DIVERGENCE_TIMES)]
    for name in ("multiped", "tripod", "biped"):
        engine = engine_voxels(reference, name)
        keep = np.array([np.argmin(np.abs(engine["t"] - t)) for t in (0.0, *DIVERGENCE_TIMES)])
        times, theirs = engine["t"][keep], engine["positions"][keep]
        runs = {label: mjregen_voxels(name, times, physics) for label, physics in (
            ("before", before), ("now", Physics()),
            ("other step", Physics().replace(timestep_safety=CHAOS_SAFETY)))}
        order = matching_order(engine["index"], runs["now"]["index"])
        for label, a, b in (
                ("before vs engine", runs["before"]["positions"][:, order], theirs),
                ("now vs engine", runs["now"]["positions"][:, order], theirs),
                (f"now vs now at safety {CHAOS_SAFETY}", runs["now"]["positions"],
                 runs["other step"]["positions"])):
            lines.append(f"| {name} | {label} | " + " | ".join(f"{r:.4f}" for r in rms(a, b)[1:])
                         + " |")
    return "\n".join(lines)


def lone_voxel_rebounds() -> list[tuple[float, float]]:
    """(time step s, rebound / the engine's) of the dropped voxel at the default step, a
    quarter of it, and the engine's own step."""
    default = Physics()
    dt = compile_robot(Robot.box((1, 1, 1)),
                       physics=default).timestep
    out = []
    for step in (dt, dt / 4, ENGINE_LONE_VOXEL_STEP):
        physics = default.replace(timestep_safety=default.scene.timestep_safety * step / dt)
        rebound = CASES["drop_voxel"](physics).measures["rebound"]
        out.append((step, rebound / REFERENCE["drop_voxel"]["rebound"]))
    return out


def write_report(reference: Path, doc: Path, jobs: int, plots: bool) -> None:
    """docs/fidelity.md: the before (the issue's audit), today's robots and small cases,
    what each of the engine's laws did, where the trajectories part, plots."""
    cpu0, wall0 = time.process_time(), time.perf_counter()
    labelled = variants()
    measured, results, spread_runs, start_runs = _run_studies(labelled, jobs)
    now = measured[next(i for i, (label, _) in enumerate(labelled) if label.startswith("**now"))]
    before = json.loads(BEFORE.read_text())
    small_rows = [row for case in SMALL for row in rows(results[case])]
    diverge = divergence_rows(reference, labelled[0][1])
    rebounds = lone_voxel_rebounds()
    if plots:
        for result in results.values():
            plot(result, reference, doc.parent)
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    doc.write_text("".join([
        _robots_section(before, now, spread_runs, start_runs, jobs, wall),
        _small_cases_section(small_rows, rebounds),
        _changes_section(labelled, measured),
        _divergence_section(diverge),
        _still_differs_section(jobs, cpu)]))


def _run_studies(labelled: list[tuple[str, Physics]], jobs: int
                 ) -> tuple[dict[int, dict], dict, list, list]:
    """Every variant on every case, the time-step spread and the starts of the paper's
    robots on `jobs` processes: (measures by variant index and case, today's results by case,
    the spread's walks, the starts' walks)."""
    import multiprocessing

    items = [(i, case, physics) for i, (_, physics) in enumerate(labelled)
             for case in (*ROBOT_FILES, *SMALL)]
    with multiprocessing.get_context("fork").Pool(jobs) as pool:
        done = pool.map(_measure, items)
        spread_runs = pool.map(_walk, [(n, Physics(), s) for n in ROBOT_FILES
                                       for s in SAFETIES])
        start_runs = pool.map(_walk_from, [(n, k) for n in ROBOT_FILES for k in range(STARTS)])
    measured: dict[int, dict] = {}
    for index, case, result in done:
        measured.setdefault(index, {})[case] = result.measures
    now_index = next(i for i, (label, _) in enumerate(labelled) if label.startswith("**now"))
    results = {case: result for index, case, result in done if index == now_index}
    return measured, results, spread_runs, start_runs


def _robots_section(before: dict, now: dict, spread_runs: list, start_runs: list, jobs: int,
                    wall: float) -> str:
    """The report's head and its section on the paper's robots (`wall`: s of the report)."""
    return f"""# Fidelity: mjregen against the paper's engine

Generated by `python benchmarks/fidelity.py --reference DIR --doc docs/fidelity.md
--jobs {jobs}` ({wall / 60:.1f} min here; DIR holds the paper engine's recordings, which are
not shipped: 7.5 MB). The engine is evosoro's Voxelyze with the paper's settings; its
robots' centre-of-mass paths ship with mjregen (`assets/reference/`), and
`tests/physics/test_fidelity.py` checks each robot against them (distance 0.9–1.1 of the engine's,
heading within 10°, planar COM path within 5 mm RMS).

## The paper's robots
Before ({before['source']}):

{robots_table_before(before)}

Now (`Physics()`, the default):

{robots_table_now(now, spread_runs, start_runs)}

The distance counts from the end of the 0.05 s settle, as the paper's fitness; the heading
is the direction of that displacement (counter-clockwise from +x); the COM path difference
compares the two planar paths from the end of the settle, every 1 ms. Every walk starts
from a symmetry-broken state (each voxel moved by 1e-4 voxel lengths, docs/transfer.md); the
first rows are start 0's, and the {STARTS} starts' row shows how far the start moves a gait.
The gaits are chaotic (a 1e-13 m change of one voxel moves a distance by ±15 %,
docs/performance.md), so the eight time-step safeties (0.5 … 0.85 of the step's stability
limit) show how much of a difference is integration noise.

"""


def _small_cases_section(small_rows: list, rebounds: list[tuple[float, float]]) -> str:
    """The section on the small cases (`rebounds`: (step s, the lone voxel's rebound / the
    engine's))."""
    return f"""## The small cases (default physics)

{markdown_table(small_rows)}

The single voxel's 46 µm rebound (a restitution of 0.1, what is left of a half-cycle of a
strongly damped contact) is a time-step effect: """ + "; ".join(
        f"at {step:.2g} s it is {ratio:.2f} of the engine's" for step, ratio in rebounds) + \
        """ (the default step of a lone voxel, a quarter of it, the engine's own step for
it). The default rule fits the step to stability, not to this bounce; in robots the bonds
set steps of 1.8–2.7e-5 s.

"""


def _changes_section(labelled: list[tuple[str, Physics]], measured: dict[int, dict]) -> str:
    """The section on the engine's laws: each added alone and taken back alone."""
    changes = "\n".join(f"{k + 1}. **{name}**: {text}." for k, (name, text, _, _)
                        in enumerate(CHANGES))
    return f"""## What was changed, and what each change did
The earlier physics followed the later Voxelyze 2 (its floor, its collision envelope) and
the tendon bundle's calibration; the paper's binary is evosoro's older Voxelyze. Reading
its source, five of its laws differed from mjregen's; each is now the default and a
`VoxelPipeline` option (`Scene.bond_damping_ratio` for ζ), whose other value is the
earlier rule (descriptions of physics formats 1–3, which held it, are read by the mjregen
at git tag `physics-formats-1-3`):

{changes}

Each law added alone to the earlier rules ("before + …") and taken back alone from
today's ("now − …"); per robot the distance ratio to the engine, the heading's difference
from the engine's and the COM path difference; then the ratio to the engine of the single
voxel's rebound, the block's first rebound apex, the slide's stopping time and the
cantilever's sag:

{ablation_table([label for label, _ in labelled], measured)}

Read with the chaos in mind (the spread above): no single law does it. The multiped's
heading needs the collision envelope, the beam law, the damping and the drag together;
the tripod's distance follows the damping, the friction stop and the drag; the friction
stop decides the slides. The small cases hardly move (the engine's damping brings the
block's rebound and the cantilever's sag to 1.00).

"""


def _divergence_section(diverge: str) -> str:
    """The section on where the trajectories part (`diverge`: `divergence_rows`)."""
    return f"""## Where the trajectories part
RMS difference of all voxel positions from the engine's (voxel lengths; each robot from its
own initial centre of mass), from the per-voxel recordings (`benchmarks/divergence.py ROBOT`
prints them for every 5 ms sample and names the voxels that differ most):

{diverge}

Before, the multiped's feet (6, 6, 0) and (5, 5, 0), diagonal neighbours √2 L apart but
many bonds apart, were pushed apart by the engine's 1.5 L collision spheres in the first
milliseconds and not by mjregen's 1.25 L ones; then its top sagged differently (damping,
torsion). Now the first 5 ms agree to a thousandth of a voxel length. A difference remains
that is not chaos: through the settle mjregen parts from the engine 10–50 times faster than
from itself at another time step (the last row of each robot). The tripod, which topples
in its settle, amplifies it most; its walk still ends within a few millimetres of the
engine's path. The candidates are below.

"""


def _still_differs_section(jobs: int, cpu: float) -> str:
    """The section on what still differs, the command lines, and the plots."""
    return f"""## What still differs from the engine
- The time step: mjregen fits it to each robot's bond network (0.75 of Euler's limit,
  docs/performance.md); the engine takes 0.9 of its own rule, 2.03e-5 s with hard voxels.
- The engine's dampers take the rate of its bond coordinates by a finite difference over
  the last step; mjregen's take the velocities (the same to first order in the step).
- The engine updates a voxel's orientation to first order and renormalises; MuJoCo
  integrates the rotation exactly.
- The engine refreshes its collision candidates only when a voxel has moved half a voxel
  since the last refresh (within 2 L); mjregen's candidate list never misses a pair.
- The engine's moment damping does not conserve angular momentum (its moment rows are damped
  at half its force rows'); mjregen does as the engine does (`beam_damping="engine"`;
  "stiffness_proportional" conserves it).

Reproduce one variant: `python benchmarks/fidelity.py --scene beam_law='"tendons"' --cases
tripod,biped,multiped`; the time-step spread: `--spread 0.5,0.55,... --jobs 2`. Measured in
{cpu / 60:.1f} CPU min of the main process (plus its {jobs} workers).

## Plots
Black: the paper engine; red: mjregen (default physics).

""" + "\n".join(f"![{case}](fidelity_{case.replace('.', '_')}.png)"
                for case in (*ROBOT_FILES, *SMALL)) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_physics_choice(parser)
    parser.add_argument("--scene", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--friction", type=float, default=None)
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--reference", type=Path, default=DEFAULT_REFERENCE,
                        help="folder of the paper engine's recordings (*.csv.gz), for the plots "
                             "(default $MJREGEN_REFERENCE, else ./reference)")
    parser.add_argument("--doc", type=Path, default=None,
                        help="write the whole report (default physics, every variant) here")
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--no-plots", action="store_true")
    parser.add_argument("--spread", default="", help="comma-separated time-step safeties")
    parser.add_argument("--jobs", type=int, default=1, help="processes for --spread, --doc")
    parser.add_argument("--write-paths", type=Path, default=None, metavar="FOLDER",
                        help="write the engine's robot COM paths (from --reference) there")
    args = parser.parse_args()
    if args.write_paths:
        print(write_engine_paths(args.reference, args.write_paths))
        return
    if args.doc:
        if not args.reference.exists():
            parser.error(f"--doc needs the engine's recordings: {args.reference} does not exist")
        args.doc.parent.mkdir(parents=True, exist_ok=True)
        write_report(args.reference, args.doc, args.jobs, plots=not args.no_plots)
        print(args.doc)
        return
    physics = physics_from_args(args)
    if args.spread:
        print(spread(physics, [float(s) for s in args.spread.split(",")], args.jobs))
        return
    all_rows, results = [], {}
    for name in args.cases.split(","):
        cpu0 = time.process_time()
        result = CASES[name](physics)
        result.cpu_time = time.process_time() - cpu0
        results[name] = result
        for row in rows(result):
            all_rows.append(row)
            print(" | ".join(str(x) for x in row), flush=True)
        print(f"  {name}: {result.cpu_time:.1f} CPU-s, stable={result.stable}", flush=True)
    table = markdown_table(all_rows)
    print(table)
    if args.json:
        args.json.write_text(json.dumps({n: {"measures": r.measures, "cpu_time": r.cpu_time,
                                             "stable": r.stable}
                                         for n, r in results.items()}, indent=1))



if __name__ == "__main__":
    main()
