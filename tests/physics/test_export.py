"""The exported MJCF is the robot: plain MuJoCo (``mujoco`` and ``numpy`` only, plus the one
plugin-library call) steps it exactly as `mjregen walk` does, muscles included."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap

import mujoco
import numpy as np
import pytest

import mjregen
from mjregen.grid import Material, Robot
from mjregen.physics import Physics, box_physics, paper_physics, sphere_physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import Simulation, simulate, simulation_of

PAPER = "assets/robots/paper"
SLAB = np.ones((4, 3, 2), dtype=np.int8)
SLAB[:, :, 0] = np.where(np.arange(4)[:, None] % 2 == 0, 3, 4)
SLAB[1, 1, 1] = 2

# A separate Python process that imports only mujoco and numpy: load the plugin library,
# step the exported file with mj_step until the end of the walk, print the COM path.
PLAIN_MUJOCO = textwrap.dedent("""
    import json, sys
    import mujoco, numpy as np
    library, xml = sys.argv[1], sys.argv[2]
    settle, measured = float(sys.argv[3]), float(sys.argv[4])
    mujoco.mj_loadPluginLibrary(library)
    model = mujoco.MjModel.from_xml_path(xml)
    data = mujoco.MjData(model)
    if model.nkey:  # the start simulate walks from (every voxel moved by its seeded offset)
        mujoco.mj_resetDataKeyframe(model, data, model.key("start_0").id)
    dt = model.opt.timestep
    def com():
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        return data.subtree_com[0].tolist()
    mujoco.mj_step(model, data, nstep=round(settle / dt))
    start = com()
    mujoco.mj_step(model, data, nstep=round(measured / dt))
    print(json.dumps({"start": start, "end": com(), "qpos": data.qpos.tolist(),
                      "modules": sorted(m for m in sys.modules if m.split(".")[0] == "mjregen")}))
""")


def plain_mujoco(xml_path, settle: float, measured: float) -> dict:
    done = subprocess.run([sys.executable, "-c", PLAIN_MUJOCO, str(mjregen.plugin_library()),
                           str(xml_path), repr(settle), repr(measured)],
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


@pytest.mark.parametrize("name", ["tripod", "biped", "multiped"])
def test_paper_robot_walks_the_same_distance_in_plain_mujoco(name, tmp_path):
    """The must-show of the plugin design: the same distance and displacement (so the same
    heading) to 1e-6 voxel lengths."""
    robot = Robot.load(f"{PAPER}/{name}.npy")
    walked = simulate(robot)
    assert walked.stable
    xml = tmp_path / f"{name}.xml"
    xml.write_text(compile_robot(robot).to_xml())
    settle, measured = Physics().scene.timing(3)
    plain = plain_mujoco(xml, settle, measured)
    assert plain["modules"] == []  # mjregen was not imported
    move = np.subtract(plain["end"], plain["start"])[:2] / 1e-3
    assert np.linalg.norm(move) == pytest.approx(walked.distance, abs=1e-6)
    assert move == pytest.approx(np.asarray(walked.displacement), abs=1e-6)
    assert walked.distance > 20.0  # and it walked


PRESETS = {"default": Physics(), "tendons": Physics().replace(bond_element="tendons"),
           "paper": paper_physics()}


@pytest.mark.parametrize("preset", PRESETS)
@pytest.mark.parametrize("dim", [2, 3])
def test_exported_model_steps_like_simulate(preset, dim, tmp_path):
    """mj_step on the file = `simulate`'s trajectory (its fast path) to 1e-9 m, muscles on."""
    physics = PRESETS[preset].replace(settle_time=0.004)
    robot = Robot.from_body(SLAB if dim == 3 else SLAB[:, 1, :])
    compiled = compile_robot(robot, physics=physics)
    sim = simulation_of(compiled)
    assert sim.stepper is not None  # the fast path
    n = round(0.012 / compiled.timestep)
    assert sim.run(n) == ""
    xml = tmp_path / "robot.xml"
    xml.write_text(compiled.to_xml())
    plain = plain_mujoco(xml, 0.0, n * compiled.timestep)
    qpos = np.array(plain["qpos"])
    assert np.max(np.abs(qpos - sim.data.qpos)) < 1e-9
    assert np.max(np.abs(sim.data.qpos - compiled.model.qpos0)) > 1e-5  # it moved


