"""Mechanics of compiled robots against closed-form physics.

Units SI; L = 1 mm voxels of m = 1 g; E soft 1e7 Pa, hard 5e7 Pa; g = 27.468 m/s².
"""

import math

import mujoco
import numpy as np
import pytest

from mjregen.grid import Material, Robot
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import Simulation, simulation_of

L, M, G = 1e-3, 1e-3, 27.468


def bar(n: int, material: int, *, dim: int, axis: int) -> Robot:
    """A straight bar of n voxels along grid `axis` (0 = x, last = z)."""
    shape = [1] * dim
    shape[axis] = n
    return Robot.box(shape, material)


def dropped_voxel(physics: Physics, seconds: float, dim: int = 3) -> tuple[np.ndarray, np.ndarray, float]:
    """(t, COM ``(n, 3)``, dt) of a soft voxel dropped with its bottom 5 mm above the floor,
    recorded at the start of every step for `seconds`."""
    compiled = compile_robot(Robot.box((1,) * dim),
                             physics=physics.replace(start_shift=0.0), elevation=5e-3)
    sim = simulation_of(compiled)
    dt = compiled.timestep
    n = round(seconds / dt)
    com = np.empty((n, 3))
    assert sim.run(n, com=com) == ""
    return np.arange(n) * dt, com, dt


@pytest.mark.parametrize("dim", [2, 3])
def test_free_fall_follows_parabola_until_contact(dim):
    """A voxel dropped from 5 mm: z(t) = z0 − g t²/2 until it touches the floor.

    Tolerance: semi-implicit Euler gives z_n = z0 − g dt² n(n+1)/2, i.e. an error of exactly
    g·dt·t/2 (≤ 12 µm here); we allow that bound plus 1 nm. Drag off (see the next test).
    """
    t, com, dt = dropped_voxel(Physics().replace(drag_ratio=0.0), 0.025, dim)
    z0 = 5e-3 + L / 2
    exact = z0 - G * t**2 / 2
    falling = exact > L / 2
    assert falling.sum() > 300
    error = np.abs(com[falling, 2] - exact[falling])
    assert np.all(error <= G * dt * t[falling] / 2 + 1e-9)
    assert np.allclose(com[:, :2], 0.0, atol=1e-12)  # straight down
    # then it stops on the floor (contact at t = sqrt(2·5 mm/g) = 19.1 ms)
    assert com[-1, 2] == pytest.approx(L / 2, abs=0.02 * L)


def test_free_fall_with_drag_follows_the_linear_drag_solution():
    """The engine's "slow" drag F = −2ζ sqrt(m E L)·v: z(t) = z0 − (g/k)(t − (1 − e^{−kt})/k)
    with k = 2ζ sqrt(E L/m) = 6.32 s⁻¹ for ζ = 0.001 (0.15 mm less fall than without drag
    after 17.5 ms, the engine's figure). Tolerance: the Euler bound of the previous test."""
    t, com, dt = dropped_voxel(Physics().replace(drag_ratio=0.001), 0.0175)
    k = 2 * 0.001 * math.sqrt(1e7 * L / M)
    z0 = 5e-3 + L / 2
    exact = z0 - G / k * (t - (1 - np.exp(-k * t)) / k)
    assert np.all(np.abs(com[:, 2] - exact) <= G * dt * t / 2 + 1e-9)
    # the drag's lead over a drag-free fall, against the same Euler steps without drag:
    # g (t²/2 − t/k + (1 − e^{−kt})/k²) = g k t³/6 (1 − kt/4 + …) = 0.15 mm at 17.5 ms
    steps = len(t) - 1
    no_drag = z0 - G * dt**2 * steps * (steps + 1) / 2
    lead = G * (t[-1] ** 2 / 2 - t[-1] / k + (1 - math.exp(-k * t[-1])) / k**2)
    assert lead == pytest.approx(0.15e-3, rel=0.02)
    assert com[-1, 2] - no_drag == pytest.approx(lead, rel=0.02)


