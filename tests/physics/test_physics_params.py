"""Physics parameters: the paper's defaults, the time-step rule, the two pipelines, old
descriptions, and clear errors."""

import math

import pytest

from mjregen.grid import Material
from mjregen.physics import (
    PHYSICS_FORMAT,
    MaterialProperties,
    MujocoPipeline,
    Physics,
    PhysicsParameterError,
    Scene,
    VoxelPipeline,
    migrate_physics,
    paper_physics,
)
from mjregen.physics.migrate import REPLAYS_FORMATS_1_TO_3
from mjregen.physics.timestep import stiffest_bond_step


def test_defaults_are_the_papers():
    physics = Physics()
    soft, hard = physics.materials[Material.SOFT], physics.materials[Material.HARD]
    red, green = physics.materials[Material.MUSCLE_PLUS], physics.materials[Material.MUSCLE_MINUS]
    assert (soft.youngs_modulus, hard.youngs_modulus) == (1e7, 5e7)
    assert red.youngs_modulus == green.youngs_modulus == 1e7
    assert physics.voxel_mass(Material.SOFT) == pytest.approx(1e-3, rel=1e-12)  # 1 g
    assert (red.phase_sign, green.phase_sign) == (1, -1)
    assert red.strain_amplitude == green.strain_amplitude == 0.14
    assert not soft.is_muscle and red.is_muscle
    scene = physics.scene
    assert (scene.gravity, scene.frequency, scene.waveform) == (27.468, 40.0, "contract")
    assert scene.timing(3) == (0.05, 0.5) and scene.timing(2) == (1.0, 0.25)
    assert soft.shear_modulus == pytest.approx(1e7 / 2.7)
    # the voxel plugin with the engine's floor, beams, damping, self-collision and drag
    assert physics.pipeline == VoxelPipeline() and physics.pipeline.name == "voxel"
    voxel = physics.pipeline
    assert (voxel.bond_element, voxel.bond_model) == ("beam", "euler_bernoulli")
    assert (voxel.beam_law, voxel.beam_damping) == ("engine", "engine")
    assert scene.bond_damping_ratio == 0.5 and scene.drag_ratio == 0.001
    assert (voxel.floor_stiffness, voxel.floor_damping, voxel.friction_stop) == (
        2.0, 0.8, "momentum")
    assert (voxel.collision_radius, voxel.collision_stiffness, voxel.collision_damping,
            voxel.collision_hops) == (0.75, 1.0, 0.0, 3)
    assert voxel.drag_law == "engine"
    assert (voxel.timestep_rule, voxel.stepper) == ("network", "auto")
    assert physics == paper_physics()
    mujoco = MujocoPipeline()
    assert (mujoco.name, mujoco.contact_shape, mujoco.bond_model) == ("mujoco", "sphere", "timoshenko")
    assert (mujoco.contact_stiffness, mujoco.contact_damping, mujoco.collision_radius) == (2.0, 1.2, 0.0)
    assert (mujoco.integrator, mujoco.timestep_rule) == ("euler", "stiffest_bond")


def test_timestep_rule_is_the_euler_limit_of_the_damped_bond_network():
    """dt = safety · 2 (sqrt(1 + (ζr)²) − ζr) / (r sqrt(k/m)), r = 2.7 (Timoshenko) or
    2.7 sqrt(2.7) (shear-rigid, ν = 0.35); numbers worked by hand."""
    k_soft = 1e7 * 1e-3 / 1e-3
    step = stiffest_bond_step
    undamped = Physics(scene=Scene(timestep_safety=1.0, bond_damping_ratio=0.0),
                       pipeline=VoxelPipeline(bond_model="timoshenko"))
    assert step(undamped, k_soft) == pytest.approx(2 / 2.7 / math.sqrt(k_soft), rel=1e-12)
    timoshenko = undamped.replace(bond_damping_ratio=1.0)
    # ζr = 2.7: 2 (sqrt(8.29) − 2.7) / 2.7 = 2 (2.879236 − 2.7) / 2.7 = 0.132768
    assert step(timoshenko, k_soft) == pytest.approx(0.132768 / math.sqrt(k_soft), rel=1e-5)
    # the rule depends on the bond model, not on the pipeline
    assert step(timoshenko.replace(pipeline="mujoco"), k_soft) == step(timoshenko, k_soft)
    default = Physics().replace(bond_damping_ratio=0.4)  # shear-rigid, ζ 0.4, safety 0.75:
    # r = 4.4365, ζr = 1.7746
    assert step(default, k_soft) == pytest.approx(0.75 * 0.118271 / math.sqrt(k_soft),
                                                  rel=1e-4)
    assert step(default, 5 * k_soft) == pytest.approx(step(default, k_soft) / math.sqrt(5))
    half = default.replace(timestep_safety=0.375)
    assert step(half, 1e7) == pytest.approx(0.5 * step(default, 1e7), rel=1e-12)
    with pytest.raises(ValueError, match="stiffness_per_mass"):
        step(default, 0.0)