@pytest.mark.parametrize("physics", [sphere_physics(), box_physics()], ids=["sphere", "box"])
@pytest.mark.parametrize("dim", [2, 3])
def test_pure_mujoco_presets_export_their_model(physics, dim):
    """The pure-MuJoCo pipeline's file is its model (tendons, contacts; muscles are its
    first tendons, driven by Simulation): loading it gives the same trajectory."""
    physics = physics.replace(settle_time=0.002)
    robot = Robot.from_body(SLAB if dim == 3 else SLAB[:, 1, :])
    compiled = compile_robot(robot, physics=physics)
    assert compiled.pipeline == "mujoco" and compiled.model.nplugin == 0
    plain = mujoco.MjModel.from_xml_string(compiled.to_xml())
    settle, _ = physics.scene.timing(dim)
    runs = []
    for model in (compiled.model, plain):
        sim = Simulation(model, physics=physics, muscles=compiled.muscles,
                         actuation_start=settle)
        assert sim.run(600) == ""
        runs.append(sim.data.qpos.copy())
    assert np.array_equal(runs[0], runs[1])


def test_exported_file_shows_bonds_and_muscles():
    robot = Robot.from_body(SLAB)
    compiled = compile_robot(robot)
    xml = compiled.to_xml()
    assert 'plugin="mjregen.voxels"' in xml
    assert 'material="muscle_plus"' in xml and 'material="muscle_minus"' in xml
    model = mujoco.MjModel.from_xml_string(xml)
    assert model.nplugin == 1 and model.npluginstate == robot.n_voxels  # the stick flags
    assert model.body("voxel_1_1_1").id > 0
    assert model.opt.timestep == compiled.timestep


L, G = 1e-3, 27.468  # the paper's voxel size (m) and gravity (m/s²)


def plain_model(robot: Robot, physics: Physics | None = None, **options) -> mujoco.MjModel:
    """The robot's exported MJCF, loaded by plain MuJoCo."""
    return mujoco.MjModel.from_xml_string(compile_robot(robot, physics=physics,
                                                        **options).to_xml())


def com_z(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    return float(data.subtree_com[0, 2])


def test_exported_block_falls_on_the_parabola():
    """Before touching the floor (drag off), semi-implicit Euler's free fall
    z₀ − g h² n(n+1)/2 exactly (to rounding), which is the parabola to within g·h·t."""
    model = plain_model(Robot.box((2, 2, 2)),
                        Physics().replace(drag_ratio=0.0), elevation=5 * L)
    data = mujoco.MjData(model)
    z0, h = com_z(model, data), model.opt.timestep
    n = round(0.01 / h)
    mujoco.mj_step(model, data, nstep=n)
    fallen = z0 - com_z(model, data)
    assert fallen == pytest.approx(G * h * h * n * (n + 1) / 2, rel=1e-9)
    assert fallen == pytest.approx(G * (n * h) ** 2 / 2, abs=G * h * n * h)
    assert np.allclose(data.qvel[2::6], -G * n * h, rtol=1e-9)


def test_exported_block_rests_on_the_floor_without_sinking():
    """A 3³ soft block settles on the engine floor: its bottom centres sit at L/2 less the
    floor spring's compression under a column's weight (3 m g / 2 E L), and it is still."""
    robot = Robot.box((3, 3, 3))
    model = plain_model(robot)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=round(0.3 / model.opt.timestep))
    mujoco.mj_kinematics(model, data)
    bottom = np.min(data.xpos[1:, 2])
    compression = 3 * 1e-3 * G / (2.0 * 1e7 * L)  # the column of three voxels on its spring
    assert bottom == pytest.approx(L / 2 - compression, abs=0.2 * compression)
    assert np.max(np.abs(data.qvel[:3])) < 1e-3 * L / 1.0  # < 0.001 voxel lengths per s
    bottom_layer = np.array([index[2] == 1 for index, _ in robot.voxels()])
    assert np.array_equal(data.plugin_state, bottom_layer.astype(float))  # they stick