@pytest.mark.parametrize("code, modulus", [(Material.SOFT, 1e7), (Material.HARD, 5e7)])
def test_drag_slows_each_voxel_with_its_own_modulus_and_its_spin_ten_times_harder(code,
                                                                                  modulus):
    """The engine's slow damping on a free voxel (no gravity, floor or bonds): its velocity
    decays as e^{−kt}, k = 2ζ sqrt(E L/m) with its own E (6.32 s⁻¹ soft, 14.1 s⁻¹ hard, the
    rates of the engine's recordings), its spin as e^{−k_r t}, k_r = 2·10ζ sqrt(E L³/I),
    I = m L²/6 (155 s⁻¹ soft, 347 s⁻¹ hard). Tolerance: twice Euler's error of a decay,
    k² t dt / 2 relative to first order."""
    physics = Physics().replace(floor=False, gravity=0.0, settle_time=0.0)
    compiled = compile_robot(Robot.box((1, 1, 1), code),
                             physics=physics)
    sim = simulation_of(compiled)
    sim.data.qvel[:] = [0.01, 0.0, 0.0, 0.0, 0.0, 2.0]  # m/s along x, rad/s about z
    duration, dt = 0.01, compiled.timestep
    steps = round(duration / dt)
    assert sim.run(steps) == ""
    t = steps * dt
    k = 2 * 0.001 * math.sqrt(modulus * L / M)
    k_spin = 2 * 10 * 0.001 * math.sqrt(modulus * L**3 / (M * L**2 / 6))
    assert k == pytest.approx({1e7: 6.32, 5e7: 14.1}[modulus], rel=3e-3)
    for value, start, rate in ((sim.data.qvel[0], 0.01, k), (sim.data.qvel[5], 2.0, k_spin)):
        assert value == pytest.approx(start * math.exp(-rate * t),
                                      rel=rate**2 * t * dt)


@pytest.mark.parametrize("body", [np.ones((2, 2, 2)), np.full((2, 2, 2), 2), np.ones((3, 2))],
                         ids=["soft-2x2x2", "hard-2x2x2", "soft-2D-3x2"])
def test_block_rests_on_floor_for_two_seconds(body):
    """A passive block on the floor: no drift, sinks < 2 % of a voxel, gains no energy."""
    compiled = compile_robot(Robot.from_body(body.astype(np.int8)))
    model = compiled.model
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    sim = Simulation(model, physics=compiled.physics, muscles=None, actuation_start=0.0)
    mujoco.mj_forward(model, sim.data)
    energy0 = sim.data.energy.sum()
    start = sim.com()
    n = round(2.0 / compiled.timestep)
    com = np.empty((n, 3))
    assert sim.run(n, com=com) == ""
    assert np.abs(com[:, :2] - start[:2]).max() < 1e-6 * L  # no drift
    assert start[2] - com[:, 2].min() < 0.02 * L  # compression under own weight + contact
    lowest = sim.data.xpos[compiled.body_ids, 2].min() - L / 2
    assert lowest > -0.02 * L  # sinks into the floor < 2 % of a voxel
    mujoco.mj_forward(model, sim.data)
    assert sim.data.energy.sum() <= energy0 + 1e-12  # J; settling only dissipates
    assert np.abs(sim.data.qvel).max() < 1e-6  # at rest at the end


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("material, E", [(Material.SOFT, 1e7), (Material.HARD, 5e7)])
@pytest.mark.parametrize("element", ["tendons", "beam"])
def test_hanging_column_stretches_as_E_predicts(dim, material, E, element):
    """A vertical column of n voxels hanging from its clamped top voxel, floor off.

    Bond k (counted from the bottom) carries the weight of the k voxels below it, and a bond
    of two half-voxels has stiffness E·A/L = E·L; the bottom voxel sinks
    Σ k·m·g/(E·L) = m·g·n(n−1)/(2·E·L) (soft n = 5: 27.5 µm). Tolerance 2 %: the lowest
    axial mode is the least damped (stiffness-proportional damping), so after 0.2 s a small
    ringing remains; averaged over the last 20 ms.
    """
    n = 5
    robot = bar(n, material, dim=dim, axis=dim - 1)
    physics = Physics().replace(floor=False, bond_element=element)
    compiled = compile_robot(robot, physics=physics, clamped=[(1,) * (dim - 1) + (n,)])
    sim = simulation_of(compiled)
    bottom = compiled.body_ids[np.argmin(compiled.voxel_index[:, -1])]
    z0 = compiled.model.body_pos[bottom, 2]
    sim.run(round(0.18 / compiled.timestep))
    sag = []
    for _ in range(round(0.02 / compiled.timestep)):
        sim.run(1)
        sag.append(z0 - sim.data.xpos[bottom, 2])
    predicted = M * G * n * (n - 1) / (2 * E * L)
    assert np.mean(sag) == pytest.approx(predicted, rel=0.02)