@pytest.mark.parametrize("kwargs, word", [
    (dict(youngs_modulus=0.0), "youngs_modulus"),
    (dict(youngs_modulus=-1e7), "youngs_modulus"),
    (dict(youngs_modulus=math.nan), "finite"),
    (dict(youngs_modulus=1e7, density=0.0), "density"),
    (dict(youngs_modulus=1e7, poisson_ratio=0.5), "poisson_ratio"),
    (dict(youngs_modulus=1e7, friction=-0.1), "friction"),
    (dict(youngs_modulus=1e7, friction=0.3), "kinetic_friction"),  # kinetic 0.5 > static 0.3
    (dict(youngs_modulus=1e7, kinetic_friction=-0.1), "kinetic_friction"),
    (dict(youngs_modulus=1e7, strain_amplitude=0.14), "muscle"),
    (dict(youngs_modulus=1e7, strain_amplitude=1.2, phase_sign=1), "strain_amplitude"),
    (dict(youngs_modulus=1e7, strain_amplitude=0.1, phase_sign=2), "phase_sign"),
    (dict(youngs_modulus="stiff"), "number"),
])
def test_bad_material_raises_naming_the_parameter(kwargs, word):
    with pytest.raises(PhysicsParameterError, match=word):
        MaterialProperties(**kwargs)


@pytest.mark.parametrize("kwargs, word", [
    (dict(voxel_size=0.0), "voxel_size"),
    (dict(gravity=math.inf), "finite"),
    (dict(frequency=-40.0), "frequency"),
    (dict(settle_time=-1.0), "settle_time"),
    (dict(timestep_safety=0.0), "timestep_safety"),
    (dict(timestep_safety=math.nan), "finite"),
    (dict(waveform="square"), "waveform"),
    (dict(floor=1), "floor"),
    (dict(bond_damping_ratio=-0.1), "bond_damping_ratio"),
    (dict(drag_ratio=-0.1), "drag_ratio"),
])
def test_bad_scene_raises_naming_the_parameter(kwargs, word):
    with pytest.raises(PhysicsParameterError, match=word):
        Scene(**kwargs)


@pytest.mark.parametrize("kwargs, word", [
    (dict(bond_element="springs"), "bond_element"),
    (dict(bond_model="rigid"), "bond_model"),
    (dict(floor_stiffness=0.0), "floor_stiffness"),
    # the engine floor is a penalty spring (the paper's: 2.0 E·L)
    (dict(floor_stiffness=None), "floor_stiffness must be a number"),
    (dict(floor_damping=-0.1), "floor_damping"),
    (dict(collision_radius=1.0), "collision_radius"),
    (dict(collision_radius=0.75, collision_hops=0), "collision_radius"),
    (dict(collision_radius=-0.1), "collision_radius"),
    (dict(collision_hops=-1), "collision_hops must be an integer"),
    (dict(collision_hops=1.5), "collision_hops must be an integer"),
    (dict(collision_stiffness=0.0), "collision_stiffness"),
    (dict(collision_damping=-1.0), "collision_damping"),
    (dict(friction_stop="never"), "friction_stop must be one of"),
    (dict(friction_stop_time=0.0), "friction_stop_time"),
    (dict(drag_law="fluid"), "drag_law must be one of"),
    (dict(beam_law="spring"), "beam_law must be one of"),
    (dict(beam_damping="rayleigh"), "beam_damping must be one of"),
    (dict(timestep_rule="fastest"), "timestep_rule"),
    (dict(stepper="fast"), "stepper must be one of"),
])
def test_bad_voxel_pipeline_raises_naming_the_parameter(kwargs, word):
    with pytest.raises(PhysicsParameterError, match=word):
        VoxelPipeline(**kwargs)


@pytest.mark.parametrize("kwargs, word", [
    (dict(integrator="implicitfast"), "integrator"),
    (dict(contact_timeconst=0.0), "contact_timeconst"),
    (dict(contact_dampratio=0.0), "contact_dampratio"),
    (dict(contact_width=0.0), "contact_width"),
    (dict(contact_shape="capsule"), "contact_shape"),
    (dict(contact_shape="engine"), "contact_shape"),  # the engine floor: the voxel pipeline
    (dict(contact_stiffness=0.0), "contact_stiffness"),
    (dict(contact_damping=-1.0), "contact_damping"),
    (dict(collision_radius=0.75), "collision_radius"),
    (dict(bond_model="rigid"), "bond_model"),
    (dict(timestep_rule="fastest"), "timestep_rule"),
])
def test_bad_mujoco_pipeline_raises_naming_the_parameter(kwargs, word):
    with pytest.raises(PhysicsParameterError, match=word):
        MujocoPipeline(**kwargs)