def test_exported_hard_cantilever_sags_like_a_beam():
    """A clamped bar of 5 hard voxels, floor off: the tip's mean sag is the Euler–Bernoulli
    beam's Σ P x² (3ℓ − x) / 6EI (P = m g at the centres x = L..4L, I = L⁴/12) within
    0.8–1.25 (the sag oscillates about it: the first mode is lightly damped)."""
    grid = np.full((5, 1, 1), int(Material.HARD), np.int8)
    robot = Robot.from_body(grid)
    physics = Physics().replace(floor=False)
    model = plain_model(robot, physics, clamped=[(1, 1, 1)], elevation=0.01)
    data = mujoco.MjData(model)
    tip = model.body("voxel_5_1_1").id
    z0, h = model.body_pos[tip, 2], model.opt.timestep
    mujoco.mj_step(model, data, nstep=round(0.28 / h))
    sag = []
    for _ in range(round(0.02 / h)):
        mujoco.mj_step(model, data)
        mujoco.mj_kinematics(model, data)
        sag.append(z0 - data.xpos[tip, 2])
    x = np.arange(1, 5) * L
    theory = float(np.sum(1e-3 * G * x**2 * (3 * 4 * L - x) / (6 * 5e7 * L**4 / 12)))
    assert 0.8 * theory <= np.mean(sag) <= 1.25 * theory


def test_exported_file_refuses_other_integrators_and_bad_configuration():
    """The plugin's state and muscles advance per Euler step: an edited integrator is an
    error naming the cause, and so is a configuration number that does not parse."""
    xml = compile_robot(Robot.box((2, 2, 2))).to_xml()
    with pytest.raises(ValueError, match="integrator must be Euler"):
        mujoco.MjData(mujoco.MjModel.from_xml_string(
            xml.replace("<option ", '<option integrator="RK4" ')))
    with pytest.raises(ValueError, match="'bond_beta'"):
        mujoco.MjData(mujoco.MjModel.from_xml_string(
            xml.replace('key="bond_beta" value="', 'key="bond_beta" value="x')))


@pytest.mark.parametrize("key, value, message", [
    ("dim", "4", "mjregen.voxels: dim must be 2 or 3, got 4"),
    ("voxel_size", "0", "mjregen.voxels: voxel_size must be > 0"),
    ("waveform", "square", "waveform must be 'contract' or 'symmetric', got 'square'"),
    ("voxels", "voxel_9_9_9 voxel_1_1_2 voxel_1_2_1 voxel_1_2_2 voxel_2_1_1 voxel_2_1_2 "
     "voxel_2_2_1 voxel_2_2_2", "voxel 0 names body 'voxel_9_9_9', which the model does not have"),
    ("phase", "1 0", "attribute 'phase' has 2 numbers, needs 8"),
    ("bond_axis", "0 1 2 0 1 2 0 1 2 0 1 9", "attribute 'bond_axis': entry 11 is 9, needs an "
     "integer in [0, 2]"),
    ("friction_stop_time", "-1", "friction_stop_time must be >= 0"),
    ("collision_hops", "1001", "attribute 'collision_hops': entry 0 is 1001"),
    ("drag_rotational", "nan 0 0 0 0 0 0 0", "attribute 'drag_rotational': entry 0 is not a "
     "finite number"),
])
def test_each_part_of_the_plugin_configuration_is_checked(key, value, message):
    """A configuration the plugin cannot use is one error naming the attribute and what is
    wrong with it, whichever part of the configuration it is in."""
    xml = compile_robot(Robot.box((2, 2, 2))).to_xml()
    start = xml.index(f'key="{key}" value="') + len(f'key="{key}" value="')
    edited = xml[:start] + value + xml[xml.index('"', start):]
    with pytest.raises(ValueError, match=re.escape(message)):
        mujoco.MjData(mujoco.MjModel.from_xml_string(edited))
