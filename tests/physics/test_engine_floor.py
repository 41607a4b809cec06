"""The paper engine's floor (the voxel pipeline's, the default) against closed-form physics.

One voxel, L = 1 mm, m = 1 g, E = 1e7 Pa: floor spring k = 2·E·L = 2e4 N/m on the centre's
penetration below the half size, static friction 1.0, kinetic 0.5. Drag off unless stated,
so the numbers are exact mechanics.
"""

import math

import mujoco
import numpy as np
import pytest

from mjregen.grid import Robot
from mjregen.physics import Physics, PhysicsParameterError, VoxelPipeline, mjcf, voxel_plugin
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulation_of

pytestmark = pytest.mark.skipif(not voxel_plugin.available(),
                                reason="the engine floor is computed by the voxel plugin")

L, M, G = 1e-3, 1e-3, 27.468
K_FLOOR = 2.0 * 1e7 * L
NO_DRAG = Physics().replace(drag_ratio=0.0, settle_time=0.0)


def voxel(code: int = 1, physics: Physics = NO_DRAG):
    compiled = compile_robot(Robot.box((1, 1, 1), code),
                             physics=physics)
    return compiled, simulation_of(compiled)


def run(sim, seconds: float) -> None:
    assert sim.run(round(seconds / sim.model.opt.timestep)) == ""


def test_rests_at_the_static_penetration_whatever_its_orientation():
    """Centre height L/2 − m g / k = 0.49863 mm (the engine's, cases.md), tilted or not:
    the floor acts on the centre, not on the box's corners."""
    for tilt in (0.0, 0.3):
        compiled, sim = voxel()
        sim.data.qpos[3:7] = [math.cos(tilt), math.sin(tilt), 0.0, 0.0]
        run(sim, 0.05)
        assert sim.data.qpos[2] == pytest.approx(L / 2 - M * G / K_FLOOR, abs=1e-9)
        assert np.abs(sim.data.qvel).max() < 1e-6


def test_kicked_voxel_slides_on_kinetic_friction_then_sticks_dead():
    """v0 = 0.1 m/s: decelerates at μk g, slides v0² / (2 μk g) = 0.364 mm in v0/(μk g) =
    7.3 ms, then static friction holds it exactly still."""
    compiled, sim = voxel()
    run(sim, 0.02)
    x0 = sim.data.qpos[0]
    assert sim.data.plugin_state[0] == 1.0  # resting: static friction holds it
    sim.data.qvel[0] = 0.1  # a kick from outside releases it
    run(sim, 0.004)
    assert sim.data.qvel[0] == pytest.approx(0.1 - 0.5 * G * 0.004, rel=0.01)
    run(sim, 0.02)
    assert sim.data.qpos[0] - x0 == pytest.approx(0.1**2 / (2 * 0.5 * G), rel=0.01)
    assert sim.data.qvel[0] == 0.0 and sim.data.plugin_state[0] == 1.0  # stuck
    x_stop = sim.data.qpos[0]
    run(sim, 0.02)
    assert sim.data.qpos[0] == x_stop


@pytest.mark.parametrize("rule", ["momentum", "energy"])
def test_a_slow_voxel_pushed_between_kinetic_and_static_friction(rule):
    """Resting on the floor, pushed along x with 0.75 m g (between μk N = 0.5 m g and
    μs N = m g), given the speed v = 0.6 g dt. The engine's rule ("momentum"): the friction
    impulse μk N dt is below its momentum m v, so it slides, and the push outweighs kinetic
    friction: it accelerates at 0.25 g. The energy rule: after the step its momentum
    m v + (0.75 − 0.5) m g dt = 0.85 m g dt is below m g dt, the step's friction work would
    exceed its kinetic energy, so it stops, and static friction then holds it."""
    compiled, sim = voxel(physics=NO_DRAG.replace(friction_stop=rule))
    run(sim, 0.02)
    sim.data.qfrc_applied[0] = 0.75 * M * G
    dt = sim.model.opt.timestep
    sim.data.qvel[0] = 0.6 * G * dt
    x0 = sim.data.qpos[0]
    run(sim, 0.01)
    if rule == "momentum":
        assert sim.data.qvel[0] == pytest.approx(0.6 * G * dt + 0.25 * G * 0.01, rel=0.02)
    else:
        assert sim.data.qvel[0] == pytest.approx(0.0, abs=1e-15)
        assert abs(sim.data.qpos[0] - x0) < 1e-12