def cantilever_sag(n: int, material: int, *, dim: int, gravity: float, settle: float,
                   bond_model: str = "euler_bernoulli", bond_element: str = "beam") -> float:
    """Tip sag (m) of a horizontal bar of n voxels whose first voxel is clamped, floor off.

    Averaged over the last 20 ms of `settle` s.
    """
    physics = Physics().replace(floor=False, gravity=gravity, bond_model=bond_model,
                                      bond_element=bond_element)
    compiled = compile_robot(bar(n, material, dim=dim, axis=0), physics=physics,
                             clamped=[(1,) * dim])
    sim = simulation_of(compiled)
    tip = compiled.body_ids[np.argmax(compiled.voxel_index[:, 0])]
    z0 = compiled.model.body_pos[tip, 2]
    sim.run(round((settle - 0.02) / compiled.timestep))
    sag = []
    for _ in range(round(0.02 / compiled.timestep)):
        sim.run(1)
        sag.append(z0 - sim.data.xpos[tip, 2])
    return float(np.mean(sag))


def euler_bernoulli(n: int, E: float, gravity: float) -> tuple[float, float]:
    """(bending, shear) tip deflections in m of a cantilever clamped at voxel 0's centre.

    The voxels' weights P = m·g act at their centres x_i = i·L (i = 1..n−1), tip at
    ℓ = (n−1)·L. Euler–Bernoulli: Σ P x_i² (3ℓ − x_i) / (6 E I), I = L⁴/12 (the discrete-load
    form of wL⁴/8EI). Timoshenko adds the shear deflection Σ P x_i / (G A), G = E/2.7.
    """
    P, I, A = M * gravity, L**4 / 12, L**2
    x = np.arange(1, n) * L
    ell = (n - 1) * L
    bending = float(np.sum(P * x**2 * (3 * ell - x) / (6 * E * I)))
    shear = float(np.sum(P * x / (E / 2.7 * A)))
    return bending, shear


# (n, material, E, gravity scale): the paper's g keeps sags < 0.35 mm (hard) or < 0.15 mm
# (soft n = 3); soft n = 4, 5 at g/10 keep the bending linear (slope < 0.1 rad).
CANTILEVERS = [(3, Material.HARD, 5e7, 1.0), (4, Material.HARD, 5e7, 1.0),
               (5, Material.HARD, 5e7, 1.0), (3, Material.SOFT, 1e7, 1.0),
               (4, Material.SOFT, 1e7, 0.1), (5, Material.SOFT, 1e7, 0.1)]


@pytest.mark.parametrize("element", ["tendons", "beam"])
@pytest.mark.parametrize("n, material, E, scale", CANTILEVERS)
def test_cantilever_sags_like_a_beam(n, material, E, scale, element):
    """Tip sag vs beam theory, for both bond models and both bond elements.

    "euler_bernoulli" (shear-rigid bonds, the default and the paper engine's beam element):
    measured sag / Euler–Bernoulli = 0.992–1.000 (3D, settled 0.3 s, or 0.8 s at g/10);
    tolerance [0.98, 1.01].
    "timoshenko": sag / EB = 1.12 (n=3), 1.06 (n=4), 1.03 (n=5), the same for soft and hard;
    sag / Timoshenko (EB + shear, κ = 1) = 0.94, 0.97, 0.98. The excess over EB is the shear
    compliance of cube-shaped segments (GA/L per bond); the deficit against Timoshenko is
    the one-bond-per-voxel discretisation of the bending. Tolerances: within [0.90, 1.02]
    of Timoshenko and [1.0, 1.15] of EB.
    """
    gravity = G * scale
    settle = 0.3 if scale == 1 else 0.8
    bending, shear = euler_bernoulli(n, E, gravity)
    rigid = cantilever_sag(n, material, dim=3, gravity=gravity, settle=settle,
                           bond_element=element)
    assert 0.98 <= rigid / bending <= 1.01
    sag = cantilever_sag(n, material, dim=3, gravity=gravity, settle=settle,
                         bond_model="timoshenko", bond_element=element)
    assert 1.0 <= sag / bending <= 1.15
    assert 0.90 <= sag / (bending + shear) <= 1.02


