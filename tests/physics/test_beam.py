"""Beam bond elements (`VoxelPipeline.bond_element` "beam", the default): one co-rotated beam
per bond.

Mechanics against theory (axial, cantilever, shear, muscle strain) run for both elements in
tests/physics/test_physics_mechanics.py; here: with the tendons' law and damping the beam's linear
stiffness and damping equal the tendon bundle's, so does its law along the axis at large
strain; with the paper engine's (the default) its axial spring is linear, its torsion is
G·J/L and its dampers are the engine's; it exerts nothing under rigid motion, conserves
momentum (and angular momentum, but for the engine's moment damping), keeps mirror
symmetry, and is refused where it cannot run.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjregen.grid import Robot
from mjregen.physics import (
    MujocoPipeline,
    Physics,
    PhysicsParameterError,
    VoxelPipeline,
)
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulate, simulation_of

ROBOTS = Path(__file__).resolve().parents[2] / "assets" / "robots"


def block_robot(dim: int) -> Robot:
    """A small mixed block: soft, hard and both muscles, bonds along every axis."""
    body = np.array([[[1, 2], [3, 1]], [[4, 1], [1, 2]], [[1, 3], [2, 1]]], dtype=np.int8)
    return Robot.from_body(body if dim == 3 else body[:, 0, :])


TENDON_BEAMS = {"beam_law": "tendons", "beam_damping": "stiffness_proportional"}


def passive_forces(robot: Robot, element: str, qpos: np.ndarray, qvel: np.ndarray,
                   time: float = 0.0, **changes: object) -> tuple[np.ndarray, mujoco.MjData]:
    """qfrc_passive of the bonds alone (no floor, gravity, drag or self-collision)."""
    physics = Physics().replace(bond_element=element, floor=False, gravity=0.0,
                                drag_ratio=0.0, collision_radius=0.0, settle_time=0.0,
                                **changes)
    sim = simulation_of(compile_robot(robot, physics=physics))
    sim.data.qpos[:], sim.data.qvel[:], sim.data.time = qpos, qvel, time
    mujoco.mj_forward(sim.model, sim.data)
    return sim.data.qfrc_passive.copy(), sim.data


def plugin_model(robot: Robot) -> mujoco.MjModel:
    """The default (voxel plugin) model of `robot`: its dofs and rest state."""
    return compile_robot(robot, physics=Physics()).model


def split(linear: np.ndarray, angular: np.ndarray) -> np.ndarray:
    """A dof vector from per-voxel linear ``(n_voxels, 3 or 2)`` and angular ``(n_voxels, 3
    or 1)`` parts: 3D free joints (3 + 3), 2D (slide x, slide z, hinge y)."""
    return np.concatenate([linear, angular], axis=1).ravel()


def random_parts(model: mujoco.MjModel, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    n_linear = 3 if model.nq > model.nv else 2
    n = model.nv // (n_linear + (3 if n_linear == 3 else 1))
    return (rng.normal(size=(n, n_linear)),
            rng.normal(size=(n, model.nv // n - n_linear)))


def displaced(model: mujoco.MjModel, dq: np.ndarray) -> np.ndarray:
    qpos = model.qpos0.copy()
    mujoco.mj_integratePos(model, qpos, dq, 1.0)
    return qpos


@pytest.mark.parametrize("dim", [2, 3])
def test_linear_stiffness_and_damping_equal_the_tendon_bundles(dim):
    """Beams with the tendons' law and damping. Small displacements (1e-8 m ~ 1e-5 strain),
    rotations (1e-5 rad), velocities and angular velocities: the beam's force changes
    equal the tendons' to 1e-4 (the tendons' values are rounded to the 6 digits MJCF keeps,
    which leaves them ~2e-5 N at rest)."""
    robot = block_robot(dim)
    model = plugin_model(robot)
    zero = np.zeros(model.nv)
    rest = {e: passive_forces(robot, e, model.qpos0, zero, **TENDON_BEAMS)[0]
            for e in ("tendons", "beam")}
    assert np.abs(rest["beam"]).max() < 1e-12
    linear, angular = random_parts(model, np.random.default_rng(dim))
    cases = [(displaced(model, split(1e-8 * linear, 0 * angular)), zero),
             (displaced(model, split(0 * linear, 1e-5 * angular)), zero),
             (model.qpos0, split(1e-3 * linear, 0 * angular)),
             (model.qpos0, split(0 * linear, angular))]
    for qpos, qvel in cases:
        change = {e: passive_forces(robot, e, qpos, qvel, **TENDON_BEAMS)[0] - rest[e]
                  for e in rest}
        error = np.linalg.norm(change["beam"] - change["tendons"])
        assert error < 1e-4 * np.linalg.norm(change["tendons"])


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("strain", [-0.14, -0.05, 0.05, 0.10])
def test_axial_law_is_the_tendon_bundles(dim, strain):
    """beam_law "tendons": stretched or compressed far beyond the linear range (a muscle's
    14 %), a two-voxel bar pulls back with its tendons' force, which stiffens in tension and
    softens in compression (3D: +10 % at +10 %, −14 % at −14 % against E·L·strain)."""
    robot = Robot.box((2, 1, 1) if dim == 3 else (2, 1))
    model = plugin_model(robot)
    qpos = model.qpos0.copy()
    qpos[model.nq // 2] += strain * 1e-3  # second voxel's x
    forces = {e: passive_forces(robot, e, qpos, np.zeros(model.nv), **TENDON_BEAMS)[0]
              for e in ("tendons", "beam")}
    x = model.nv // 2  # second voxel's x force (the first voxel's is dof 0)
    beam = forces["beam"]
    assert beam[x] == pytest.approx(forces["tendons"][x], rel=2e-4)  # tendons: ~2e-5 N at rest
    assert beam[0] == -beam[x]
    assert np.abs(np.delete(beam, [0, x])).max() < 1e-12
    linear = -1e7 * 1e-3 * strain * 1e-3  # -E·L·(strain·L), N
    assert abs(beam[x] / linear - 1.0) > 0.02  # not Hookean


def world_wrench(data: mujoco.MjData, qfrc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(total force, total torque about the origin) in world axes of 3D free voxels."""
    force, torque = np.zeros(3), np.zeros(3)
    for body in range(1, data.xpos.shape[0]):
        f, tau_body = qfrc[6 * (body - 1): 6 * (body - 1) + 3], qfrc[6 * (body - 1) + 3: 6 * body]
        tau = data.xmat[body].reshape(3, 3) @ tau_body
        force += f
        torque += tau + np.cross(data.xpos[body], f)
    return force, torque