def tilt(sim, degrees: float) -> None:
    theta = math.radians(degrees)
    sim.model.opt.gravity[:] = [G * math.sin(theta), 0.0, -G * math.cos(theta)]


@pytest.mark.parametrize("degrees", [40.0, 50.0])
def test_inclined_floor_holds_below_the_static_angle_and_slides_above(degrees):
    """A resting voxel, then gravity tilted by θ: static friction 1.0 holds while
    tan θ < 1 (40°: not a nanometre of creep); at 50° it breaks loose and slides with
    acceleration g (sin θ − μk cos θ)."""
    compiled, sim = voxel()
    run(sim, 0.02)
    tilt(sim, degrees)
    run(sim, 0.01)
    x1, v1 = sim.data.qpos[0], sim.data.qvel[0]
    run(sim, 0.02)
    theta = math.radians(degrees)
    if math.tan(theta) < 1.0:
        assert sim.data.qpos[0] == x1 and sim.data.qvel[0] == 0.0
        return
    acceleration = (sim.data.qvel[0] - v1) / 0.02
    assert acceleration == pytest.approx(G * (math.sin(theta) - 0.5 * math.cos(theta)),
                                         rel=0.01)


def test_stick_slip_hysteresis_a_sliding_voxel_keeps_sliding_where_a_resting_one_holds():
    """At 40° (μk < tan θ < μs) a resting voxel holds (previous test) but a moving one
    accelerates at g (sin θ − μk cos θ): kinetic friction cannot stop it."""
    compiled, sim = voxel()
    run(sim, 0.02)
    tilt(sim, 40.0)
    sim.data.qvel[0] = 0.01
    run(sim, 0.005)
    v1 = sim.data.qvel[0]
    run(sim, 0.02)
    theta = math.radians(40.0)
    acceleration = (sim.data.qvel[0] - v1) / 0.02
    assert acceleration == pytest.approx(G * (math.sin(theta) - 0.5 * math.cos(theta)),
                                         rel=0.01)


def test_contracting_muscle_voxel_sinks_with_its_half_size():
    """A lone red voxel: its floor half size follows L/2 (1 + 0.14 min(0, sin 2π f t)), so
    its centre drops to 0.43 mm − m g / k at full contraction (the engine's muscles feet)."""
    compiled, sim = voxel(code=3)
    dt = compiled.timestep
    heights = []
    for _ in range(round(0.05 / dt)):
        sim.run(1)
        heights.append(sim.data.qpos[2])
    late = np.array(heights[round(0.025 / dt):])
    assert late.min() == pytest.approx(0.86 * L / 2 - M * G / K_FLOOR, rel=0.01)
    assert late.max() == pytest.approx(L / 2 - M * G / K_FLOOR, rel=0.01)


@pytest.mark.parametrize("stiffness", [1.0, 4.0])
def test_floor_stiffness_sets_the_static_penetration(stiffness):
    """`floor_stiffness` is the spring in units of E·L: the centre rests m g / k lower."""
    compiled, sim = voxel(physics=NO_DRAG.replace(floor_stiffness=stiffness))
    run(sim, 0.05)
    assert sim.data.qpos[2] == pytest.approx(L / 2 - M * G / (stiffness * 1e7 * L), abs=1e-9)


def test_engine_floor_is_stepped_with_euler_and_needs_a_penalty_stiffness():
    """The voxel pipeline has no integrator to choose (MuJoCo's Euler) and no MuJoCo
    contact parameters: its floor is the engine's penalty spring."""
    with pytest.raises(PhysicsParameterError, match="integrator: not a field of the scene "
                                                    "or of the voxel pipeline"):
        Physics().replace(integrator="rk4")
    assert compile_robot(Robot.box((1, 1, 1))).model.opt.integrator \
        == mujoco.mjtIntegrator.mjINT_EULER
    with pytest.raises(PhysicsParameterError, match="floor_stiffness"):
        Physics().replace(floor_stiffness=None)
    with pytest.raises(PhysicsParameterError, match="floor_stiffness"):
        VoxelPipeline(floor_stiffness=0.0)
    for name in ("contact_stiffness", "contact_damping", "contact_shape"):
        with pytest.raises(PhysicsParameterError, match=f"{name}: not a field"):
            Physics().replace(**{name: 2.0})
    # MuJoCo's contact shapes take either integrator
    assert Physics().replace(pipeline="mujoco", integrator="rk4",
                             contact_shape="point").pipeline.integrator == "rk4"


