"""Convergence order of the integrators and stability of the automatic time step (issue #7).

Fast versions of `benchmarks/accuracy.py` on its harness (`mjregen.validation.integration`);
the full sweeps are there (docs/accuracy.md).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from mjregen.grid import Material, Robot
from mjregen.physics import MujocoPipeline, Physics
from mjregen.validation.integration import Run, evaluate, mujoco_twin

from repo_modules import load_module

accuracy = load_module("benchmarks/accuracy.py")


def cantilever_error(integrator: str, dt: float, reference: np.ndarray) -> float:
    return float(np.linalg.norm(evaluate(CANTILEVER_RUN(dt, integrator))["com_end"]
                                - reference))


def CANTILEVER_RUN(dt: float, integrator: str) -> Run:
    """A 3-voxel hard cantilever clamped at one end, floor off, released under gravity:
    a smooth ODE (no contacts, no muscles), so each integrator shows its textbook order.
    Tendon bonds and Stokes drag: Euler steps them in the voxel plugin, RK4 as MuJoCo's
    tendons and viscosity, the same ODE (tests/physics/test_plugin.py; beams differ from tendons by
    a third of Euler's error)."""
    robot = Robot.box((3, 1, 1), Material.HARD)
    return Run(robot, Physics().replace(floor=False, bond_element="tendons", drag_law="stokes"),
               settle=0.004, measured=0.0, dt=dt, integrator=integrator, clamped=((1, 1, 1),))


@pytest.fixture(scope="module")
def cantilever_reference() -> np.ndarray:
    return evaluate(CANTILEVER_RUN(0.004 / 6400, "rk4"))["com_end"]


@pytest.mark.parametrize("integrator, order", [("euler", 1), ("rk4", 4)])
def test_halving_dt_reduces_error_as_the_order_predicts(integrator, order,
                                                        cantilever_reference):
    dt = 0.004 / 400 if integrator == "rk4" else 0.004 / 800
    errors = [cantilever_error(integrator, dt / 2 ** k, cantilever_reference) for k in range(3)]
    ratios = [errors[k] / errors[k + 1] for k in range(2)]
    observed = [math.log2(r) for r in ratios]
    assert all(abs(p - order) < 0.35 for p in observed), (errors, observed)


def test_other_integrators_run_the_voxel_pipelines_mujoco_twin():
    """Integrators other than Euler (and "-mid") need MuJoCo's tendons and contacts: the
    same bonds, the engine floor's constants on "point" contacts, the same time-step rule."""
    physics = Physics().replace(bond_model="timoshenko", collision_radius=0.5,
                                floor_damping=0.7, settle_time=0.01)
    twin = mujoco_twin(physics)
    assert twin.scene == physics.scene and twin.materials == physics.materials
    assert twin.pipeline == MujocoPipeline(
        contact_shape="point", bond_model="timoshenko", contact_stiffness=2.0,
        contact_damping=0.7, collision_radius=0.5, timestep_rule="network")
    # the engine's 0.75 L envelope (bond hops excluded): MuJoCo's largest without neighbours
    assert mujoco_twin(Physics()).pipeline.collision_radius == 0.625
    run = CANTILEVER_RUN(1e-5, "rk4")
    assert evaluate(run)["dt"] == 1e-5
    assert mujoco_twin(run.physics).pipeline.bond_model == "euler_bernoulli"


def muscle_pair_run(dt: float, integrator: str) -> Run:
    """Two muscle voxels in phase, the first clamped (floor and gravity off),
    symmetric drive: the free voxel's motion moves the centre of mass."""
    robot = Robot.from_body(np.array([[[Material.MUSCLE_PLUS]], [[Material.MUSCLE_PLUS]]],
                                     dtype=np.int8))
    physics = Physics().replace(floor=False, gravity=0.0, waveform="symmetric")
    return Run(robot, physics, settle=0.0, measured=0.005, dt=dt, integrator=integrator,
               clamped=((1, 1, 1),))


def test_muscle_drive_sampled_per_step_limits_rk4_to_first_order():
    """The rest lengths are held over a step (sampled at its start): RK4 drops to order 1;
    sampling at the step's midpoint brings it to order 2 (see docs/accuracy.md)."""
    reference = evaluate(muscle_pair_run(0.005 / 32000, "rk4-mid"))["com_end"]
    observed = {}
    for variant in ("rk4", "rk4-mid"):
        errors = [np.linalg.norm(evaluate(muscle_pair_run(0.005 / n, variant))["com_end"]
                                 - reference) for n in (500, 1000)]
        observed[variant] = math.log2(errors[0] / errors[1])
    assert abs(observed["rk4"] - 1) < 0.35, observed
    assert abs(observed["rk4-mid"] - 2) < 0.5, observed


def scaled_hard(factor: float) -> dict:
    materials = dict(Physics().materials)
    hard = materials[Material.HARD]
    materials[Material.HARD] = replace(hard, youngs_modulus=hard.youngs_modulus * factor)
    return materials


def strain(amplitude: float) -> dict:
    materials = dict(Physics().materials)
    for code in (Material.MUSCLE_PLUS, Material.MUSCLE_MINUS):
        materials[code] = replace(materials[code], strain_amplitude=amplitude)
    return materials


EXTREME_CASES = {
    "hard block 3^3, E x1000": lambda: Run(Robot.box((3,) * 3, Material.HARD),
                                           Physics(materials=scaled_hard(1000)),
                                           settle=0.002, measured=0.001),
    "hard block 4^3, dropped from 5 L": lambda: Run(Robot.box((4,) * 3, Material.HARD), Physics(),
                                                    settle=0.03, measured=0.0, elevation=5e-3),
    "single hard voxel": lambda: Run(Robot.box((1, 1, 1), 2),
                                     Physics(), settle=0.02, measured=0.0),
    "hard tower 1x1x6": lambda: Run(Robot.box((1, 1, 6), 2),
                                    Physics(), settle=0.02, measured=0.0),
    "hard cantilever 8, clamped": lambda: Run(
        Robot.box((8, 1, 1), 2), Physics(), settle=0.02,
        measured=0.0, elevation=5e-3, clamped=((1, 1, 1),)),
    "muscle block 3^3 in phase, ±50 %": lambda: Run(
        Robot.box((3,) * 3, Material.MUSCLE_PLUS),
        Physics(materials=strain(0.5)).replace(waveform="symmetric"),
        settle=0.005, measured=0.03),
    "soft block 4^3, zeta 0.05": lambda: Run(Robot.box((4,) * 3, Material.SOFT),
                                             Physics().replace(bond_damping_ratio=0.05),
                                             settle=0.02, measured=0.0),
}


@pytest.mark.parametrize("name", list(EXTREME_CASES))
def test_automatic_time_step_is_stable_on_extreme_cases(name):
    out = evaluate(EXTREME_CASES[name]())
    assert out["stable"], out["reason"]


def heavily_damped_block(safety: float | None = None) -> Run:
    physics = Physics().replace(bond_damping_ratio=2.0)
    if safety is not None:
        physics = physics.replace(timestep_safety=safety)
    return Run(Robot.box((4,) * 3, Material.SOFT), physics, settle=0.03, measured=0.0)


@pytest.mark.parametrize("bond_model", ["euler_bernoulli", "timoshenko"])
@pytest.mark.parametrize("zeta", [0.4, 2.0])
def test_time_step_rule_puts_the_limit_at_safety_one(bond_model, zeta):
    """`stiffest_bond_step` (rule "stiffest_bond") is Euler's stability limit of a block's
    damped bond network of tendon-law beams: a kicked 4³ block runs at safety 1.0 and
    diverges at 1.25, whatever the bond model and damping (measured on 4³ and 5³ blocks:
    stable at 1.0, unstable at 1.1, for ζ 0.4, 1 and 2; the engine's beams, with softer
    torsion, are stable at longer steps)."""
    def run(safety: float) -> bool:
        physics = Physics().replace(bond_damping_ratio=zeta, bond_model=bond_model,
                                    timestep_safety=safety, timestep_rule="stiffest_bond",
                                    beam_law="tendons", beam_damping="stiffness_proportional")
        return evaluate(Run(Robot.box((4,) * 3, Material.SOFT), physics, settle=0.03, measured=0.0,
                            kick=1e-3))["stable"]

    assert run(1.0)
    assert not run(1.25)


def test_automatic_time_step_is_stable_at_zeta_2():
    assert evaluate(heavily_damped_block())["stable"]


def test_explicit_instability_is_detected():
    """The stability search relies on the guard: a step far above the limit is flagged."""
    out = evaluate(replace(heavily_damped_block(), dt=4 * Physics().scene.timestep_safety
                           * 0.9 / (2 * math.pi * math.sqrt(1e7))))
    assert not out["stable"]


@pytest.mark.slow
def test_stability_search_finds_the_damped_block_limit():
    case = accuracy.Case("soft block 4^3 zeta 2", heavily_damped_block())
    row = accuracy.stability_search(case, iterations=2)
    assert float(row["max_stable_safety"]) < Physics().scene.timestep_safety


def test_walker_rows_summarise_shifted_starts_and_safeties():
    def out(distance, stable=True):
        return {"distance": distance, "dt": 1e-5, "stable": stable}

    robot = Robot.from_body(np.ones((2, 1, 1), dtype=np.int8))
    results = {("w", "default", 0): out(40.0)}
    for size in accuracy.PERTURBATIONS:
        for k, d in enumerate((20.0, 30.0, 40.0), start=1):
            results[("w", f"shift {size:g}", k)] = out(d)
        results[("w", f"shift {size:g}", 4)] = out(float("nan"), stable=False)
    for s, d in ((0.5, 38.0), (0.75, 40.0), (0.8, 45.0)):
        results[("w", "safety", s)] = out(d)
    (row,) = accuracy.walker_rows(results, {"w": robot})
    assert (row["robot"], row["voxels"], row["default"]) == ("w", 2, 40.0)
    for size in accuracy.PERTURBATIONS:  # the unstable run is left out
        assert [row[f"shift_{size:g}_{k}"] for k in ("mean", "min", "max")] == [30.0, 20.0, 40.0]
    assert (row["safeties_median"], row["safeties_min"], row["safeties_max"]) == (40.0, 38.0,
                                                                               45.0)
    text = accuracy.walker_section([row])
    assert "w (75 %)" in text  # 30 of 40 from the smallest shift: below accuracy.KEPT


def test_chaos_rows_summarise_the_runs_of_each_robot():
    """Per robot: the shifted starts' spread per size, the safeties' range, each friction
    rule's step ladder (the default rule's starts with the default run), the limit from
    the ladders' last steps and the default's distance from it."""
    def out(distance, stable=True):
        return {"distance": distance, "dt": 1e-5, "stable": stable}

    results = {("tripod", "default", 0): out(40.0)}
    for size in accuracy.PERTURBATIONS:
        for k, d in enumerate((39.0, 41.0, 40.0), start=1):
            results[("tripod", f"shift {size:g}", k)] = out(d)
    for s, d in ((0.5, 38.0), (0.75, 40.0), (0.8, 45.0)):
        results[("tripod", "safety", s)] = out(d)
    results[("tripod", "safety", 0.85)] = out(float("nan"), stable=False)
    for k in range(1, accuracy.HALVINGS + 1):
        results[("tripod", "ladder momentum", k)] = out(42.0 if k >= 3 else 41.0)
    for k in range(0, accuracy.HALVINGS + 1):
        results[("tripod", "ladder energy", k)] = out(42.5 if k >= 3 else 39.0)
        results[("tripod", "ladder fixed", k)] = out(30.0)  # not a limit ladder
    (row,) = accuracy.chaos_rows(results)
    assert row["default"] == 40.0
    assert all(row[f"shift_{size:g}_std"] == "1" for size in accuracy.PERTURBATIONS)
    assert (row["safeties_median"], row["safeties_min"], row["safeties_max"]) == (40.0, 38.0,
                                                                               45.0)
    assert row["ladder_momentum"] == "40.000 41.000 41.000 42.000 42.000 42.000"
    assert row["ladder_energy"].split()[0] == "39.000"
    assert row["ladder_fixed"] == " ".join(["30.000"] * (accuracy.HALVINGS + 1))
    assert (row["converged"], row["converged_spread"], row["default_error"]) == (42.25, 0.5,
                                                                               2.25)