def test_cantilever_2d_equals_3d_and_matches_the_paper_engine():
    """One model for both dimensions; 5 hard voxels sag 0.2845 mm in the paper's engine.

    Its bonds have no shear compliance, so it matches EB (0.2857 mm), as do our default
    shear-rigid beam bonds (0.2840 mm; tendon bonds 0.2835 mm); Timoshenko bonds add 3.5 %.
    2D and 3D agree to 1e-8 with beams (0.14 % with tendons, whose settling bars still ring a
    little with ζ = 0.4).
    """
    sag2 = cantilever_sag(5, Material.HARD, dim=2, gravity=G, settle=0.3)
    sag3 = cantilever_sag(5, Material.HARD, dim=3, gravity=G, settle=0.3)
    assert sag2 == pytest.approx(sag3, rel=2e-3)
    assert sag3 == pytest.approx(0.2845e-3, rel=0.01)
    shear = cantilever_sag(5, Material.HARD, dim=3, gravity=G, settle=0.3,
                           bond_model="timoshenko")
    assert shear == pytest.approx(0.2845e-3, rel=0.06)


@pytest.mark.parametrize("element", ["tendons", "beam"])
@pytest.mark.parametrize("bond_model, shear_modulus_ratio",
                         [("timoshenko", 1 / 2.7), ("euler_bernoulli", 1.0)])
def test_two_voxel_cantilever_measures_shear_stiffness(bond_model, shear_modulus_ratio, element):
    """One bond carrying the tip voxel's weight P: transverse stiffness in series with bending.

    For one segment with the bending rotation at its midpoint the tip sags
    P/(G·L) + P·L³/(4·E·I); Timoshenko bonds have G = E/2.7 (shear is 47 % of the sag, so a
    wrong G shows), shear-rigid bonds a transverse stiffness E·L = 12EI/L³ (G = E). 1 %.
    """
    gravity = G
    sag = cantilever_sag(2, Material.HARD, dim=3, gravity=gravity, settle=0.15,
                         bond_model=bond_model, bond_element=element)
    P, E = M * gravity, 5e7
    predicted = P / (E * shear_modulus_ratio * L) + P * L**3 / (4 * E * L**4 / 12)
    assert sag == pytest.approx(predicted, rel=0.01)


def muscle_pair(codes: tuple[int, int], *, waveform: str = "contract",
                bond_element: str = "beam") -> tuple[np.ndarray, np.ndarray]:
    """(t, centre distance) of a free two-voxel bar, no floor or gravity, actuated from t=0;
    bond damping ratio 1 (overdamped: a clean first-order lag)."""
    physics = Physics().replace(floor=False, gravity=0.0, settle_time=0.0, start_shift=0.0,
                                waveform=waveform, bond_damping_ratio=1.0,
                                bond_element=bond_element)
    compiled = compile_robot(Robot.from_body(np.array(codes, dtype=np.int8).reshape(2, 1, 1)),
                             physics=physics)
    sim = simulation_of(compiled)
    n = round(0.1 / compiled.timestep)
    distance = np.empty(n)
    for k in range(n):
        sim.run(1)
        distance[k] = np.linalg.norm(np.diff(sim.data.xpos[compiled.body_ids], axis=0))
    return np.arange(1, n + 1) * compiled.timestep, distance


@pytest.mark.parametrize("element", ["tendons", "beam"])
def test_muscle_contracts_with_commanded_amplitude_and_waveform(element):
    """Red–red bar at 40 Hz, contract-only: length L·(1 + 0.14·min(0, sin 2πft)).

    The bond's axial resonance (sqrt(2EL/m)/2π ≈ 710 Hz) is far above 40 Hz and the bond is
    overdamped (ζ = 1 per voxel mass is √2 for the pair), so the bar follows the command
    as a first-order lag of c/k = 2 sqrt(m/EL) = 0.63 ms: within 1 % of L of the lagged
    command at every step after the first cycle (2.3 % without the lag), peak contraction
    0.86 L within 0.5 %, never longer than L (+1e-9 m).
    """
    t, distance = muscle_pair((3, 3), bond_element=element)
    lag = 2 * math.sqrt(M / (1e7 * L))
    command = L * (1 + 0.14 * np.minimum(0.0, np.sin(2 * math.pi * 40 * (t - lag))))
    late = t > 0.025
    assert np.abs(distance[late] - command[late]).max() < 0.01 * L
    assert distance[late].min() == pytest.approx(0.86 * L, rel=0.005)
    assert distance.max() <= L + 1e-9