def colliding_pair(speed: float, **changes: object):
    """Two soft voxels two grid cells apart (not bonded: they collide), no gravity, no
    floor, no drag, flying at each other at ±`speed` m/s along x."""
    body = np.zeros((3, 1, 1), dtype=np.int8)
    body[0], body[2] = 1, 1
    physics = Physics().replace(floor=False, gravity=0.0, drag_ratio=0.0, settle_time=0.0,
                                **changes)
    compiled = compile_robot(Robot.from_body(body), physics=physics)
    sim = simulation_of(compiled)
    left, right = np.argsort(compiled.voxel_index[:, 0])
    sim.data.qvel[6 * left], sim.data.qvel[6 * right] = speed, -speed
    return compiled, sim, left, right


def collide(speed: float, **changes: object) -> tuple[float, float, float]:
    """(closest centre distance m, left and right voxels' speeds after 30 ms m/s)."""
    compiled, sim, left, right = colliding_pair(speed, **changes)
    closest = np.inf
    for _ in range(round(0.03 / compiled.timestep)):
        assert sim.run(1) == ""
        closest = min(closest, sim.data.qpos[7 * right] - sim.data.qpos[7 * left])
    return closest, sim.data.qvel[6 * left], sim.data.qvel[6 * right]


def test_self_collision_is_the_engines_undamped_spring_and_conserves_momentum():
    """The engine's collision (the default): centres 2 L apart, spheres of 0.75 L, contact
    below 1.5 L; an undamped spring k = E·L between them. An elastic bounce: the voxels come
    back with their speed (to the time step's error), momentum exactly conserved, the
    deepest penetration that of the linear spring, 2v sqrt(μ/k) with μ = m/2."""
    speed = 0.05
    closest, v_left, v_right = collide(speed)
    assert v_left < 0.0 < v_right  # bounced
    assert (v_right - v_left) / (2 * speed) == pytest.approx(1.0, abs=0.01)
    assert abs(v_left + v_right) < 1e-12  # momentum
    k = 1e7 * L
    assert 1.5 * L - closest == pytest.approx(2 * speed * math.sqrt(M / 2 / k), rel=0.02)


def test_self_collision_with_the_floors_spring_and_damper_loses_energy():
    """collision_stiffness 2 and damping 0.8 (the floor's constants), spheres of 0.625 L:
    restitution < 1, momentum exactly conserved, penetration below the undamped bound."""
    speed = 0.05
    closest, v_left, v_right = collide(speed, collision_radius=0.625, collision_stiffness=2.0,
                                       collision_damping=0.8)
    assert v_left < 0.0 < v_right
    assert v_right - v_left < 0.9 * 2 * speed
    assert abs(v_left + v_right) < 1e-12
    assert 0.0 < 1.25 * L - closest <= 2 * speed * math.sqrt(M / 2 / K_FLOOR)


