"""Native stepper: MuJoCo's Euler step for voxel bodies, checked against mj_step and physics."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from mjregen.grid import Robot
from mjregen.physics import Physics, PhysicsParameterError, voxel_plugin
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import Simulation, simulate, simulation_of
from mjregen.physics.stepper import NativeStepper, unsupported
from mjregen.tasks.fitness import UNSTABLE_FITNESS, locomotion_fitness

pytestmark = pytest.mark.skipif(not voxel_plugin.available(),
                                reason="no C compiler for the voxel plugin")

SLAB = np.ones((4, 3, 2), dtype=np.int8)
SLAB[:, :, 0] = np.where(np.arange(4)[:, None] % 2 == 0, 3, 4)
SLAB[1, 1, 1] = 2
MUJOCO = Physics().replace(stepper="mujoco")
NATIVE = Physics().replace(stepper="native")
# the pure-MuJoCo pipeline as the old flat scene's defaults built it (MuJoCo's tendons and
# point contacts, shear-rigid bonds, damping 0.8, self-collision 0.625 L, the network step)
POINT = Physics().replace(pipeline="mujoco", contact_shape="point", bond_model="euler_bernoulli",
                          contact_damping=0.8, collision_radius=0.625, timestep_rule="network")


def _run(robot: Robot, physics: Physics, steps: int, **compile_options):
    sim = simulation_of(compile_robot(robot, physics=physics, **compile_options))
    assert (sim.stepper is not None) == (physics.pipeline.stepper != "mujoco")
    assert sim.run(steps) == ""
    return sim


@pytest.mark.parametrize("physics", [NATIVE, NATIVE.replace(bond_element="tendons")],
                         ids=["beams", "tendons"])
@pytest.mark.parametrize("grid", [SLAB, SLAB[:, 1, :]], ids=["3d", "2d"])
def test_same_motion_as_mj_step(grid, physics):
    """Settle 5 ms, then walk: 3000 steps with floor contacts, friction and muscles."""
    robot = Robot.from_body(grid)
    physics = physics.replace(settle_time=0.005)
    a = _run(robot, physics.replace(stepper="mujoco"), 3000)
    b = _run(robot, physics, 3000)
    assert b.data.time == pytest.approx(a.data.time, rel=1e-15)
    assert np.max(np.abs(a.data.qpos - b.data.qpos)) < 1e-12  # m (and quaternion units)
    assert np.max(np.abs(a.data.qvel - b.data.qvel)) < 1e-8 * max(1.0, np.max(np.abs(a.data.qvel)))
    assert np.max(np.abs(a.data.qpos - a.model.qpos0)) > 1e-5  # it did move


def test_clamped_voxels_stay_and_the_rest_moves_like_mj_step():
    robot = Robot.box((4, 1, 1), 2)
    root = next(iter(robot.voxels()))[0]
    physics = Physics().replace(floor=False)
    a = _run(robot, physics.replace(stepper="mujoco"), 2000, clamped=[root],
             elevation=2e-3)
    b = _run(robot, physics.replace(stepper="native"), 2000, clamped=[root],
             elevation=2e-3)
    assert np.max(np.abs(a.data.qpos - a.model.qpos0)) > 1e-6  # it sagged
    assert np.max(np.abs(a.data.qpos - b.data.qpos)) < 1e-12
    assert a.model.nbody - 1 == 4 and a.model.njnt == 3  # the clamped voxel has no joint


def test_free_fall_is_semi_implicit_euler():
    """No floor: after n steps z = z0 − g dt² n(n+1)/2 and v = −g n dt (exactly the Euler map)."""
    physics = NATIVE.replace(floor=False, drag_ratio=0.0, start_shift=0.0)
    sim = simulation_of(compile_robot(Robot.box((2, 2, 2), 1),
                                      physics=physics))
    z0 = sim.data.qpos[2]
    n, dt, g = 1000, sim.model.opt.timestep, physics.scene.gravity
    assert sim.run(n) == ""
    assert sim.data.qvel[2] == pytest.approx(-g * n * dt, rel=1e-12)
    assert sim.data.qpos[2] == pytest.approx(z0 - g * dt * dt * n * (n + 1) / 2, rel=1e-12)
    assert np.allclose(sim.data.qvel[3:6], 0.0, atol=1e-9)  # no spin from a uniform fall


def test_spin_about_a_fixed_axis_turns_by_omega_t():
    """A lone voxel spun about a body axis: the quaternion turns by ω·t (no gravity, floor)."""
    physics = NATIVE.replace(floor=False, gravity=0.0, drag_ratio=0.0)
    sim = simulation_of(compile_robot(Robot.box((1, 1, 1)),
                                      physics=physics))
    omega, n = 300.0, 4000  # rad/s
    sim.data.qvel[3:6] = [0.0, 0.0, omega]
    assert sim.run(n) == ""
    angle = omega * n * sim.model.opt.timestep
    quat = sim.data.qpos[3:7]
    assert np.linalg.norm(quat) == pytest.approx(1.0, abs=1e-12)
    expected = np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])
    assert min(np.max(np.abs(quat - expected)), np.max(np.abs(quat + expected))) < 1e-9


@pytest.mark.parametrize("turn", [1e-3, 0.15])  # rad per step: half turns below/above 0.05
def test_quaternion_update_equals_mujoco_at_any_turn_per_step(turn):
    """The stepper's quaternion update (a series for small turns, sin and cos above)
    equals MuJoCo's mju_quatIntegrate in mj_step, step by step."""
    physics = NATIVE.replace(floor=False, gravity=0.0, drag_ratio=0.0)
    model = compile_robot(Robot.box((1, 1, 1)), physics=physics).model
    ours, theirs = mujoco.MjData(model), mujoco.MjData(model)
    spin = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    for data in (ours, theirs):
        data.qvel[3:6] = spin * turn / model.opt.timestep  # rad/s, body frame
    stepper = NativeStepper(model, ours)
    for _ in range(20):
        assert stepper.step(1) == 1
        mujoco.mj_step(model, theirs)
        assert np.max(np.abs(ours.qpos - theirs.qpos)) < 1e-15
    assert abs(ours.qpos[3]) < math.cos(20 * turn / 2) + 1e-9  # it turned