def test_red_and_green_are_in_counter_phase():
    """Red contracts in the second half of each 25 ms period, green in the first."""
    t, red = muscle_pair((3, 3))
    _, green = muscle_pair((4, 4))
    phase = (t % 0.025) / 0.025
    late = t > 0.025
    first, second = late & (phase > 0.2) & (phase < 0.3), late & (phase > 0.7) & (phase < 0.8)
    assert red[first].min() > 0.97 * L and red[second].max() < 0.90 * L
    assert green[second].min() > 0.97 * L and green[first].max() < 0.90 * L
    # a red–green bond averages the two: rest L·(1 + 0.07·(min(0, sin) + min(0, −sin)))
    _, mixed = muscle_pair((3, 4))
    assert mixed[late].min() == pytest.approx(0.93 * L, rel=0.005)


def test_symmetric_waveform_also_extends():
    t, distance = muscle_pair((3, 3), waveform="symmetric")
    late = t > 0.025
    assert distance[late].max() == pytest.approx(1.14 * L, rel=0.005)
    assert distance[late].min() == pytest.approx(0.86 * L, rel=0.005)


@pytest.mark.parametrize("shape, spin", [("point", (0.0, 0.1)), ("sphere", (5.0, math.inf))])
def test_point_contacts_rest_like_the_engine_and_exert_no_moment(shape, spin):
    """`MujocoPipeline.contact_shape` "point": a voxel rests with its centre at L/2 whatever its orientation
    (the engine: 0.49863 mm; MuJoCo's contact impedance leaves ~nm penetration at rest), and
    a kicked voxel slides without starting to roll."""
    # the pure-MuJoCo pipeline; shear-rigid bonds (the old default) set the lone voxel's step
    physics = Physics().replace(pipeline="mujoco", contact_shape=shape, contact_stiffness=2.0,
                                contact_damping=1.2, settle_time=0.0, collision_radius=0.0,
                                bond_model="euler_bernoulli", timestep_rule="network")
    robot = Robot.box((1, 1, 1))
    compiled = compile_robot(robot, physics=physics)
    sim = simulation_of(compiled)
    data = sim.data
    data.qpos[3:7] = [math.cos(0.3), math.sin(0.3), 0.0, 0.0]  # tilted 0.6 rad about x
    assert sim.run(round(0.05 / compiled.timestep)) == ""
    assert data.qpos[2] == pytest.approx(L / 2, abs=2e-6)  # a box corner would be at 0.78 mm
    data.qvel[0] = 0.1  # m/s along x
    assert sim.run(round(0.005 / compiled.timestep)) == ""
    # "point": no rolling, friction acts through the centre; "sphere": at the bottom, it rolls
    assert spin[0] <= np.linalg.norm(data.qvel[3:6]) < spin[1]
    assert data.qvel[0] < 0.1


def test_resting_muscles_move_as_soft_voxels():
    """Until the settle ends the muscles do not work: the paper's multiped with its muscle
    voxels moves as the same robot with those voxels soft, to rounding (the muscles' bonds
    come first, so the forces are summed in another order)."""
    multiped = Robot.load("assets/robots/paper/multiped.npy")
    grid = multiped.grid.copy()
    grid[grid >= Material.MUSCLE_PLUS] = Material.SOFT
    states = []
    for robot in (multiped, Robot(grid)):
        compiled = compile_robot(robot, physics=Physics().replace(start_shift=0.0))
        sim = simulation_of(compiled)
        settle, _ = Physics().scene.timing(3)
        assert sim.run(round(settle / compiled.timestep)) == ""
        states.append(sim.data.qpos.copy())
    assert np.abs(states[0] - states[1]).max() < 1e-12
