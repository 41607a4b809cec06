"""Voxel plugin: the same motion as the pure-MuJoCo tendon model, per-MjData state."""

from __future__ import annotations

import copy
import shutil
import threading
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjregen.grid import Robot
from mjregen.physics import Physics, PhysicsParameterError, voxel_plugin
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulation_of

pytestmark = pytest.mark.skipif(not voxel_plugin.available(),
                                reason="no C compiler for the voxel plugin")

SLAB = np.ones((4, 3, 2), dtype=np.int8)
SLAB[:, :, 0] = np.where(np.arange(4)[:, None] % 2 == 0, 3, 4)
SLAB[1, 1, 1] = 2
# what both pipelines compute alike: tendon bonds, muscles and drag (the plugin's "stokes"
# drag is MuJoCo's viscosity on the voxel's box); the engine floor and the plugin's self-collision
# have no MuJoCo twin (tests/physics/test_engine_floor.py)
TENDONS = Physics().replace(bond_element="tendons", floor=False, collision_radius=0.0,
                            drag_law="stokes")


def mujoco_twin(physics: Physics, shape: str = "point") -> Physics:
    """The pure-MuJoCo pipeline with the voxel pipeline's bond model, self-collision radius
    and time-step rule (and its floor's spring and damper as the contacts')."""
    voxel = physics.pipeline
    return physics.replace(pipeline="mujoco", contact_shape=shape, bond_model=voxel.bond_model,
                           contact_stiffness=voxel.floor_stiffness,
                           contact_damping=voxel.floor_damping,
                           collision_radius=voxel.collision_radius,
                           timestep_rule=voxel.timestep_rule)


def _both(robot, physics, steps, clamped=(), elevation=0.0):
    """(qpos, qvel, largest bond strain) after `steps` steps with each pipeline: the
    voxel plugin (`physics`) and MuJoCo's tendons (its `mujoco_twin`)."""
    out, steps_of = {}, set()
    for pipeline, twin in (("voxel", physics), ("mujoco", mujoco_twin(physics))):
        compiled = compile_robot(robot, physics=twin, clamped=clamped, elevation=elevation)
        assert compiled.pipeline == pipeline
        sim = simulation_of(compiled)
        assert (sim.stepper is not None) == (pipeline == "voxel")
        assert sim.run(steps) == ""
        mujoco.mj_kinematics(sim.model, sim.data)
        centres = sim.data.xpos[compiled.body_ids]
        lengths = np.linalg.norm(np.diff(centres[compiled.bonds.beams.ends], axis=1)[:, 0], axis=1)
        strain = np.max(np.abs(lengths / physics.scene.voxel_size - 1.0))
        out[pipeline] = sim.data.qpos.copy(), sim.data.qvel.copy(), strain
        steps_of.add(compiled.timestep)
    assert len(steps_of) == 1  # the same bond network, the same time step
    return out


@pytest.mark.parametrize("physics", [
    TENDONS,
    TENDONS.replace(waveform="symmetric", bond_model="timoshenko"),
], ids=["default", "symmetric"])
@pytest.mark.parametrize("grid", [SLAB, SLAB[:, 1, :]], ids=["3d", "2d"])
def test_driven_robot_same_motion(grid, physics):
    """Settle 5 ms, then 1500 steps in all with muscles driven (~30 ms in 3D), falling."""
    physics = physics.replace(settle_time=0.005)
    out = _both(Robot.from_body(grid), physics, 1500)
    (q_v, v_v, strain), (q_m, v_m, _) = out["voxel"], out["mujoco"]
    assert strain > 1e-3  # the muscles work (a free fall alone strains nothing)
    assert np.max(np.abs(q_v - q_m)) < 1e-12  # m (and quaternion units)
    assert np.max(np.abs(v_v - v_m)) < 1e-8 * max(1.0, np.max(np.abs(v_m)))


@pytest.mark.parametrize("dim", [2, 3])
def test_clamped_hard_cantilever_same_motion(dim):
    shape = (5, 1, 1) if dim == 3 else (5, 1)
    robot = Robot.box(shape, 2)
    root = next(iter(robot.voxels()))[0]
    out = _both(robot, TENDONS, 3000, clamped=[root], elevation=0.01)
    (q_v, v_v, *_), (q_m, v_m, *_) = out["voxel"], out["mujoco"]
    assert np.max(np.abs(q_m - q_v)) < 1e-13
    assert np.max(np.abs(v_m - v_v)) < 1e-9
    rest = compile_robot(robot, physics=TENDONS, clamped=[root], elevation=0.01).model.qpos0
    assert np.max(np.abs(q_m - rest)) > 1e-5  # it did sag


