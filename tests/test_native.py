"""Native bond backend: the same motion as the tendon model, per-MjData state, export."""

from __future__ import annotations

import gc
import threading

import mujoco
import numpy as np
import pytest

from mjregen import bonds_native
from mjregen.compile import compile_robot
from mjregen.grid import Robot
from mjregen.physics import Physics, PhysicsParameterError
from mjregen.simulate import simulate, simulation_of

pytestmark = pytest.mark.skipif(not bonds_native.available(),
                                reason="no C compiler for the native bond backend")

SLAB = np.ones((4, 3, 2), dtype=np.int8)
SLAB[:, :, 0] = np.where(np.arange(4)[:, None] % 2 == 0, 3, 4)
SLAB[1, 1, 1] = 2
# the tendon model (the exported MJCF) has MuJoCo contacts: compare backends on point contacts
# (the default "engine" floor exists only in the native loop; tests/test_engine_floor.py)
TENDONS = Physics().replace_scene(bond_element="tendons")  # what both backends compute
CONTACTS = TENDONS.replace_scene(contact_shape="point")


def _both(robot, physics, steps, clamped=(), elevation=0.0):
    """qpos, qvel after `steps` steps with each backend."""
    out = {}
    for backend in ("tendon", "native"):
        compiled = compile_robot(robot, physics=physics.replace_scene(bond_backend=backend),
                                 clamped=clamped, elevation=elevation)
        assert compiled.bond_backend == backend
        sim = simulation_of(compiled)
        assert sim.native == (backend == "native")
        assert sim.run(steps) == ""
        out[backend] = sim.data.qpos.copy(), sim.data.qvel.copy()
    return out


@pytest.mark.parametrize("physics", [
    CONTACTS,
    CONTACTS.replace_scene(damp_strain_rate=True),
    CONTACTS.replace_scene(waveform="symmetric", bond_model="timoshenko", self_collision=False),
], ids=["default", "strain_rate", "symmetric"])
@pytest.mark.parametrize("grid", [SLAB, SLAB[:, 1, :]], ids=["3d", "2d"])
def test_walking_robot_same_motion(grid, physics):
    """Settle 5 ms, then 1500 steps in all with muscles driven (~30 ms in 3D)."""
    physics = physics.replace_scene(settle_time=0.005)
    out = _both(Robot.from_body(grid), physics, 1500)
    (q_t, v_t), (q_n, v_n) = out["tendon"], out["native"]
    assert np.max(np.abs(q_t - q_n)) < 1e-12  # m (and quaternion units)
    assert np.max(np.abs(v_t - v_n)) < 1e-8 * max(1.0, np.max(np.abs(v_t)))


@pytest.mark.parametrize("dim", [2, 3])
def test_clamped_hard_cantilever_same_motion(dim):
    shape = (5, 1, 1) if dim == 3 else (5, 1)
    robot = Robot.from_body(np.full(shape, 2, dtype=np.int8))
    physics = TENDONS.replace_scene(floor=False)
    root = next(iter(robot.voxels()))[0]
    out = _both(robot, physics, 3000, clamped=[root], elevation=0.01)
    (q_t, v_t), (q_n, v_n) = out["tendon"], out["native"]
    assert np.max(np.abs(q_t)) > 1e-5  # it did sag
    assert np.max(np.abs(q_t - q_n)) < 1e-13
    assert np.max(np.abs(v_t - v_n)) < 1e-9


def test_simulate_results_agree_and_export_is_the_tendon_model():
    robot = Robot.from_body(SLAB)
    results = {b: simulate(robot, physics=CONTACTS.replace_scene(bond_backend=b),
                           duration=0.03) for b in ("tendon", "native")}
    assert results["native"].steps == results["tendon"].steps
    assert results["native"].distance == pytest.approx(results["tendon"].distance, rel=1e-6)
    compiled = compile_robot(robot, physics=TENDONS.replace_scene(bond_backend="native"))
    assert compiled.native_model.ntendon == 0 and compiled.native_model.nsite == 0
    assert compiled.model.ntendon == compiled.bonds.count == 8 * compiled.n_bonds
    plain = mujoco.MjModel.from_xml_string(compiled.to_xml())
    assert plain.ntendon == compiled.model.ntendon
    assert compiled.timestep == plain.opt.timestep


def test_state_is_per_data_and_released():
    gc.collect()
    before = bonds_native.registered()
    compiled = compile_robot(Robot.from_body(SLAB),
                             physics=TENDONS.replace_scene(bond_backend="native"))
    sims = [simulation_of(compiled) for _ in range(2)]
    assert bonds_native.registered() == before + 2
    # an unregistered MjData of the same model feels no bonds: it falls apart differently
    loose = mujoco.MjData(compiled.native_model)
    mujoco.mj_step(compiled.native_model, loose, nstep=300)
    for sim in sims:
        sim.run(300)
    assert np.array_equal(sims[0].data.qpos, sims[1].data.qpos)
    assert not np.allclose(loose.qpos, sims[0].data.qpos, atol=1e-7)
    del sims, sim
    gc.collect()
    assert bonds_native.registered() == before


def test_threads_give_the_serial_result():
    compiled = compile_robot(Robot.from_body(SLAB),
                             physics=TENDONS.replace_scene(bond_backend="native"))
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


def test_native_needs_euler():
    with pytest.raises(PhysicsParameterError, match="euler"):
        TENDONS.replace_scene(bond_backend="native", integrator="rk4")
    compiled = compile_robot(Robot.from_body(SLAB), physics=CONTACTS.replace_scene(
        integrator="rk4", bond_backend="auto"))
    assert compiled.bond_backend == "tendon"  # auto falls back


def test_skipping_mujocos_contact_stages_changes_nothing():
    """The default model disables MuJoCo's collision and constraint stages (everything that
    touches is native): stepping with them enabled gives bit-identical states."""
    compiled = compile_robot(Robot.load("assets/robots/paper/tripod.npy"),
                             physics=Physics().replace_scene(stepper="mujoco"))
    assert compiled.native_model.opt.disableflags != 0
    fast = simulation_of(compiled)
    assert fast.run(3000) == ""
    compiled.native_model.opt.disableflags = 0
    full = simulation_of(compiled)
    assert full.run(3000) == ""
    assert np.array_equal(fast.data.qpos, full.data.qpos)
    assert np.array_equal(fast.data.qvel, full.data.qvel)
