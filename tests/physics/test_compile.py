"""Compiler: model structure, placement, only what the robot needs, MJCF export."""

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjregen.errors import CompileError
from mjregen.grid import Material, Robot
from mjregen.physics import MaterialProperties, Physics, PhysicsParameterError
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import Simulation

ROBOTS = Path(__file__).resolve().parents[2] / "assets" / "robots"
L = 1e-3


def mujoco_physics(**changes) -> Physics:
    """The pure-MuJoCo pipeline as these tests built it from the old flat scene's defaults:
    shear-rigid bonds, contact damping 0.8, self-collision spheres of 0.625 L, the network
    time step (today's `MujocoPipeline` defaults differ)."""
    return Physics().replace(**{"pipeline": "mujoco", "bond_model": "euler_bernoulli",
                                "contact_damping": 0.8, "collision_radius": 0.625,
                                "timestep_rule": "network", **changes})


def config(compiled) -> dict:
    """The voxel plugin's configuration: attribute -> numbers (or the text itself)."""
    out = {}
    for key, value in compiled.spec.plugins[0].config.items():
        try:
            out[key] = np.array(value.split(), dtype=float)
        except ValueError:
            out[key] = value
    return out


def test_3d_structure_body_per_voxel_free_joint_8_tendons_per_bond():
    robot = Robot.box((3, 2, 2))  # 12 voxels, 20 bonds
    compiled = compile_robot(robot, physics=Physics().replace(collision_radius=0.0))
    model = compiled.model
    assert compiled.pipeline == "voxel" and compiled.plugin_instance == 0
    assert compiled.bonds.count == 2 * 2 * 2 + 3 * 2 * 1 + 3 * 1 * 2 == 20
    assert model.nbody == 12 + 1 and model.njnt == 12
    assert np.all(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    assert model.nplugin == 1 and model.ntendon == model.npair == model.nsite == 0
    assert compiled.bonds.tendons.count == 8 * 20
    assert np.all(np.bincount(compiled.bonds.tendons.bond) == 8)
    assert compiled.bonds.beams.count == 20
    assert model.nu == 0 and compiled.muscles is None  # no muscle machinery without muscles
    assert np.all(model.geom_contype == 0) and np.all(model.geom_conaffinity == 0)
    assert np.allclose(compiled.masses, 1e-3)
    names = [f"voxel_{x}_{y}_{z}" for x, y, z in compiled.voxel_index]
    assert [model.body(b).name for b in compiled.body_ids] == names
    assert [model.geom(model.body_geomadr[b]).name for b in compiled.body_ids] == names
    assert config(compiled)["voxels"].split() == names  # the plugin finds them by name
    # the pure-MuJoCo pipeline: the same bonds as MuJoCo tendons, contacts with the floor
    pure = compile_robot(robot, physics=mujoco_physics(collision_radius=0.0,
                                                       contact_shape="box"))
    assert pure.pipeline == "mujoco" and pure.plugin_instance is None
    assert pure.model.nplugin == 0 and pure.model.ntendon == 8 * 20
    assert pure.model.npair == 12  # voxel-floor pairs only
    assert [pure.model.body(b).name for b in pure.body_ids] == names


def test_voxel_pipeline_computes_floor_collision_and_drag_in_the_plugin():
    """Default physics: floor, self-collision (surface voxels more than 3 bonds apart,
    0.75 L spheres, spring E·L per voxel, undamped) and drag are the plugin's; the model has
    no contact geoms, no pairs, no viscosity, MuJoCo's contact stages off, and a stick flag
    per voxel in its plugin state. The pure-MuJoCo pipeline has MuJoCo's equivalents (point
    contacts, collision spheres, viscosity), the linear drag of the same size."""
    robot = Robot.box((3, 3, 3))  # 26 surface voxels + 1
    compiled = compile_robot(robot)
    model, values = compiled.model, config(compiled)
    assert model.npair == 0 and model.npluginstate == 27
    assert np.all(model.geom_contype == 0) and model.opt.viscosity == 0.0
    skipped = mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    assert model.opt.disableflags & skipped == skipped  # nothing for MuJoCo to collide
    centre = int(np.flatnonzero((compiled.voxel_index == 2).all(axis=1))[0])
    assert values["collides"].sum() == 26 and values["collides"][centre] == 0
    assert values["collision_radius"] == pytest.approx([0.75e-3])
    assert values["collision_stiffness"] == pytest.approx(np.full(27, 1e7 * 1e-3))
    assert np.all(values["collision_damping"] == 0.0) and values["collision_hops"] == [3.0]
    assert values["friction_stop"] == "momentum"
    assert values["floor"] == [1.0]
    assert values["floor_stiffness"] == pytest.approx(np.full(27, 2.0 * 1e7 * 1e-3))
    assert np.all(values["static_friction"] == 1.0)
    assert np.all(values["kinetic_friction"] == 0.5)
    # drag 2ζ sqrt(m E L) = 2·0.001·sqrt(1e-3 kg · 1e4 N/m) = 6.3246e-3 N s/m (c/m = 6.32/s);
    # on the rotation 2·10ζ sqrt(I E L³), I = m L²/6: 2.58199e-8 N m s (c/I = 155/s)
    assert values["drag_linear"] == pytest.approx(np.full(27, 6.3246e-3), rel=1e-5)
    assert values["drag_rotational"] == pytest.approx(np.full(27, 2.58199e-8), rel=1e-5)
    pure = compile_robot(robot, physics=mujoco_physics(contact_shape="point"))
    exported = pure.model
    assert exported.npair == 27 and exported.opt.disableflags == 0
    assert (exported.geom_contype == 1).sum() == 26
    # MuJoCo's Stokes drag on a box of edge L: 3π μ L (μ rounded to MJCF's 6 digits)
    assert 3 * math.pi * exported.opt.viscosity * L == pytest.approx(values["drag_linear"][0],
                                                                     rel=1e-6)


def test_geoms_carry_their_voxels_materials():
    robot = Robot.from_body(np.array([[[1, 2], [3, 4]], [[2, 1], [4, 3]]], dtype=np.int8))
    compiled = compile_robot(robot)
    model = compiled.model
    codes = robot.grid[tuple(compiled.voxel_index.T)]
    materials = [model.material(model.geom_matid[model.body_geomadr[b]]).name
                 for b in compiled.body_ids]
    names = {1: "soft", 2: "hard", 3: "muscle_plus", 4: "muscle_minus"}
    assert materials == [names[int(code)] for code in codes]


def test_2d_structure_slide_slide_hinge_4_tendons_per_bond():
    robot = Robot.box((3, 2))  # 6 voxels, 7 bonds
    compiled = compile_robot(robot)
    model = compiled.model
    assert model.njnt == 3 * 6 and model.nv == 3 * 6
    types = model.jnt_type.reshape(6, 3)
    assert np.all(types == [mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_SLIDE,
                            mujoco.mjtJoint.mjJNT_HINGE])
    assert np.allclose(model.jnt_axis.reshape(6, 3, 3)[0], [[1, 0, 0], [0, 0, 1], [0, 1, 0]])
    assert compiled.bonds.count == 7 and compiled.bonds.tendons.count == 4 * 7
    assert [model.body(b).name for b in compiled.body_ids] == \
        [f"voxel_{x}_{z}" for x, z in compiled.voxel_index]
    pure = compile_robot(robot, physics=mujoco_physics(contact_shape="box"))
    assert pure.model.ntendon == 4 * 7


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
    """At the lattice positions every tendon sits at its rest length (MuJoCo's tendons and
    the plugin's alike) and the beams exert no force: no drift."""
    robot = Robot.from_body(np.array([[[1, 2], [3, 4]], [[2, 1], [4, 3]]], dtype=np.int8))
    pure = compile_robot(robot, physics=mujoco_physics(contact_shape="box"))
    data = mujoco.MjData(pure.model)
    mujoco.mj_forward(pure.model, data)
    assert np.allclose(data.ten_length, pure.model.tendon_lengthspring[:, 0], rtol=1e-6)
    for element in ("tendons", "beam"):
        compiled = compile_robot(robot, physics=Physics().replace(
            bond_element=element, floor=False, drag_ratio=0.0))
        table, centres = compiled.bonds.tendons, compiled.model.body_pos[compiled.body_ids]
        sites = centres[table.ends] + table.offsets
        length = np.linalg.norm(sites[:, 1] - sites[:, 0], axis=1)
        assert np.allclose(length, table.rest, rtol=1e-6)
        data = mujoco.MjData(compiled.model)
        mujoco.mj_forward(compiled.model, data)
        # N; the tendons' values are rounded to MJCF's 6 digits (a voxel weighs 2.7e-2 N)
        assert np.abs(data.qfrc_passive).max() < (1e-4 if element == "tendons" else 1e-12)


def test_timestep_from_stiffest_bond_present():
    limit = Physics().replace(timestep_safety=1.0, timestep_rule="stiffest_bond",
                              bond_damping_ratio=0.4)
    soft, hard, lone = (compile_robot(Robot.from_body(body.astype(np.int8)), physics=limit)
                        for body in (np.ones((2, 1, 1)), np.full((2, 1, 1), 2), np.ones((1, 1, 1))))
    # Euler's limit for shear-rigid bonds at ζ 0.4 (tests/physics/test_physics_params.py):
    # 0.118271 / sqrt(E L / m), E = 1e7 Pa soft; a hard–hard bond is 5× stiffer
    assert soft.timestep == pytest.approx(0.118271 / math.sqrt(1e7), rel=1e-4)
    assert hard.timestep == pytest.approx(soft.timestep / math.sqrt(5), rel=1e-4)
    assert lone.timestep == pytest.approx(soft.timestep, rel=1e-5)
    default = compile_robot(Robot.box((2, 1, 1)),
                            physics=limit.replace(timestep_safety=0.75))
    assert default.timestep == pytest.approx(0.75 * soft.timestep, rel=1e-5)


@pytest.mark.parametrize("damping", ["stiffness_proportional", "engine"])
def test_default_timestep_is_075_of_the_networks_euler_limit(damping):
    """Two soft voxels on the floor. In the horizontal plane the bond's shear mode (u the
    voxels' opposite sideways shift, θ their common turn) has K = E L [[4, −2L], [−2L, L²]]
    on masses 2m, 2I = mL²/3 (ω² = 5 E L/m, tests/physics/test_timestep.py). In the vertical plane the
    floor (the engine's spring 2 E L and damper 0.8·2 sqrt(m E L) on each voxel's vertical
    motion) joins it. The bond's damping C = D K: D = β on every row (stiffness-
    proportional), or β on the force row and β/2 on the moment row (the engine's),
    β = 2ζ sqrt(m/(E L)); the axial mode (2 E L/m) is damped at 2β E L/m. The step is 0.75
    of Euler's limit h, h² λ + 2 h μ = 4, with λ, μ the largest eigenvalues of M⁻¹K, M⁻¹C
    (the plugin estimates the engine's non-symmetric μ within 3 %)."""
    physics = Physics().replace(beam_damping=damping)
    w2 = 1e7 * 1e-3 / physics.voxel_mass(1)  # E L / m, s⁻²
    beta = 2.0 * physics.scene.bond_damping_ratio / math.sqrt(w2)  # s
    rows = np.diag([beta, beta if damping == "stiffness_proportional" else beta / 2])
    inv_mass = np.diag([1.0 / 2.0, 3.0])  # 1/(2m), 1/(2I) in units of m = 1, L = 1
    bond = np.array([[4.0, -2.0], [-2.0, 1.0]]) * w2
    floor_k = np.diag([2.0 * 2.0 * w2, 0.0])  # two voxels' springs on u
    floor_c = np.diag([2.0 * 0.8 * 2.0 * math.sqrt(w2), 0.0])

    def largest(matrix: np.ndarray) -> float:
        return float(max(np.linalg.eigvals(matrix).real))

    lam = max(5.0 * w2, largest(inv_mass @ (bond + floor_k)))
    mu = max(largest(inv_mass @ rows @ bond), 2.0 * beta * w2,
             largest(inv_mass @ (rows @ bond + floor_c)))
    limit = (math.sqrt(mu * mu + 4.0 * lam) - mu) / lam
    default = compile_robot(Robot.box((2, 1, 1)),
                            physics=physics)
    exact = damping == "stiffness_proportional"
    assert default.timestep == pytest.approx(0.75 * limit, rel=1e-5 if exact else 0.03)


def test_muscle_tendons_come_first_and_cover_exactly_the_muscle_bonds():
    # soft-red-soft-soft bar: bonds 0-1 and 1-2 touch the muscle, 2-3 does not
    robot = Robot.from_body(np.array([[[1]], [[3]], [[1]], [[1]]], dtype=np.int8))
    compiled = compile_robot(robot, physics=mujoco_physics(contact_shape="box"))
    assert compiled.muscles is not None and compiled.muscles.count == 2 * 8
    assert np.allclose(compiled.muscles.weights, [0.07, 0.0])  # half of 0.14, red phase
    assert compiled.model.ntendon == 3 * 8
    bond = compiled.bonds.tendons.bond
    assert set(bond[:16]) == {0, 1} and set(bond[16:]) == {2}
    # the voxel plugin drives the same bonds itself: the first two, weights in its config
    plugin = compile_robot(robot)
    assert plugin.muscles is None
    assert np.allclose(plugin.bonds.beams.muscle_weights, [[0.07, 0.0], [0.07, 0.0]])
    codes = robot.grid[tuple(plugin.voxel_index.T)]
    assert (codes[plugin.bonds.beams.ends] == 3).any(axis=1).tolist() == [True, True, False]
    assert np.allclose(config(plugin)["bond_muscle"], [0.07, 0.0, 0.07, 0.0, 0.0, 0.0])


def test_bad_input_raises_clear_errors():
    with pytest.raises(CompileError, match="empty"):
        compile_robot(Robot(np.zeros((5, 5, 5), dtype=np.int8)))
    with pytest.raises(CompileError, match="8,000 voxels is larger than mjregen compiles"):
        compile_robot(Robot.box((20, 20, 20)))  # MuJoCo could not allocate it
    robot = Robot.box((2, 1, 1))
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
    # actuation from t = 0 so the muscles act within the short run
    compiled = compile_robot(Robot.load(ROBOTS / f"{name}.npy"),
                             physics=Physics().replace(settle_time=0.0))
    plain = mujoco.MjModel.from_xml_string(compiled.to_xml())  # the plugin is loaded
    assert plain.nplugin == 1 and plain.opt.timestep == compiled.timestep
    ours, exported = (Simulation(model, physics=compiled.physics,
                                 plugin_instance=compiled.plugin_instance)
                      for model in (compiled.model, plain))
    n = 1500
    a, b = np.empty((n, 3)), np.empty((n, 3))
    assert ours.run(n, com=a) == "" and exported.run(n, com=b) == ""
    assert np.array_equal(a, b)
    assert np.array_equal(ours.data.qpos, exported.data.qpos)
    assert np.ptp(a[:, 0]) > 0  # it did move


def test_point_contacts_and_collision_spheres_build_the_documented_geoms():
    """"point" contacts: a hidden plane at L/2 and a tiny sphere per voxel; a self-collision
    radius other than L/2 gets its own sphere; the exported file runs the same, its muscle
    tendons' rest lengths rewritten every step."""
    robot = Robot.load(ROBOTS / "bimorph_walker_3d.npy")
    physics = mujoco_physics(contact_shape="point", collision_radius=0.625)
    compiled = compile_robot(robot, physics=physics)
    model = compiled.model
    plane = model.geom("floor_centres")
    assert model.geom_pos[plane.id][2] == pytest.approx(0.5e-3, abs=2e-9)
    assert model.npair == robot.n_voxels
    assert all(model.pair_geom1 == plane.id)
    assert np.allclose(model.geom_size[model.pair_geom2, 0], 1e-9)
    collide = model.geom_contype > 0
    assert collide.any() and np.allclose(model.geom_size[collide, 0], 0.625e-3)
    assert model.nu == 0 and model.nplugin == 0
    plain = mujoco.MjModel.from_xml_string(compiled.to_xml())
    a, b = (Simulation(m, physics=physics, muscles=compiled.muscles, actuation_start=0.0)
            for m in (model, plain))
    assert a.run(500) == "" and b.run(500) == ""
    assert np.array_equal(a.data.qpos, b.data.qpos)
    driven = compiled.muscles.count
    assert not np.allclose(model.tendon_lengthspring[:driven, 0], compiled.bonds.tendons.rest[:driven])


@pytest.mark.parametrize("pipeline", ["voxel", "mujoco"])
def test_each_pipeline_builds_its_own_forces_and_driver(pipeline):
    """The voxel pipeline's model holds the plugin (instance 0) and no tendons, and the
    plugin drives its muscles; the MuJoCo pipeline's holds no plugin, its bonds are tendons
    and Python drives the muscle tendons."""
    robot = Robot(np.pad(np.full((2, 2, 2), int(Material.MUSCLE_PLUS), np.int8), 1))
    compiled = compile_robot(robot, physics=Physics().replace(pipeline=pipeline))
    voxel = pipeline == "voxel"
    assert compiled.pipeline == pipeline
    assert compiled.model.nplugin == int(voxel)
    assert compiled.plugin_instance == (0 if voxel else None)
    assert (compiled.model.ntendon == 0) == voxel
    assert (compiled.muscles is None) == voxel
    assert (Simulation(compiled.model, physics=compiled.physics,
                       plugin_instance=compiled.plugin_instance).stepper is None) != voxel
