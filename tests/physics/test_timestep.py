"""The bond network's fastest modes and the time step fitted to them
(`mjregen.physics.timestep`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mjregen.grid import Material, Robot
from mjregen.physics import MujocoPipeline, Physics, PhysicsParameterError, voxel_plugin
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulation_of
from mjregen.physics.timestep import (
    largest_eigenvalue,
    network_rates,
    own_damping_rates,
    rotational_dofs,
    stable_step,
    stiffest_bond_step,
    strain_stiffening,
)

pytestmark = pytest.mark.skipif(not voxel_plugin.available(),
                                reason="no C compiler for the voxel plugin")

NETWORK = Physics().replace(timestep_rule="network")
STIFFEST_BOND = Physics().replace(timestep_rule="stiffest_bond")


def _rates(robot: Robot, physics: Physics) -> tuple[float, float]:
    compiled = compile_robot(robot, physics=physics)
    return network_rates(compiled.model, voxel_size=physics.scene.voxel_size,
                         instance=compiled.plugin_instance)


@pytest.mark.parametrize("element", ["beam", "tendons"])
@pytest.mark.parametrize("bond_model", ["euler_bernoulli", "timoshenko"])
def test_two_voxels_fastest_mode_is_the_beam_theory_one(bond_model, element):
    """Two free voxels (mass m, inertia I = mL²/6) on one bond: the shear mode (both voxels
    turn by θ, their centres move apart sideways by Lθ/2: k_s (2u − Lθ)²/2 on masses 2m, 2I)
    has ω² = 5 k_s/m, the axial mode 2 E L/m, torsion 2 k_t/I, antisymmetric bending
    E L/m. Shear-rigid bonds (k_s = E L): 5 E L/m is the fastest; Timoshenko (k_s = G L,
    G = E/2(1+ν) = 0.37 E): the axial 2 E L/m is.

    Damping rates: the tendons' C = βK, β = 2ζ sqrt(m/(E L)), damp the fastest mode at
    β λ. The engine's beam damps the moments at half β: the shear mode's damping per mass,
    in units sqrt(E L/m) and (m, L) = 1, is [[2β', −β'], [−3β'', 1.5β'']] (β' = 2ζ,
    β'' = ζ: the force and the moment rows of M⁻¹K scaled), largest eigenvalue 3.5 at
    ζ = 0.5, k_s = E L; the axial mode's is 2ζ·2 = 2. The plugin's estimate (Lanczos, made
    for symmetric operators) is within 3 % of these (engine damping is not symmetric)."""
    physics = NETWORK.replace(bond_model=bond_model, bond_element=element, floor=False)
    hard = physics.materials[Material.HARD]
    robot = Robot.box((2, 1, 1), Material.HARD)
    k_over_m = hard.youngs_modulus * physics.scene.voxel_size / physics.voxel_mass(Material.HARD)
    expected = 5.0 * k_over_m if bond_model == "euler_bernoulli" else 2.0 * k_over_m
    stiffness, damping = _rates(robot, physics)
    assert stiffness == pytest.approx(expected, rel=1e-4)
    zeta = physics.scene.bond_damping_ratio
    if element == "tendons":
        beta = 2.0 * zeta / np.sqrt(k_over_m)
        assert damping == pytest.approx(beta * expected, rel=1e-4)
    else:
        assert zeta == 0.5
        rate = 3.5 if bond_model == "euler_bernoulli" else 2.0
        assert damping == pytest.approx(rate * np.sqrt(k_over_m), rel=0.03)


@pytest.mark.parametrize("bond_model", ["euler_bernoulli", "timoshenko"])
def test_two_voxels_with_their_rotations_held_have_only_sliding_modes(bond_model):
    """Two voxels on one beam bond, their rotations held (infinite rotational inertia):
    no shear mode turns them, so the fastest modes are the axial one, 2 E L/m, and, for
    shear-rigid bonds, the transverse one (k = 12 E I/L³ = E L with its ends held straight),
    2 E L/m as well; the Timoshenko bond's transverse spring is softer. Both are damped
    by the force rows (c = 2ζ sqrt(m k)): 2ζ·2 sqrt(E L/m)."""
    physics = NETWORK.replace(bond_model=bond_model, bond_element="beam", floor=False)
    hard = physics.materials[Material.HARD]
    compiled = compile_robot(Robot.box((2, 1, 1), Material.HARD), physics=physics)
    k_over_m = hard.youngs_modulus * physics.scene.voxel_size / physics.voxel_mass(Material.HARD)
    stiffness, damping = network_rates(compiled.model, voxel_size=physics.scene.voxel_size,
                                       instance=compiled.plugin_instance,
                                       held=rotational_dofs(compiled.model))
    assert stiffness == pytest.approx(2.0 * k_over_m, rel=1e-4)
    zeta = physics.scene.bond_damping_ratio
    assert damping == pytest.approx(2.0 * zeta * 2.0 * np.sqrt(k_over_m), rel=1e-4)
    with pytest.raises(PhysicsParameterError, match="held must be a"):
        network_rates(compiled.model, voxel_size=physics.scene.voxel_size,
                      instance=compiled.plugin_instance, held=np.zeros(3, dtype=bool))


def test_a_voxels_own_damping_is_its_bonds_damper_over_its_mass():
    """Two free voxels on one bond along x: voxel 0 moving along x alone works the axial
    damper c = β E L, β = 2ζ sqrt(m/(E L)), so its own rate C_xx/m is 2ζ sqrt(E L/m), the
    same for voxel 1; the two sideways dofs damp alike."""
    physics = NETWORK.replace(floor=False)
    hard = physics.materials[Material.HARD]
    compiled = compile_robot(Robot.box((2, 1, 1), Material.HARD), physics=physics)
    rates = own_damping_rates(compiled.model, voxel_size=physics.scene.voxel_size,
                              instance=compiled.plugin_instance)
    assert rates.shape == (12,)
    k_over_m = hard.youngs_modulus * physics.scene.voxel_size / physics.voxel_mass(Material.HARD)
    axial = 2.0 * physics.scene.bond_damping_ratio * np.sqrt(k_over_m)
    assert rates[0] == pytest.approx(axial, rel=1e-6)
    assert rates[6] == pytest.approx(axial, rel=1e-6)
    assert rates[1] == pytest.approx(rates[2], rel=1e-6)
    assert rates[1] > 0.0


def test_lanczos_finds_the_largest_eigenvalue():
    rng = np.random.default_rng(3)
    basis, _ = np.linalg.qr(rng.standard_normal((300, 300)))
    values = np.concatenate([rng.uniform(0.0, 1.0, 299), [1.3]])
    matrix = basis @ np.diag(values) @ basis.T
    assert largest_eigenvalue(lambda y: matrix @ y, 300) == pytest.approx(1.3, rel=1e-6)


SOFT, HARD, MINUS = Material.SOFT, Material.HARD, Material.MUSCLE_MINUS


@pytest.mark.parametrize("pieces", [
    [{(1, 1, 3): MINUS, (1, 1, 4): HARD}, {(6, 1, 5): MINUS, (6, 1, 6): MINUS},
     {(6, 2, 4): MINUS, (7, 2, 4): HARD}],
    [{(1, 1, 1): SOFT, (1, 1, 2): SOFT}, {(1, 4, 1): SOFT, (1, 5, 1): SOFT},
     {(7, 6, 7): SOFT, (7, 7, 6): SOFT, (7, 7, 7): SOFT}],
])
def test_a_robot_of_separate_pieces_steps_like_its_fastest_piece(pieces):
    # pieces apart: no bond joins them, so the fastest mode of the robot is its fastest
    # piece's (robots like these, grown in evolutions, once got 1e-11 and 7e-8 s steps)
    whole = np.zeros((9, 9, 9), dtype=np.int8)
    steps = []
    for piece in pieces:
        alone = np.zeros((9, 9, 9), dtype=np.int8)
        for cell, material in piece.items():
            whole[cell] = alone[cell] = material
        steps.append(compile_robot(Robot(alone), physics=NETWORK).timestep)
    assert compile_robot(Robot(whole), physics=NETWORK).timestep == pytest.approx(min(steps),
                                                                                 rel=0.02)


def test_a_failed_step_estimate_is_an_error_not_a_hang(monkeypatch):
    from mjregen.errors import CompileError
    from mjregen.physics import compile as compile_module

    monkeypatch.setattr(compile_module, "network_rule_rates", lambda *a: (1e20, 1e12))
    with pytest.raises(CompileError, match="time step estimate of this robot failed"):
        compile_robot(Robot.box((2, 1, 1)), physics=NETWORK)


def test_stable_step_is_semi_implicit_eulers_limit():
    # undamped: h ω = 2; damped: h²λ + 2hμ = 4
    assert stable_step(4.0, 0.0) == pytest.approx(1.0)
    h = stable_step(1e8, 3e4)
    assert h * h * 1e8 + 2 * h * 3e4 == pytest.approx(4.0)


def test_network_step_is_where_a_kicked_block_diverges():
    """A hard 3³ block, every voxel kicked: stable at 0.95 of the network's limit, diverges
    at 1.05 of it (the limit is neither loose nor unsafe; measured: stable at 1.0, diverges
    at 1.02, also for 4³, a two-voxel bar and a soft five-voxel rod)."""
    robot = Robot.box((3, 3, 3), Material.HARD)
    outcomes = {}
    for safety in (0.95, 1.05):
        physics = NETWORK.replace(timestep_safety=safety, floor=False, gravity=0.0)
        sim = simulation_of(compile_robot(robot, physics=physics))
        sim.data.qvel[:] = np.random.default_rng(0).normal(0.0, 0.01, sim.model.nv)  # m/s, rad/s
        outcomes[safety] = sim.run(3000) == ""
    assert outcomes == {0.95: True, 1.05: False}


def test_lengthening_muscles_stiffen_their_bonds_contracting_ones_do_not():
    """At the longest commanded rest length l = x L the tendons' axial law
    k0 + kd l²/(l² + D²) stiffens by x² (1 + D²/L²)/(x² + D²/L²) (the bonds' D² = 2 L²),
    the two-voxel shear mode by (2 + 3x²)/5: a ±14 % muscle bar (x = 1.14) by the larger of
    the two (1.18); the engine's linear axial spring does not stiffen, so there only the
    shear mode does."""
    robot = Robot.box((2, 1, 1), Material.MUSCLE_PLUS)
    physics = Physics().replace(beam_law="tendons")
    beams = compile_robot(robot, physics=physics).bonds.beams
    assert beams.axial_law[0, 2] == pytest.approx(2e-6)  # m², D² = 2 L²
    plus = physics.materials[Material.MUSCLE_PLUS]
    symmetric = physics.replace(waveform="symmetric")
    assert strain_stiffening(beams, physics.scene) == 1.0  # contract-only: shorter, softer
    extension = 1.0 + plus.strain_amplitude  # both voxels lengthen the bond
    axial = extension ** 2 * 3.0 / (extension ** 2 + 2.0)
    shear = (2.0 + 3.0 * extension ** 2) / 5.0
    assert strain_stiffening(beams, symmetric.scene) == pytest.approx(max(axial, shear),
                                                                      rel=1e-12)
    engine = compile_robot(robot).bonds.beams
    assert np.all(engine.axial_law[:, 1:] == 0.0)  # linear
    assert strain_stiffening(engine, symmetric.scene) == pytest.approx(shear, rel=1e-12)


def test_network_rule_is_the_voxel_pipelines_default():
    assert Physics().pipeline.timestep_rule == "network"
    assert MujocoPipeline().timestep_rule == "stiffest_bond"  # needs no C compiler


def test_network_rule_fits_the_step_to_the_robot():
    """A block's network of tendon-law beams is as stiff as the stiffest-bond rule assumes:
    about the same step (the engine's beams, with their softer torsion G·J/L, get a longer
    one: the rule is conservative for them); the paper's biped (hard voxels in thin legs)
    gets a longer one; a pure-MuJoCo build takes the step of the voxel plugin's tendons
    (without a floor: MuJoCo's contacts are not in the network)."""
    block = Robot.box((4, 4, 4), Material.HARD)
    biped = Robot.load("assets/robots/paper/biped.npy")
    tendon_law = {"beam_law": "tendons", "beam_damping": "stiffness_proportional",
                  "bond_damping_ratio": 0.4}
    ratio = {name: compile_robot(robot, physics=NETWORK.replace(**changes)).timestep
             / compile_robot(robot, physics=STIFFEST_BOND.replace(**changes)).timestep
             for name, robot, changes in (("block", block, tendon_law),
                                          ("engine block", block, {}),
                                          ("biped", biped, tendon_law))}
    assert 0.95 < ratio["block"] < 1.15
    assert ratio["engine block"] > 1.3
    assert ratio["biped"] > 1.6
    plugin = NETWORK.replace(bond_element="tendons", floor=False)
    for bond_model in ("euler_bernoulli", "timoshenko"):
        for floor in (False, True):  # MuJoCo's contacts are not in the network
            pure = plugin.replace(pipeline="mujoco", contact_shape="point", floor=floor,
                                  bond_model=bond_model, timestep_rule="network")
            assert compile_robot(biped, physics=pure).timestep == compile_robot(
                biped, physics=plugin.replace(bond_model=bond_model)).timestep
    # the engine floor's springs and dampers join the voxel pipeline's network: shorter
    assert compile_robot(biped, physics=plugin.replace(floor=True)).timestep < \
        compile_robot(biped, physics=plugin).timestep


def test_without_a_compiler_the_network_rule_says_so_and_the_mujoco_presets_still_run(
        monkeypatch, tmp_path):
    from mjregen.physics import NativeBuildError, sphere_physics

    # a process without the plugin library and without a C compiler to build it
    monkeypatch.setattr(voxel_plugin, "_library", None)
    monkeypatch.setattr(voxel_plugin, "library_path", lambda: tmp_path / "missing.so")
    monkeypatch.setattr(voxel_plugin, "_compiler", lambda: None)
    robot = Robot.box((2, 2, 2), Material.SOFT)
    with pytest.raises(NativeBuildError, match="C compiler"):
        compile_robot(robot, physics=NETWORK)  # the voxel pipeline needs the plugin
    # the pure-MuJoCo pipeline's network step would need the plugin's forces
    with pytest.raises(PhysicsParameterError, match="C compiler.*timestep_rule 'stiffest_bond'"):
        compile_robot(robot, physics=NETWORK.replace(pipeline="mujoco", contact_shape="point",
                                                     timestep_rule="network"))
    physics = sphere_physics()  # MuJoCo tendons and contacts, the stiffest-bond step
    assert physics.pipeline.timestep_rule == "stiffest_bond"
    compiled = compile_robot(robot, physics=physics)
    assert compiled.timestep == pytest.approx(
        stiffest_bond_step(physics, 1e7 * 1e-3 / physics.voxel_mass(Material.SOFT)), rel=1e-5)
    assert simulation_of(compiled).run(100) == ""


def test_compiled_robot_reports_the_rates_behind_its_step():
    """The network rule's (λ, μ) are kept with the compiled robot: the stored step is
    timestep_safety × stable_step(λ, μ) (rounded like MJCF). With the default bond damping
    (ζ = 0.4 per bond, stiffness-proportional: C = βK) the fastest mode is overdamped
    (μ > 2√λ): a mode's damping ratio grows with its frequency."""
    from mjregen.physics.rounding import round_like_mjcf

    compiled = compile_robot(Robot.box((3, 3, 3)),
                             physics=NETWORK)
    stiffness, damping = compiled.network_rates
    safety = NETWORK.scene.timestep_safety
    assert compiled.timestep == round_like_mjcf(safety * stable_step(stiffness, damping))
    assert damping > 2.0 * np.sqrt(stiffness)  # mode damping ratio above 1
    assert compile_robot(Robot.box((3, 3, 3)),
                         physics=STIFFEST_BOND).network_rates is None


def test_a_robot_without_hard_voxels_takes_nothing_from_the_hard_material():
    """The step is the robot's own network's: a soft block's step and motion do not depend
    on the hard material's modulus (the engine's rule would take its stiffest material's);
    one hard voxel in it shortens the step only as far as its own bonds need."""
    soft = Robot.box((3, 3, 3))
    physics = Physics().replace(settle_time=0.0)
    materials = dict(physics.materials)
    hard = materials[Material.HARD]
    materials[Material.HARD] = dataclasses.replace(hard, youngs_modulus=10 * hard.youngs_modulus)
    stiff = Physics(materials=materials, scene=physics.scene, pipeline=physics.pipeline)
    runs = []
    for p in (physics, stiff):
        compiled = compile_robot(soft, physics=p)
        sim = simulation_of(compiled)
        assert sim.run(2000) == ""
        runs.append((compiled.timestep, sim.data.qpos.copy()))
    assert runs[0][0] == runs[1][0] and np.array_equal(runs[0][1], runs[1][1])
    grid = soft.grid.copy()
    grid[tuple(np.argwhere(grid)[0])] = Material.HARD  # a corner voxel
    one_hard = compile_robot(Robot(grid), physics=physics).timestep
    assert one_hard < runs[0][0]
    assert one_hard > runs[0][0] / np.sqrt(5.0)  # not the hard material's step