@pytest.mark.parametrize("law", ["engine", "tendons"])
@pytest.mark.parametrize("damping", ["engine", "stiffness_proportional"])
def test_large_deformation_conserves_momentum_and_angular_momentum(law, damping):
    """Bends of ~0.3 rad, strains of ~20 %, fast random velocities: the bonds' forces sum
    to zero and so do their moments about any point (to rounding), so a free robot can
    neither push nor spin itself — except through the engine's moment damping (half its
    force damping), which turns a moving robot's angular momentum but never at rest."""
    robot = block_robot(3)
    model = plugin_model(robot)
    rng = np.random.default_rng(7)
    linear, angular = random_parts(model, rng)
    qpos = displaced(model, split(2e-4 * linear, 0.3 * angular))
    moving = split(*random_parts(model, rng))
    for qvel in (moving, np.zeros(model.nv)):
        qfrc, data = passive_forces(robot, "beam", qpos, qvel, time=0.01, beam_law=law,
                                    beam_damping=damping)
        force, torque = world_wrench(data, qfrc)
        scale = np.abs(qfrc[:3]).max()
        assert scale > 1e-3  # the bonds are loaded
        assert np.abs(force).max() < 1e-12 * scale / 1e-3
        if damping == "stiffness_proportional" or qvel is not moving:
            assert np.abs(torque).max() < 1e-15 * scale / 1e-3
        else:
            assert np.abs(torque).max() > 1e-9 * scale / 1e-3