def test_both_pipelines_hold_the_same_bond_tendons():
    """One `BondTable`: the voxel plugin's configuration and MuJoCo's tendons ``bond<b>_<t>``,
    8 per 3D bond; the plugin's model has no tendons or sites of its own."""
    robot = Robot.from_body(SLAB)
    voxel = compile_robot(robot, physics=TENDONS)
    mujoco_pipeline = compile_robot(robot, physics=mujoco_twin(TENDONS))
    assert voxel.model.nplugin == 1 and voxel.model.ntendon == voxel.model.nsite == 0
    table = voxel.bonds.tendons
    assert table.count == 8 * voxel.bonds.count and np.all(np.bincount(table.bond) == 8)
    config = voxel.spec.plugins[0].config
    for key, values in (("tendon_stiffness", table.stiffness), ("tendon_damping", table.damping),
                        ("tendon_rest", table.rest), ("tendon_bond", table.bond)):
        assert np.array_equal(np.array(config[key].split(), dtype=float), values)
    model = mujoco_pipeline.model
    assert model.nplugin == 0 and model.ntendon == table.count
    assert [model.tendon(t).name for t in range(model.ntendon)] == \
        [f"bond{b}_{t}" for t, b in enumerate(table.bond)]
    assert np.array_equal(model.tendon_stiffness, table.stiffness)
    assert np.array_equal(model.tendon_damping, table.damping)
    assert np.array_equal(model.tendon_lengthspring[:, 0], table.rest)
    for field in ("ends", "offsets", "stiffness", "damping", "rest", "bond", "lateral"):
        assert np.array_equal(getattr(mujoco_pipeline.bonds.tendons, field), getattr(table, field))


def test_state_is_per_data():
    """The floor's stick flags are each MjData's plugin_state: two MjData of one model step
    identically, a copy steps like its original, mj_forward changes no state, and the flags
    matter (a copy whose flags are cleared moves differently). With the energy stop rule:
    under the engine's rule a voxel the step stops has no speed left at all, and one
    without speed is at rest whatever its flag, so clearing the flags of a resting robot
    changes nothing there."""
    compiled = compile_robot(Robot.from_body(SLAB),
                             physics=Physics().replace(friction_stop="energy"))
    sims = [simulation_of(compiled) for _ in range(2)]
    for sim in sims:
        assert sim.run(300) == ""
    assert np.array_equal(sims[0].data.qpos, sims[1].data.qpos)
    data = sims[0].data
    assert compiled.model.npluginstate == len(compiled.voxel_index) and data.plugin_state.any()
    assert not mujoco.MjData(compiled.model).plugin_state.any()  # fresh: nothing sticks
    state = data.plugin_state.copy()
    mujoco.mj_forward(compiled.model, data)
    assert np.array_equal(data.plugin_state, state)
    twin, loose = copy.copy(data), copy.copy(data)
    loose.plugin_state[:] = 0.0
    for other in (data, twin, loose):
        mujoco.mj_step(compiled.model, other, nstep=300)
    assert np.array_equal(twin.qpos, data.qpos)
    assert not np.array_equal(loose.qpos, data.qpos)


def test_threads_give_the_serial_result():
    compiled = compile_robot(Robot.from_body(SLAB))
    serial = simulation_of(compiled)
    serial.run(800)
    sims = [simulation_of(compiled) for _ in range(2)]
    threads = [threading.Thread(target=sim.run, args=(800,)) for sim in sims]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for sim in sims:
        assert np.array_equal(sim.data.qpos, serial.data.qpos)


def test_engine_is_stepped_with_euler_mujoco_contacts_take_rk4():
    with pytest.raises(PhysicsParameterError, match="integrator: not a field of the scene or "
                                                    "of the voxel pipeline"):
        Physics().replace(integrator="rk4")
    assert compile_robot(Robot.from_body(SLAB)).model.opt.integrator == \
        mujoco.mjtIntegrator.mjINT_EULER
    compiled = compile_robot(Robot.from_body(SLAB), physics=Physics().replace(
        pipeline="mujoco", integrator="rk4", contact_shape="point"))
    assert compiled.pipeline == "mujoco" and compiled.plugin_instance is None
    assert compiled.model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4


def test_skipping_mujocos_contact_stages_changes_nothing():
    """The voxel model disables MuJoCo's collision and constraint stages (everything that
    touches is the plugin's): stepping with them enabled gives bit-identical states."""
    compiled = compile_robot(Robot.load("assets/robots/paper/tripod.npy"),
                             physics=Physics().replace(stepper="mujoco"))
    skipped = mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    assert compiled.model.opt.disableflags & skipped == skipped
    fast = simulation_of(compiled)
    assert fast.stepper is None and fast.run(3000) == ""
    compiled.model.opt.disableflags = 0
    full = simulation_of(compiled)
    assert full.run(3000) == ""
    assert np.array_equal(fast.data.qpos, full.data.qpos)
    assert np.array_equal(fast.data.qvel, full.data.qvel)