@pytest.mark.parametrize("name", ["tripod", "biped"])
def test_paper_robot_walks_the_same_distance(name):
    robot = Robot(np.load(f"assets/robots/paper/{name}.npy"))
    a = simulate(robot, physics=MUJOCO, duration=0.1)
    b = simulate(robot, physics=NATIVE, duration=0.1, record=True)
    assert b.stable and b.steps == a.steps
    assert b.distance == pytest.approx(a.distance, rel=1e-8, abs=1e-9)
    assert a.distance > 1.0  # voxel lengths: it walked
    # the recorded centre of mass is MuJoCo's at the start of each step
    sim = simulation_of(compile_robot(robot, physics=NATIVE))
    assert b.com[0] == pytest.approx(sim.com(), abs=1e-15)


def test_default_uses_the_native_stepper_where_the_model_qualifies():
    robot = Robot.from_body(SLAB)
    compiled = compile_robot(robot)
    assert unsupported(compiled.model) == ""
    assert simulation_of(compiled).stepper is not None
    sim = simulation_of(compile_robot(robot, physics=POINT))  # MuJoCo tendons and contacts
    assert sim.stepper is None  # the pure-MuJoCo pipeline: always mj_step
    assert "plugin" in unsupported(sim.model)
    compiled.model.opt.disableflags = 0  # the voxel model with MuJoCo's contact stages on
    assert "contacts" in unsupported(compiled.model)
    assert simulation_of(compiled).stepper is None