@pytest.mark.parametrize("pipeline, changes", [
    # the voxel plugin is stepped with Euler and has the engine floor, no contact shapes
    ("voxel", dict(integrator="rk4")),
    ("voxel", dict(contact_shape="point")),
    ("voxel", dict(contact_stiffness=2.0)),
    ("voxel", dict(self_collision=False)),  # format 1's switch: collision_radius 0 now
    # the pure-MuJoCo pipeline's bonds are always 8 tendons, stepped by mj_step
    ("mujoco", dict(bond_element="beam")),
    ("mujoco", dict(stepper="native")),
    ("mujoco", dict(floor_stiffness=2.0)),
])
def test_a_field_of_the_other_pipeline_is_refused(pipeline, changes):
    (name,) = changes
    with pytest.raises(PhysicsParameterError, match=f"{name}: not a field of the scene or of "
                                                    f"the {pipeline} pipeline"):
        Physics().replace(pipeline=pipeline, **changes)


def test_replace_with_an_unknown_field_names_both_field_sets():
    with pytest.raises(PhysicsParameterError) as voxel:
        Physics().replace(gravity=0.0, colour="red", contact_shape="box")
    message = str(voxel.value)
    assert message.startswith("colour, contact_shape: not a field of the scene or of the voxel")
    scene = "bond_damping_ratio, drag_ratio, floor, frequency, gravity, measured_time, " \
            "settle_rest, settle_time, start_shift, timestep_safety, voxel_size, waveform"
    assert f"scene: {scene};" in message
    assert "voxel: beam_damping, beam_law, bond_element, bond_model, collision_damping, " \
           "collision_hops, collision_radius, collision_stiffness, drag_law, floor_damping, " \
           "floor_stiffness, friction_stop, friction_stop_time, stepper, timestep_rule" \
           in message
    with pytest.raises(PhysicsParameterError) as mujoco:
        Physics().replace(pipeline="mujoco", bond_element="beam")
    message = str(mujoco.value)
    assert message.startswith("bond_element: not a field of the scene or of the mujoco")
    assert f"scene: {scene};" in message
    assert "mujoco: bond_model, collision_radius, contact_damping, contact_dampratio, " \
           "contact_shape, contact_stiffness, contact_timeconst, contact_width, integrator, " \
           "timestep_rule" in message
    with pytest.raises(PhysicsParameterError, match="pipeline must be one of"):
        Physics().replace(pipeline="fluid")


def test_replace_routes_fields_and_switches_pipelines():
    physics = Physics().replace(gravity=0.0, floor_stiffness=4.0, collision_radius=0.0)
    assert physics.scene == Scene(gravity=0.0)
    assert physics.pipeline == VoxelPipeline(floor_stiffness=4.0, collision_radius=0.0)
    # another pipeline starts from its own defaults; the scene is kept
    switched = physics.replace(pipeline="mujoco", contact_shape="point")
    assert switched.scene == physics.scene and switched.materials == physics.materials
    assert switched.pipeline == MujocoPipeline(contact_shape="point")
    # naming the current pipeline keeps its fields
    kept = switched.replace(pipeline="mujoco", integrator="rk4")
    assert kept.pipeline == MujocoPipeline(contact_shape="point", integrator="rk4")
    assert kept.replace(pipeline="voxel").pipeline == VoxelPipeline()
    # or a pipeline object, then changed
    given = Physics().replace(pipeline=MujocoPipeline(contact_shape="box"), contact_damping=0.8)
    assert given.pipeline == MujocoPipeline(contact_shape="box", contact_damping=0.8)
    with pytest.raises(PhysicsParameterError, match="pipeline must be VoxelPipeline"):
        Physics(pipeline="mujoco")
    with pytest.raises(PhysicsParameterError, match="scene must be a Scene"):
        Physics(scene=VoxelPipeline())


def test_physics_needs_every_material_and_copies_changes():
    materials = dict(Physics().materials)
    del materials[Material.HARD]
    with pytest.raises(PhysicsParameterError, match="HARD"):
        Physics(materials=materials)
    changed = Physics().replace(gravity=0.0)
    assert changed.scene.gravity == 0.0 and Physics().scene.gravity == 27.468
    with pytest.raises(PhysicsParameterError, match="gravity"):
        Physics().replace(gravity=-1.0)


