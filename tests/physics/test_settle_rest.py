"""The settle's rest (`Scene.settle_rest`): a robot at rest is held still until its muscles
start, in the plugin itself, so that mj_step and the native stepper hold it alike."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjregen.grid import Material, Robot, lay_flat
from mjregen.physics import Physics, PhysicsParameterError, voxel_plugin
from mjregen.physics.compile import compile_robot
from mjregen.physics.params import REST_WINDOW
from mjregen.physics.simulation import simulation_of, walk

pytestmark = pytest.mark.skipif(not voxel_plugin.available(),
                                reason="no C compiler for the voxel plugin")

# a small sheet: a 2D pattern of both muscle phases and a passive voxel, laid flat
PATTERN = np.array([[3, 3, 4], [3, 1, 4], [0, 4, 4]], dtype=np.int8)
SHEET = Robot(lay_flat(np.pad(PATTERN, 1)[None])[0])
REST = Physics().replace(settle_time=0.2, measured_time=0.05, settle_rest=1e-6)


def _xml(robot: Robot, physics: Physics) -> str:
    return compile_robot(robot, physics=physics).to_xml()


def _sim(robot: Robot, physics: Physics):
    return simulation_of(compile_robot(robot, physics=physics))


def _settle(sim, dt: float, settle: float) -> np.ndarray:
    """Step through the settle; the centre of mass (m) at each step's start ``(n, 3)``."""
    n = round(settle / dt)
    com = np.empty((n, 3))
    assert sim.run(n, com=com) == ""
    return com


def test_one_voxel_comes_to_rest_at_the_floor_springs_equilibrium_and_is_held_there():
    """A voxel dropped onto the engine floor (spring k = 2 E L on the centre's depth below
    L/2) rests at z = L/2 − m g / k; from the rest on its position is held exactly and its
    velocity is zero until the muscles start."""
    robot = Robot.box((1, 1, 1), Material.SOFT)
    physics = REST.replace(settle_time=0.1)
    sim = _sim(robot, physics)
    dt, L = sim.model.opt.timestep, physics.scene.voxel_size
    com = _settle(sim, dt, 0.1)
    props = physics.materials[Material.SOFT]
    mass = props.density * L ** 3
    k = physics.pipeline.floor_stiffness * props.youngs_modulus * L
    rest_z = L / 2 - mass * physics.scene.gravity / k
    moved = np.flatnonzero(np.any(com != com[-1], axis=1))
    assert 100 < moved[-1] < len(com) - 100  # it fell, then was held within the settle
    assert com[-1, 2] == pytest.approx(rest_z, rel=1e-9, abs=0)
    assert np.all(sim.data.qvel == 0.0)


@pytest.mark.parametrize("stepper", ["native", "mujoco"])
def test_a_sheet_held_at_rest_walks_as_after_the_full_settle(stepper):
    """At 1e-6 voxel lengths/s the state the hold keeps is the full settle's end state but
    for the residual motion: the walk after it moves by well under 1e-6 voxel lengths, and
    each stepper (the plugin's hold in mj_step, the skipped steps in the native one) gives
    it."""
    full = walk(compile_robot(SHEET, physics=REST.replace(settle_rest=0.0, stepper=stepper)))
    rested = walk(compile_robot(SHEET, physics=REST.replace(stepper=stepper)))
    assert full.stable and rested.stable and full.distance > 0.01
    assert rested.steps == full.steps
    assert abs(rested.distance - full.distance) < 1e-6


def test_mj_step_holds_the_robot_like_the_native_stepper():
    """Settle and walk with the hold: mj_step (the plugin's compute and advance) and the
    native stepper (which skips the held steps) reach the same state, to rounding."""
    native = _sim(SHEET, REST.replace(stepper="native"))
    plain = _sim(SHEET, REST.replace(stepper="mujoco"))
    n = round(0.25 / native.model.opt.timestep)
    assert native.model.opt.timestep == plain.model.opt.timestep
    assert native.run(n) == "" and plain.run(n) == ""
    assert native.data.time == plain.data.time
    assert np.max(np.abs(native.data.qpos - plain.data.qpos)) < 1e-12
    assert np.max(np.abs(native.data.qvel - plain.data.qvel)) < 1e-8 * np.max(np.abs(plain.data.qvel))
    n_voxels = SHEET.n_voxels
    flags = slice(0, n_voxels + 2)  # the stick flags, held, quiet
    assert np.array_equal(native.data.plugin_state[flags], plain.data.plugin_state[flags])
    assert plain.data.plugin_state[n_voxels] == 1.0  # it was held
    kept = slice(n_voxels + 3, None)  # the held positions
    assert np.max(np.abs(native.data.plugin_state[kept] - plain.data.plugin_state[kept])) < 1e-12


def test_a_robot_never_at_rest_steps_exactly_as_without_the_option():
    """A threshold no motion reaches: the rest is tracked but never begins, and every number
    is the full settle's."""
    never = walk(compile_robot(SHEET, physics=REST.replace(settle_rest=1e-300)))
    full = walk(compile_robot(SHEET, physics=REST.replace(settle_rest=0.0)))
    assert never.distance == full.distance and never.steps == full.steps


def test_the_rest_needs_the_whole_window():
    """A window longer than the settle: the robot is never held."""
    sim = _sim(SHEET, REST.replace(settle_time=REST_WINDOW / 2))
    _settle(sim, sim.model.opt.timestep, REST_WINDOW / 2)
    assert sim.data.plugin_state[SHEET.n_voxels] == 0.0


def test_the_model_text_holds_the_rest_only_when_it_is_on():
    """The exported MJCF carries the hold (plain MuJoCo with the plugin does it); without it
    the model text is what it was before the option existed."""
    on = _xml(SHEET, REST)
    off = _xml(SHEET, REST.replace(settle_rest=0.0))
    assert f'value="1e-06 {REST_WINDOW!r}"' in on and "settle_rest" not in off
    assert off == _xml(SHEET, REST.replace(settle_rest=None))
    model = mujoco.MjModel.from_xml_string(on)
    assert model.npluginstate == SHEET.n_voxels * (1 + 7) + 3


def test_bad_rest_settings_are_refused():
    with pytest.raises(PhysicsParameterError, match="settle_rest"):
        Physics().replace(settle_rest=-1.0)
    with pytest.raises(PhysicsParameterError, match="the mujoco pipeline settles for the full"):
        Physics().replace(pipeline="mujoco", settle_rest=1e-6)
    assert Physics().replace(pipeline="mujoco", settle_rest=0.0).scene.rest_threshold == 0.0