def test_a_compiler_without_march_native_builds_the_generic_library(tmp_path, monkeypatch):
    """A compiler that rejects -march=native (Apple's clang on arm64) gets the same build
    without it, instead of no plugin."""
    real = shutil.which("cc") or shutil.which("gcc")
    wrapper = tmp_path / "cc-without-march"
    wrapper.write_text("#!/bin/sh\nfor word in \"$@\"; do case $word in -march=*) "
                       "echo \"error: unsupported argument to option '-march='\" >&2; "
                       f"exit 1;; esac; done\nexec {real} \"$@\"\n")
    wrapper.chmod(0o755)
    monkeypatch.setenv("CC", str(wrapper))
    monkeypatch.setenv("MJREGEN_CACHE", str(tmp_path / "cache"))
    path = voxel_plugin.plugin_library()
    assert path.is_file() and path.parent == tmp_path / "cache"


LOAD_AND_WALK = ("import sys; from mjregen.grid import Robot; "
                 "from mjregen.physics.simulation import simulate; "
                 "print(simulate(Robot.load(sys.argv[1]), duration=0.01).stable)")


def test_a_damaged_cached_library_is_built_again_not_loaded(tmp_path):
    """A truncated library (a full disk, a build killed while copying) would crash the
    process that loads it: its bytes no longer match the digest written beside it, so it is
    built again, and leftover build folders of killed builds are cleared."""
    import os
    import subprocess
    import sys

    built = voxel_plugin.plugin_library()
    cache = tmp_path / "cache"
    cache.mkdir()
    copy = cache / built.name
    copy.write_bytes(built.read_bytes()[: len(built.read_bytes()) // 3])
    (cache / (built.name + ".sha256")).write_text((built.parent / (built.name + ".sha256"))
                                                  .read_text())
    stale = cache / "tmpkilledbuild"
    stale.mkdir()
    os.utime(stale, (0, 0))
    env = {**os.environ, "MJREGEN_CACHE": str(cache)}
    done = subprocess.run([sys.executable, "-c", LOAD_AND_WALK,
                           "assets/robots/bimorph_walker_3d.npy"], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0 and done.stdout.strip() == "True", done.stderr
    assert copy.stat().st_size == built.stat().st_size and not stale.exists()


def test_a_cache_folder_that_cannot_be_written_is_one_clear_error(tmp_path):
    import os
    import subprocess
    import sys

    blocker = tmp_path / "not_a_folder"
    blocker.write_text("")
    env = {**os.environ, "MJREGEN_CACHE": str(blocker)}
    done = subprocess.run([sys.executable, "-m", "mjregen", "walk",
                           "assets/robots/bimorph_walker_3d.npy", "--duration", "0.01"],
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 1
    assert done.stderr.count("\n") == 1 and "cannot be written" in done.stderr
    assert "set $MJREGEN_CACHE to a writable folder" in done.stderr


def test_an_empty_or_relative_cache_variable_gives_an_absolute_folder(tmp_path, monkeypatch):
    """The loader is handed an absolute path (a relative one it would look up elsewhere);
    an empty variable counts as unset."""
    from mjregen.physics.plugin_cache import library_path

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MJREGEN_CACHE", "rel")
    assert library_path().parent == tmp_path / "rel"
    monkeypatch.setenv("MJREGEN_CACHE", "")
    monkeypatch.setenv("XDG_CACHE_HOME", "")
    assert library_path().parent == Path.home() / ".cache" / "mjregen"


def test_the_writer_and_the_headers_attribute_table_agree():
    """Every attribute the MJCF writer sets is declared in voxels.h's table, and every
    declared one is written by the beam or the tendon configuration, the settle rest's when
    it is on (a new parameter is a table entry and a writer entry, or this fails)."""
    robot = Robot.from_body(SLAB)
    written = set()
    for physics in (Physics(), TENDONS.replace(settle_rest=1e-6)):
        written |= set(compile_robot(robot, physics=physics).spec.plugins[0].config)
    assert written == set(voxel_plugin.ATTRIBUTES)
    assert len(voxel_plugin.ATTRIBUTES) == len(set(voxel_plugin.ATTRIBUTES))


def test_a_header_without_the_attribute_table_is_a_clear_error(tmp_path):
    header = tmp_path / "voxels.h"
    header.write_text("#define SOMETHING_ELSE 1\n")
    with pytest.raises(voxel_plugin.NativeBuildError, match="MJR_ATTRIBUTES"):
        voxel_plugin.declared_attributes(header)