def test_voxels_within_the_collision_hops_never_collide():
    """Two columns of three voxels, diagonal neighbours (√2 L apart, inside the 1.5 L
    contact), joined by one voxel on top: the bottom pair is 6 bonds apart, the middle pair
    4, the top pair 2. At rest (no gravity, floor or drag; bonds at rest pull nothing) a
    pair that collides pushes apart with k (1.5 − √2) L along its diagonal: with
    collision_hops 3 the bottom and middle pairs, with 5 the bottom one only, with 0 (grid
    neighbours never collide) none."""
    body = np.zeros((2, 2, 3), dtype=np.int8)
    body[0, 0, :] = body[1, 1, :] = 1
    body[0, 1, 2] = 1  # the bridge on top
    robot = Robot.from_body(body)
    push = 1e7 * L * (1.5 - math.sqrt(2.0)) * L / math.sqrt(2.0)  # N along x and y each
    for hops, pushed in ((3, {0, 1}), (5, {0}), (0, set())):
        physics = Physics().replace(floor=False, gravity=0.0, drag_ratio=0.0, start_shift=0.0,
                                    settle_time=0.0, collision_hops=hops,
                                    collision_radius=0.75 if hops else 0.7)
        compiled = compile_robot(robot, physics=physics)
        sim = simulation_of(compiled)
        mujoco.mj_forward(sim.model, sim.data)
        for n, (x, y, z) in enumerate(compiled.voxel_index - compiled.voxel_index.min(axis=0)):
            if (x, y) != (0, 0):
                continue
            force = sim.data.qfrc_passive[6 * n: 6 * n + 3]
            if z in pushed:  # away from its partner at (1, 1, z)
                assert force[:2] == pytest.approx([-push, -push], rel=1e-9)
            else:
                assert np.abs(force).max() < 1e-12


def test_self_collision_candidate_list_never_changes_the_result(monkeypatch):
    """The Verlet list only filters candidates: a skin of 0.01 L (rebuilt nearly every
    step) and of 3 L (built once) give bit-identical motion."""
    states = []
    for skin in (0.01, 3.0):
        monkeypatch.setattr(mjcf, "COLLISION_SKIN", skin)
        compiled, sim, *_ = colliding_pair(0.05)
        assert float(compiled.spec.plugins[0].config["collision_skin"]) == skin * L
        assert sim.run(round(0.03 / compiled.timestep)) == ""
        states.append(sim.data.qpos.copy())
    assert np.array_equal(states[0], states[1])


@pytest.mark.parametrize("stop_time", [None, 2e-3])
def test_sliding_voxel_stops_at_the_threshold_speed_of_its_stop_rule(stop_time):
    """Kicked to v0 = 0.1 m/s, a voxel decelerates at μk g and sticks once its speed is
    below v* = μk g t, t the step (the engine's rule) or `friction_stop_time`: it slides
    (v0² − v*²)/(2 μk g) (to one step's travel v0 dt, Euler's error), whatever the step
    when t is fixed; the engine's rule converges to v0²/(2 μk g) as the step shrinks."""
    slides = []
    for safety in (0.75, 0.75 / 4):
        physics = NO_DRAG.replace(timestep_safety=safety, friction_stop_time=stop_time)
        compiled, sim = voxel(physics=physics)
        run(sim, 0.02)
        x0 = sim.data.qpos[0]
        sim.data.qvel[0] = 0.1
        run(sim, 0.02)
        assert abs(sim.data.qvel[0]) < 1e-15  # stuck
        dt = compiled.timestep
        threshold = 0.5 * G * (dt if stop_time is None else stop_time)
        expected = (0.1**2 - threshold**2) / (2 * 0.5 * G)
        assert sim.data.qpos[0] - x0 == pytest.approx(expected, abs=0.1 * dt)
        slides.append((sim.data.qpos[0] - x0, dt))
    if stop_time is not None:  # the same slide at both steps
        (long, dt_long), (short, _) = slides
        assert long == pytest.approx(short, abs=0.1 * dt_long)
        assert 0.1**2 / (2 * 0.5 * G) - short > 0.1 * dt_long  # and not the engine rule's


def test_a_robot_where_no_pair_can_collide_moves_the_same_with_or_without_collisions():
    """A 2×2×2 block (every two voxels at most 3 bonds apart, so no pair may ever collide):
    the plugin runs no collision stage, and the motion is bit for bit that of the block
    with self-collision off, muscles working on the floor."""
    robot = Robot.from_body(np.array([[[1, 3], [4, 1]], [[3, 1], [1, 4]]], dtype=np.int8))
    states = []
    for radius in (0.75, 0.0):
        physics = Physics().replace(collision_radius=radius, settle_time=0.005)
        compiled = compile_robot(robot, physics=physics)
        sim = simulation_of(compiled)
        assert sim.run(round(0.03 / compiled.timestep)) == ""
        states.append(sim.data.qpos.copy())
    assert np.array_equal(states[0], states[1])
    assert np.abs(states[0] - compile_robot(robot).model.qpos0).max() > 1e-5  # it moved