def test_native_stepper_refuses_what_it_cannot_step():
    # the stepper is the voxel pipeline's: the pure-MuJoCo pipeline has none to choose
    with pytest.raises(PhysicsParameterError, match="stepper: not a field of the scene or of "
                                                    "the mujoco pipeline"):
        Physics().replace(pipeline="mujoco", stepper="native", contact_shape="point")
    with pytest.raises(PhysicsParameterError, match="stepper must be one of"):
        Physics().replace(stepper="fast")
    tendon_model = compile_robot(Robot.from_body(SLAB), physics=POINT).model  # pure MuJoCo
    assert unsupported(tendon_model)  # no plugin, MuJoCo contacts and tendons
    # stepper "native" on a model it cannot step: refused ("auto" falls back to mj_step)
    with pytest.raises(PhysicsParameterError, match="stepper 'native' cannot step this "
                                                    "model: the model has no voxel plugin"):
        Simulation(tendon_model, physics=NATIVE)
    assert Simulation(tendon_model, physics=Physics()).stepper is None
    contacts = compile_robot(Robot.from_body(SLAB), physics=NATIVE)
    contacts.model.opt.disableflags = 0  # MuJoCo's contact stages on
    with pytest.raises(PhysicsParameterError, match="stepper 'native' cannot step this "
                                                    "model: MuJoCo contacts"):
        simulation_of(contacts)
    with pytest.raises(ValueError, match="cannot step this model"):
        NativeStepper(tendon_model, mujoco.MjData(tendon_model))
    # what `unsupported` checks, the stepper checks again against MuJoCo's own mass matrix
    spec = compile_robot(Robot.from_body(SLAB)).spec
    spec.bodies[1].geoms[0].pos = [2e-4, 0.0, 0.0]  # centre of mass off the joint: coupled
    model = spec.compile()
    assert "centre of mass" in unsupported(model)
    with pytest.raises(ValueError, match="mass matrix"):
        NativeStepper(model, mujoco.MjData(model), checked=True)
    # a body that is not a voxel (a free ball): mj_step moves it, the stepper would not
    spec = compile_robot(Robot.from_body(SLAB)).spec
    ball = spec.worldbody.add_body(name="ball", pos=[0.0, 0.0, 0.01])
    ball.add_freejoint()
    ball.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[1e-3, 0, 0], mass=1e-3)
    model = spec.compile()
    assert unsupported(model) == ""  # free, isotropic, centred: only the voxel list tells
    with pytest.raises(PhysicsParameterError, match="not the voxel plugin's voxels"):
        Simulation(model, physics=NATIVE, plugin_instance=0)
    assert Simulation(model, physics=Physics(), plugin_instance=0).stepper is None
    sim = simulation_of(compile_robot(Robot.from_body(SLAB)))
    sim.data.xfrc_applied[1, 0] = 1e-3
    with pytest.raises(ValueError, match="xfrc_applied"):
        sim.run(10)


def test_qfrc_applied_acts_like_in_mj_step():
    physics = Physics().replace(floor=False, gravity=0.0)
    robot = Robot.from_body(SLAB)
    sims = [simulation_of(compile_robot(robot, physics=physics.replace(stepper=s)))
            for s in ("mujoco", "native")]
    for sim in sims:
        sim.data.qfrc_applied[0] = 1e-4  # N on the first voxel along x
        assert sim.run(500) == ""
    assert sims[1].data.qvel[0] > 1e-5  # m/s: it pushed
    assert np.max(np.abs(sims[0].data.qpos - sims[1].data.qpos)) < 1e-13


def test_bad_state_stops_and_is_reported_unstable():
    sim = simulation_of(compile_robot(Robot.from_body(SLAB)))
    sim.data.qvel[4] = np.nan
    reason = sim.run(1000)
    assert "mjWARN_BAD" in reason and sim.steps == 0
    sim = simulation_of(compile_robot(Robot.from_body(SLAB)))
    sim.data.qvel[4] = 1e11  # rad/s: beyond MuJoCo's bad-value bound
    assert "mjWARN_BAD" in sim.run(10)
    # an unstable time step is reported as unstable, not raised
    result = simulate(Robot.from_body(SLAB), physics=Physics().replace(timestep_safety=3.0))
    assert not result.stable and locomotion_fitness(result) == UNSTABLE_FITNESS[3] == -21.0
