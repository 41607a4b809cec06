"""Physics parameters: the paper's defaults, the time-step rule, and clear errors."""

import math

import pytest

from mjregen.grid import Material
from mjregen.physics import MaterialProperties, Physics, PhysicsParameterError, Scene


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


def test_timestep_rule_is_the_euler_limit_of_the_damped_bond_network():
    """dt = safety · 2 (sqrt(1 + (ζr)²) − ζr) / (r sqrt(k/m)), r = 2.7 (Timoshenko) or
    2.7 sqrt(2.7) (shear-rigid, ν = 0.35); numbers worked by hand."""
    k_soft = 1e7 * 1e-3 / 1e-3
    undamped = Physics(scene=Scene(timestep_safety=1.0, bond_damping_ratio=0.0,
                                   bond_model="timoshenko"))
    assert undamped.timestep(k_soft) == pytest.approx(2 / 2.7 / math.sqrt(k_soft), rel=1e-12)
    timoshenko = undamped.replace_scene(bond_damping_ratio=1.0)
    # ζr = 2.7: 2 (sqrt(8.29) − 2.7) / 2.7 = 2 (2.879236 − 2.7) / 2.7 = 0.132768
    assert timoshenko.timestep(k_soft) == pytest.approx(0.132768 / math.sqrt(k_soft), rel=1e-5)
    default = Physics()  # shear-rigid, ζ 0.4, safety 0.75: r = 4.4365, ζr = 1.7746
    assert default.timestep(k_soft) == pytest.approx(0.75 * 0.118271 / math.sqrt(k_soft),
                                                     rel=1e-4)
    assert default.timestep(5 * k_soft) == pytest.approx(default.timestep(k_soft) / math.sqrt(5))
    half = default.replace_scene(timestep_safety=0.375)
    assert half.timestep(1e7) == pytest.approx(0.5 * default.timestep(1e7), rel=1e-12)


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
    (dict(integrator="implicitfast"), "integrator"),
    (dict(contact_timeconst=0.0), "contact_timeconst"),
    (dict(floor=1), "floor"),
    (dict(contact_shape="capsule"), "contact_shape"),
    (dict(collision_radius=0.75), "collision_radius"),
    # the voxel plugin (contact_shape "engine") is stepped with Euler and has a penalty floor
    (dict(integrator="rk4"), "integrator 'euler'"),
    (dict(contact_stiffness=None), "contact_stiffness"),
    # beams and the native stepper exist in the voxel pipeline only
    (dict(contact_shape="box"), "bond_element 'beam'"),
    (dict(contact_shape="point", bond_element="tendons", stepper="native"), "stepper 'native'"),
])
def test_bad_scene_raises_naming_the_parameter(kwargs, word):
    with pytest.raises(PhysicsParameterError, match=word):
        Scene(**kwargs)


def test_physics_needs_every_material_and_copies_changes():
    materials = dict(Physics().materials)
    del materials[Material.HARD]
    with pytest.raises(PhysicsParameterError, match="HARD"):
        Physics(materials=materials)
    changed = Physics().replace_scene(gravity=0.0)
    assert changed.scene.gravity == 0.0 and Physics().scene.gravity == 27.468
    with pytest.raises(PhysicsParameterError, match="gravity"):
        Physics().replace_scene(gravity=-1.0)


def test_physics_pickles_and_round_trips_through_json():
    import json
    import pickle

    physics = Physics().replace_scene(settle_time=0.2, integrator="rk4",
                                      contact_shape="sphere", bond_element="tendons")
    assert pickle.loads(pickle.dumps(physics)) == physics  # sent to worker processes
    assert Physics.from_dict(json.loads(json.dumps(physics.to_dict()))) == physics
    assert Physics.from_dict(Physics().to_dict()) == Physics()  # beams survive the trip
    # descriptions written before beam bonds existed (runs, manifests) meant tendon bonds
    old = Physics().to_dict()
    old.pop("format", None)  # ... and before description formats
    del old["scene"]["bond_element"]
    tendons = Physics.from_dict(old)
    assert tendons.scene.bond_element == "tendons"
    # ... and they may name how bonds were computed (now the pipeline's choice) or the
    # strain-rate damping, which no longer exists: refused when it was on
    old["scene"].update(bond_backend="native", damp_strain_rate=False)
    assert Physics.from_dict(old) == tendons
    old["scene"]["damp_strain_rate"] = True
    with pytest.raises(PhysicsParameterError, match="damp_strain_rate"):
        Physics.from_dict(old)
    broken = physics.to_dict()
    broken["materials"]["hard"]["youngs_modulus"] = -1.0
    with pytest.raises(PhysicsParameterError, match="youngs_modulus"):
        Physics.from_dict(broken)
    broken = physics.to_dict()
    del broken["scene"]
    with pytest.raises(PhysicsParameterError, match="invalid physics"):
        Physics.from_dict(broken)


def test_timestep_shrinks_with_heavy_bond_damping():
    """Heavy damping limits like 1/(ζ r²): doubling a large ζ about halves the step."""
    k_per_m = 5e7 * 1e-3 / 1e-3
    zeta2 = Physics().replace_scene(bond_damping_ratio=2.0).timestep(k_per_m)
    zeta4 = Physics().replace_scene(bond_damping_ratio=4.0).timestep(k_per_m)
    assert zeta4 / zeta2 == pytest.approx(0.5, rel=0.02)
    assert Physics().replace_scene(bond_damping_ratio=0.1).timestep(k_per_m) > \
        Physics().timestep(k_per_m)
