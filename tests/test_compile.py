"""Compiler: model structure, placement, only what the robot needs, MJCF export."""

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjregen.compile import CompileError, compile_robot
from mjregen.grid import Material, Robot
from mjregen.physics import MaterialProperties, Physics, PhysicsParameterError
from mjregen.simulate import Simulation

ROBOTS = Path(__file__).resolve().parents[1] / "assets" / "robots"
L = 1e-3


def test_3d_structure_body_per_voxel_free_joint_8_tendons_per_bond():
    robot = Robot.from_body(np.ones((3, 2, 2), dtype=np.int8))  # 12 voxels, 20 bonds
    compiled = compile_robot(robot, physics=Physics().replace_scene(self_collision=False))
    model = compiled.model
    assert compiled.n_bonds == 2 * 2 * 2 + 3 * 2 * 1 + 3 * 1 * 2 == 20
    assert model.nbody == 12 + 1 and model.njnt == 12
    assert np.all(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    assert model.ntendon == 8 * 20
    assert model.npair == 12  # voxel-floor pairs only
    assert model.nu == 0 and compiled.muscles is None  # no muscle machinery without muscles
    assert np.all(model.geom_contype == 0) and np.all(model.geom_conaffinity == 0)
    assert np.allclose(compiled.masses, 1e-3)


def test_engine_contacts_are_native_no_mujoco_contacts_or_viscosity():
    """Default physics: floor, self-collision (surface voxels, 0.625 L spheres) and drag are
    computed natively (`EngineContacts`); the native model has no contact geoms, no pairs, no
    viscosity, and a stick flag per voxel in MjData.userdata. The exported tendon model
    keeps MuJoCo equivalents (point contacts, collision spheres, viscosity)."""
    robot = Robot.from_body(np.ones((3, 3, 3), dtype=np.int8))  # 26 surface voxels + 1
    compiled = compile_robot(robot)
    model, table = compiled.native_model, compiled.engine_contacts
    assert table is not None and model.npair == 0 and model.nuserdata == 27
    assert np.all(model.geom_contype == 0) and model.opt.viscosity == 0.0
    skipped = mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    assert model.opt.disableflags & skipped == skipped  # nothing for MuJoCo to collide
    assert table.surface.sum() == 26 and not table.surface[13]  # the centre voxel is inside
    assert table.collision_radius == pytest.approx(0.625e-3)
    assert table.stiffness == pytest.approx(np.full(27, 2.0 * 1e7 * 1e-3))
    assert np.all(table.static_friction == 1.0) and np.all(table.kinetic_friction == 0.5)
    # drag 2ζ sqrt(m E L) = 2·0.001·sqrt(1e-3 kg · 1e4 N/m) = 6.3246e-3 N s/m (c/m = 6.32/s)
    assert table.drag_linear == pytest.approx(6.3246e-3, rel=1e-5)
    exported = compiled.model
    assert exported.npair == 27 and exported.opt.viscosity > 0 and exported.opt.disableflags == 0
    assert (exported.geom_contype == 1).sum() == 26


def test_2d_structure_slide_slide_hinge_4_tendons_per_bond():
    robot = Robot.from_body(np.ones((3, 2), dtype=np.int8))  # 6 voxels, 7 bonds
    model = compile_robot(robot).model
    assert model.njnt == 3 * 6 and model.nv == 3 * 6
    types = model.jnt_type.reshape(6, 3)
    assert np.all(types == [mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_SLIDE,
                            mujoco.mjtJoint.mjJNT_HINGE])
    assert np.allclose(model.jnt_axis.reshape(6, 3, 3)[0], [[1, 0, 0], [0, 0, 1], [0, 1, 0]])
    assert model.ntendon == 4 * 7


def test_robot_starts_resting_on_floor_centred_at_origin():
    robot = Robot.load(ROBOTS / "bimorph_walker_3d.npy")
    compiled = compile_robot(robot)
    data = mujoco.MjData(compiled.model)
    mujoco.mj_forward(compiled.model, data)
    centres = data.xpos[compiled.body_ids]
    assert centres[:, 2].min() - L / 2 == pytest.approx(0.0, abs=1e-12)
    com = compiled.masses @ centres / compiled.masses.sum()
    assert np.allclose(com[:2], 0.0, atol=1e-12)
    raised = compile_robot(robot, elevation=2e-3).model
    assert raised.body_pos[1, 2] - compiled.model.body_pos[1, 2] == pytest.approx(2e-3)


def test_bonds_start_unstressed():
    """At the lattice positions every tendon sits at its rest length: no force, no drift."""
    robot = Robot.from_body(np.array([[[1, 2], [3, 4]], [[2, 1], [4, 3]]], dtype=np.int8))
    compiled = compile_robot(robot)
    data = mujoco.MjData(compiled.model)
    mujoco.mj_forward(compiled.model, data)
    assert np.allclose(data.ten_length, compiled.model.tendon_lengthspring[:, 0], rtol=1e-6)


def test_timestep_from_stiffest_bond_present():
    limit = Physics().replace_scene(timestep_safety=1.0, timestep_rule="stiffest_bond")
    soft, hard, lone = (compile_robot(Robot.from_body(body.astype(np.int8)), physics=limit)
                        for body in (np.ones((2, 1, 1)), np.full((2, 1, 1), 2), np.ones((1, 1, 1))))
    # Euler's limit for shear-rigid bonds at ζ 0.4 (tests/test_physics_params.py):
    # 0.118271 / sqrt(E L / m), E = 1e7 Pa soft; a hard–hard bond is 5× stiffer
    assert soft.timestep == pytest.approx(0.118271 / math.sqrt(1e7), rel=1e-4)
    assert hard.timestep == pytest.approx(soft.timestep / math.sqrt(5), rel=1e-4)
    assert lone.timestep == pytest.approx(soft.timestep, rel=1e-5)
    default = compile_robot(Robot.from_body(np.ones((2, 1, 1), dtype=np.int8)),
                            physics=limit.replace_scene(timestep_safety=0.75))
    assert default.timestep == pytest.approx(0.75 * soft.timestep, rel=1e-5)


def test_default_timestep_is_075_of_the_networks_euler_limit():
    """Two soft voxels on the floor. In the horizontal plane the bond's shear mode has
    ω² = 5 E L/m (tests/test_modes.py). In the vertical plane the floor (the engine's spring
    2 E L and damper 0.8·2 sqrt(m E L) on each voxel's vertical motion) joins it: with u the
    voxels' opposite vertical shift and θ their common turn, K = E L [[4 + 4, −2L], [−2L,
    L²]] on masses 2m, 2I = mL²/3, and C = β K_bond + floor. The step is 0.75 of Euler's
    limit h, h² λ + 2 h μ = 4, with λ, μ the largest eigenvalues of M⁻¹K, M⁻¹C."""
    w2 = 1e7 * 1e-3 / Physics().voxel_mass(1)  # E L / m, s⁻²
    beta = 2.0 * 0.4 / math.sqrt(w2)  # s: C = βK for the bond
    inv_mass = np.diag([1.0 / 2.0, 3.0])  # 1/(2m), 1/(2I) in units of m = 1, L = 1
    bond = np.array([[4.0, -2.0], [-2.0, 1.0]]) * w2
    floor_k = np.diag([2.0 * 2.0 * w2, 0.0])  # two voxels' springs on u
    floor_c = np.diag([2.0 * 0.8 * 2.0 * math.sqrt(w2), 0.0])
    lam = max(5.0 * w2, max(np.linalg.eigvals(inv_mass @ (bond + floor_k)).real))
    mu = max(5.0 * beta * w2, max(np.linalg.eigvals(inv_mass @ (beta * bond + floor_c)).real))
    limit = (math.sqrt(mu * mu + 4.0 * lam) - mu) / lam
    default = compile_robot(Robot.from_body(np.ones((2, 1, 1), dtype=np.int8)))
    assert default.timestep == pytest.approx(0.75 * limit, rel=1e-5)


def test_muscle_tendons_come_first_and_cover_exactly_the_muscle_bonds():
    # soft-red-soft-soft bar: bonds 0-1 and 1-2 touch the muscle, 2-3 does not
    robot = Robot.from_body(np.array([[[1]], [[3]], [[1]], [[1]]], dtype=np.int8))
    compiled = compile_robot(robot)
    assert compiled.muscles is not None and compiled.muscles.count == 2 * 8
    assert np.allclose(compiled.muscles.weights, [0.07, 0.0])  # half of 0.14, red phase
    assert compiled.model.ntendon == 3 * 8


def test_bad_input_raises_clear_errors():
    with pytest.raises(CompileError, match="empty"):
        compile_robot(Robot(np.zeros((5, 5, 5), dtype=np.int8)))
    robot = Robot.from_body(np.ones((2, 1, 1), dtype=np.int8))
    with pytest.raises(CompileError, match="not a voxel"):
        compile_robot(robot, clamped=[(0, 0, 0)])
    with pytest.raises(CompileError, match="elevation"):
        compile_robot(robot, elevation=-1e-3)
    materials = dict(Physics().materials)
    materials[Material.HARD] = MaterialProperties(youngs_modulus=5e7, poisson_ratio=0.2)
    mixed = Robot.from_body(np.array([[[1]], [[2]]], dtype=np.int8))
    with pytest.raises(PhysicsParameterError, match="Poisson"):
        compile_robot(mixed, physics=Physics(materials=materials))


@pytest.mark.parametrize("name", ["bimorph_walker_3d", "bimorph_walker_2d"])
def test_exported_xml_reproduces_the_trajectory_bit_for_bit(name):
    compiled = compile_robot(Robot.load(ROBOTS / f"{name}.npy"))
    plain = mujoco.MjModel.from_xml_string(compiled.to_xml())
    assert "mjregen" not in type(plain).__module__
    # actuation from t = 0 so the muscles act within the short run
    ours, exported = (Simulation(model, scene=compiled.physics.scene, muscles=compiled.muscles,
                                 actuation_start=0.0) for model in (compiled.model, plain))
    n = 1500
    a, b = np.empty((n, 3)), np.empty((n, 3))
    assert ours.run(n, com=a) == "" and exported.run(n, com=b) == ""
    assert np.array_equal(a, b)
    assert np.array_equal(ours.data.qpos, exported.data.qpos)
    assert np.ptp(a[:, 0]) > 0  # it did move


def test_new_contact_and_damping_options_build_the_documented_geoms_and_drives():
    """"point" contacts: a hidden plane at L/2 and a tiny sphere per voxel; a self-collision
    radius other than L/2 gets its own sphere; damp_strain_rate one drive per driven tendon."""
    robot = Robot.load(ROBOTS / "bimorph_walker_3d.npy")
    physics = Physics().replace_scene(contact_shape="point", self_collision=True,
                                      collision_radius=0.625, damp_strain_rate=True)
    compiled = compile_robot(robot, physics=physics)
    model = compiled.model
    plane = model.geom("floor_centres")
    assert model.geom_pos[plane.id][2] == pytest.approx(0.5e-3, abs=2e-9)
    assert model.npair == robot.n_voxels
    assert all(model.pair_geom1 == plane.id)
    assert np.allclose(model.geom_size[model.pair_geom2, 0], 1e-9)
    collide = model.geom_contype > 0
    assert collide.any() and np.allclose(model.geom_size[collide, 0], 0.625e-3)
    assert model.nu == compiled.muscles.count and compiled.muscles.damping is not None
    assert np.array_equal(compiled.muscles.damping, model.tendon_damping[: model.nu])
    plain = mujoco.MjModel.from_xml_string(compiled.to_xml())
    a, b = (Simulation(m, scene=physics.scene, muscles=compiled.muscles, actuation_start=0.0)
            for m in (model, plain))
    assert a.run(500) == "" and b.run(500) == ""
    assert np.array_equal(a.data.qpos, b.data.qpos) and np.any(a.data.ctrl != 0)