def test_physics_pickles_and_round_trips_through_json():
    import json
    import pickle

    for physics in (Physics().replace(settle_time=0.2, bond_element="tendons",
                                      collision_radius=0.0, stepper="mujoco"),
                    Physics().replace(pipeline="mujoco", settle_time=0.2, integrator="rk4",
                                      contact_shape="box", contact_stiffness=None)):
        assert pickle.loads(pickle.dumps(physics)) == physics  # sent to worker processes
        values = physics.to_dict()
        assert values["format"] == PHYSICS_FORMAT == 6
        assert set(values) == {"format", "materials", "scene", "pipeline"}
        assert values["pipeline"]["name"] == physics.pipeline.name
        assert Physics.from_dict(json.loads(json.dumps(values))) == physics
        assert migrate_physics(values) == values  # today's format: nothing to migrate
    assert Physics.from_dict(Physics().to_dict()) == Physics()  # beams survive the trip
    broken = physics.to_dict()
    broken["materials"]["hard"]["youngs_modulus"] = -1.0
    with pytest.raises(PhysicsParameterError, match="youngs_modulus"):
        Physics.from_dict(broken)
    for key in ("scene", "pipeline"):
        broken = physics.to_dict()
        del broken[key]
        with pytest.raises(PhysicsParameterError, match="invalid physics"):
            Physics.from_dict(broken)
    broken = physics.to_dict()
    broken["pipeline"]["name"] = "fluid"
    with pytest.raises(PhysicsParameterError, match="invalid physics"):
        Physics.from_dict(broken)
    broken = physics.to_dict()
    broken["pipeline"]["bond_element"] = "beam"  # not a field of the MuJoCo pipeline
    with pytest.raises(PhysicsParameterError, match="invalid physics"):
        Physics.from_dict(broken)
    newer = physics.to_dict()
    newer["format"] = PHYSICS_FORMAT + 1
    with pytest.raises(PhysicsParameterError, match=f"format {PHYSICS_FORMAT + 1}"):
        Physics.from_dict(newer)


def test_format_5_leaves_the_settle_rest_to_the_body():
    """Format 5 had no settle rest: its descriptions read as unset (the body decides: the
    full settle for every robot but a sheet; a sheet's task reads the format, tests/tasks),
    so every run described then reads as it was written."""
    description = Physics().to_dict()
    description["format"] = 5
    del description["scene"]["settle_rest"]
    assert Physics.from_dict(description) == Physics()
    assert Physics().scene.settle_rest is None and Physics().scene.rest_threshold == 0.0


def test_descriptions_of_formats_1_to_3_are_refused_naming_the_version_that_reads_them():
    """Formats 1-3 (one without "format" is format 1) were written before the paper engine's
    laws were the voxel pipeline's options; no stored description is one any more, and the
    tagged mjregen replays them."""
    for version in (None, 1, 2, 3):
        described = Physics().to_dict()
        if version is None:
            del described["format"]
        else:
            described["format"] = version
        with pytest.raises(PhysicsParameterError,
                           match=f"format {version or 1} .*reads formats 4 to "
                                 f"{PHYSICS_FORMAT}; the mjregen at git tag "
                                 f"{REPLAYS_FORMATS_1_TO_3}"):
            Physics.from_dict(described)
    with pytest.raises(PhysicsParameterError, match="invalid physics"):
        migrate_physics({"materials": {}})


def test_timestep_shrinks_with_heavy_bond_damping():
    """Heavy damping limits like 1/(ζ r²): doubling a large ζ about halves the step."""
    k_per_m = 5e7 * 1e-3 / 1e-3
    zeta2 = stiffest_bond_step(Physics().replace(bond_damping_ratio=2.0), k_per_m)
    zeta4 = stiffest_bond_step(Physics().replace(bond_damping_ratio=4.0), k_per_m)
    assert zeta4 / zeta2 == pytest.approx(0.5, rel=0.02)
    assert stiffest_bond_step(Physics().replace(bond_damping_ratio=0.1), k_per_m) > \
        stiffest_bond_step(Physics(), k_per_m)


def test_descriptions_without_materials_or_of_a_newer_format_are_refused():
    with pytest.raises(PhysicsParameterError, match="invalid physics description"):
        Physics.from_dict({"scene": {"contact_shape": "engine"}})
    with pytest.raises(PhysicsParameterError, match="format 99"):
        Physics.from_dict({**Physics().to_dict(), "format": 99})
    with pytest.raises(PhysicsParameterError, match="pipeline must be"):
        Physics().replace(pipeline=None)