def test_rigid_motion_exerts_no_force():
    """A rotated (1.4 rad) and shifted robot spinning as a rigid body: no bond force."""
    robot = block_robot(3)
    model = plugin_model(robot)
    rotation = np.zeros(4)
    mujoco.mju_axisAngle2Quat(rotation, np.array([0.3, -0.8, 0.5]) / np.linalg.norm(
        [0.3, -0.8, 0.5]), 1.4)
    matrix = np.zeros(9)
    mujoco.mju_quat2Mat(matrix, rotation)
    matrix = matrix.reshape(3, 3)
    qpos, qvel = model.qpos0.copy(), np.zeros(model.nv)
    spin = np.array([3.0, -2.0, 5.0])  # rad/s, world
    for v in range(model.nv // 6):
        position = matrix @ model.qpos0[7 * v: 7 * v + 3] + [0.01, -0.02, 0.03]
        qpos[7 * v: 7 * v + 3], qpos[7 * v + 3: 7 * v + 7] = position, rotation
        qvel[6 * v: 6 * v + 3] = np.cross(spin, position)
        qvel[6 * v + 3: 6 * v + 6] = matrix.T @ spin  # body frame
    qfrc, _ = passive_forces(robot, "beam", qpos, qvel)
    assert np.abs(qfrc).max() < 1e-11


def test_mirror_symmetric_robot_stays_put_with_beams():
    """The beam is computed in the bond's mid frame, symmetric in its two voxels, so the
    mirror-symmetric in-phase robot does not move (1e-15 voxel lengths; tendons likewise)."""
    result = simulate(Robot.load(ROBOTS / "symmetric_inphase_3d.npy"),
                      physics=Physics().replace(bond_element="beam", start_shift=0.0))
    assert result.stable and result.distance < 1e-6


def test_beams_exist_in_the_voxel_pipeline_only_stepped_with_euler():
    """Beams are the voxel plugin's, which MuJoCo's Euler step integrates (the voxel pipeline
    has no integrator to choose); the pure-MuJoCo pipeline's bonds are always 8 tendons per
    bond, with either integrator."""
    for shape in ("box", "sphere", "point"):
        with pytest.raises(PhysicsParameterError, match="bond_element: not a field"):
            Physics().replace(pipeline="mujoco", contact_shape=shape, bond_element="beam")
        with pytest.raises(PhysicsParameterError, match="bond_element: not a field"):
            Physics().replace(pipeline="mujoco", contact_shape=shape, bond_element="tendons")
        valid = Physics().replace(pipeline="mujoco", contact_shape=shape, integrator="rk4")
        assert valid.pipeline == MujocoPipeline(contact_shape=shape, integrator="rk4")
    with pytest.raises(TypeError):
        MujocoPipeline(bond_element="beam")
    with pytest.raises(PhysicsParameterError, match="integrator: not a field"):
        Physics().replace(bond_element="beam", integrator="rk4")
    with pytest.raises(TypeError):
        VoxelPipeline(integrator="rk4")
    with pytest.raises(PhysicsParameterError, match="bond_element"):
        VoxelPipeline(bond_element="springs")
    robot = block_robot(3)
    for element in ("beam", "tendons"):
        model = compile_robot(robot, physics=Physics().replace(bond_element=element)).model
        assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
        assert model.nplugin == 1 and model.ntendon == 0
    pure = compile_robot(robot, physics=Physics().replace(pipeline="mujoco", integrator="rk4"))
    assert pure.model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    assert pure.model.nplugin == 0 and pure.model.ntendon == 8 * pure.bonds.count


def test_twist_moment_is_linear_in_the_angle_beyond_small_bends():
    """Two voxels, the second twisted about their common axis by θ (no displacement, no
    motion): the bond's only load is the torsion moment k_t θ (the rotation vector of
    q_i⁻¹ q_j is exact at any angle), equal and opposite on the two voxels. Past 35° the
    plugin leaves its series (accurate to 1e-7 below) for asin."""
    robot = Robot.box((2, 1, 1))
    model = plugin_model(robot)
    angles = np.array([0.1, 0.4, 0.6, 0.62, 0.9, 1.5, 2.5])  # rad; 2 asin(0.3) = 0.609
    ratios = []
    for angle in angles:
        qpos = model.qpos0.copy()
        mujoco.mju_axisAngle2Quat(qpos[10:14], np.array([1.0, 0.0, 0.0]), angle)
        qfrc, _ = passive_forces(robot, "beam", qpos, np.zeros(model.nv))
        first, second = qfrc[3:6], qfrc[9:12]  # body-frame moments (both turn about x)
        length = Physics().scene.voxel_size  # m: forces (N) against moment / L
        assert np.abs(qfrc[[0, 1, 2, 6, 7, 8]]).max() < 1e-12 * abs(second[0]) / length
        assert np.abs(second[1:]).max() < 1e-12 * abs(second[0])
        assert first[0] == pytest.approx(-second[0], rel=1e-12)
        ratios.append(-second[0] / angle)
    assert np.ptp(ratios) < 2e-7 * np.mean(ratios)


def two_voxels() -> tuple[Robot, mujoco.MjModel]:
    robot = Robot.box((2, 1, 1))
    return robot, plugin_model(robot)


@pytest.mark.parametrize("strain", [-0.14, -0.05, 0.05, 0.10])
def test_engine_beam_axial_spring_is_hookean(strain):
    """The paper engine's beam: the axial force is E·A·strain (E·L·ΔL) in tension and
    compression alike, to rounding, at a muscle's strains too."""
    robot, model = two_voxels()
    qpos = model.qpos0.copy()
    qpos[7] += strain * 1e-3  # second voxel's x
    qfrc, _ = passive_forces(robot, "beam", qpos, np.zeros(model.nv))
    E, L = 1e7, 1e-3
    assert qfrc[6] == pytest.approx(-E * L * strain * L, rel=1e-12)
    assert qfrc[0] == -qfrc[6]


def test_engine_beam_torsion_is_shear_modulus_times_polar_moment_over_length():
    """Twisted by θ about the bond axis, the pair resists with G·J/L·θ, J = L⁴/6 and
    G = E/(2(1+ν)) (the engine's a2), whatever the transverse model."""
    robot, model = two_voxels()
    E, nu, L, theta = 1e7, 0.35, 1e-3, 0.01
    expected = E / (2 * (1 + nu)) * L**4 / 6 / L * theta
    for bond_model in ("euler_bernoulli", "timoshenko"):
        qpos = model.qpos0.copy()
        mujoco.mju_axisAngle2Quat(qpos[10:14], np.array([1.0, 0.0, 0.0]), theta)
        qfrc, _ = passive_forces(robot, "beam", qpos, np.zeros(model.nv), bond_model=bond_model)
        assert -qfrc[9] == pytest.approx(expected, rel=1e-9)


def test_engine_beam_damping_halves_the_moments_ratio():
    """The engine's dampers, c = 2ζ sqrt(m k) on the force rows and half of it on the
    moment rows (ζ = 0.5), with its beam's stiffness rows (a1 = E·L, b2 = E·L²/2,
    b3 = E·L³/6, a2 = G·L³/6). A relative axial speed u meets 2ζ sqrt(m E L)·u. The second
    voxel turning at ω about z (bending) meets the moment ζ sqrt(m/(E L))·2·b3·ω and pushes
    its neighbour with the force 2ζ sqrt(m/(E L))·b2·ω; turning about the bond axis
    (torsion) it meets ζ sqrt(m/(G L))·a2·ω."""
    robot, model = two_voxels()
    E, nu, L, m, zeta = 1e7, 0.35, 1e-3, 1e-3, 0.5
    G = E / (2 * (1 + nu))
    u, omega = 0.01, 2.0
    qvel = np.zeros(model.nv)
    qvel[6] = u
    qfrc, _ = passive_forces(robot, "beam", model.qpos0, qvel)
    assert -qfrc[6] == pytest.approx(2 * zeta * np.sqrt(m * E * L) * u, rel=1e-9)
    beta = zeta * np.sqrt(m / (E * L))  # the moments' damping per stiffness
    qvel = np.zeros(model.nv)
    qvel[11] = omega  # second voxel about z (body frame = world at rest)
    qfrc, _ = passive_forces(robot, "beam", model.qpos0, qvel)
    assert -qfrc[11] == pytest.approx(beta * 2 * (E * L**3 / 6) * omega, rel=1e-9)
    assert abs(qfrc[7]) == pytest.approx(2 * beta * (E * L**2 / 2) * omega, rel=1e-9)
    qvel = np.zeros(model.nv)
    qvel[9] = omega  # about the bond axis x
    qfrc, _ = passive_forces(robot, "beam", model.qpos0, qvel)
    assert -qfrc[9] == pytest.approx(zeta * np.sqrt(m / (G * L)) * G * L**3 / 6 * omega,
                                     rel=1e-9)
    assert np.abs(qfrc[[6, 7, 8, 10, 11]]).max() < 1e-12 * abs(qfrc[9]) / L
