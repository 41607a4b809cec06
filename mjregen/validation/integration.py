"""A robot's walk with another integrator, time step or initial state: the harness of the
accuracy studies (`benchmarks/accuracy.py`, docs/accuracy.md) and of the tests that check the
integrators' orders of convergence and the time step's stability.

`evaluate(Run(...))` walks like `mjregen.physics.simulate` (`walk`: settle, then measure),
on a model whose integrator (`INTEGRATORS`, optionally with the muscles sampled at each
step's midpoint), step and initial state (random velocities, positions shifted finer than a
start's keyframe holds) the `Run` may change. Integrators other than Euler run the
pure-MuJoCo twin of the physics (`mujoco_twin`), as the voxel plugin steps only Euler.
Units: SI (m, s), distances in voxel lengths.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from mjregen.grid import Robot
from mjregen.physics import MujocoPipeline, Physics, VoxelPipeline
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import Simulation, walk
from mjregen.physics.start_state import translational_coordinates
from mjregen.tasks.fitness import locomotion_fitness

INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}
END_SPEED = 2.0  # m/s: no voxel may move faster than this at the end of a stable run
SETTLE, WALK = 0.05, 0.1  # s, the shortened accuracy window


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
    perturb: voxel lengths, standard deviation of random shifts of every voxel's initial
    position (seed `seed`), to measure how far chaos carries a rounding-size difference.
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
    perturb: float = 0.0
    seed: int = 0


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
    """Run `run`: `mjregen.physics.simulation.walk` of a model whose integrator, step and
    initial state `run` may change; returns a dict of the outcome.

    Keys: stable, reason, dt, steps, cpu (s of stepping), com_end ((3,) m), distance (voxel
    lengths, planar COM displacement after the settle; NaN when the walk became unstable),
    fitness (`locomotion_fitness`), max_speed (m/s, fastest voxel at the end), qpos (the final
    state). A walk whose fastest voxel ends faster than END_SPEED is unstable too.
    """
    name = run.integrator or getattr(run.physics.pipeline, "integrator", "euler")
    # the voxel plugin starts the muscles at the scene's settle time
    # the exact start, then every voxel shifted by `perturb` voxel lengths (seed `seed`)
    # directly in the state: finer than a start's keyframe holds
    physics = run.physics.replace(settle_time=run.settle, start_shift=0.0)
    if name != "euler" and isinstance(physics.pipeline, VoxelPipeline):
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
    if run.perturb:
        positions = translational_coordinates(model)
        sim.data.qpos[positions] += np.random.default_rng(run.seed).normal(
            0.0, run.perturb * run.physics.scene.voxel_size, int(positions.sum()))
    result = walk(compiled, sim=sim, duration=run.measured)
    reason = result.reason
    speed = max_voxel_speed(model, sim.data)
    if not reason and not speed <= END_SPEED:
        reason = f"voxel speed {speed:.3g} m/s > {END_SPEED} m/s at the end"
    return {"stable": not reason, "reason": reason, "dt": dt, "steps": sim.steps,
            "cpu": result.cpu_time, "com_end": sim.com(), "distance": result.distance,
            "fitness": locomotion_fitness(result), "max_speed": speed,
            "qpos": sim.data.qpos.copy()}


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
