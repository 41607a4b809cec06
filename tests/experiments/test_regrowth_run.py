"""`run_regrowth`, the library call behind `mjregen regen` and the regrowth experiment, and
where a regrowth starts from (`regrowth_source`)."""

import json

import numpy as np
import pytest

from mjregen.errors import MjregenError
from mjregen.experiments.regrowth import regrowth_source, run_regrowth
from mjregen.grid import Robot
from mjregen.growth.checkpoint import load_nca
from mjregen.growth.nca import NCAConfig
from mjregen.physics import Physics
from mjregen.resources import asset
from mjregen.search.ga import PRESETS
from mjregen.tasks.regrowth import similarity

WALKER_2D = asset("robots", "bimorph_walker_2d.npy")
TINY_GA = PRESETS["regen"].with_overrides(population=8, generations=2, truncation=4, elites=2)


def test_a_regrowth_starts_from_exactly_one_source():
    with pytest.raises(MjregenError, match="exactly one"):
        regrowth_source()
    with pytest.raises(MjregenError, match="exactly one"):
        regrowth_source(robot=WALKER_2D, paper="biped")
    with pytest.raises(MjregenError, match="unknown paper robot 'hexapod'"):
        regrowth_source(paper="hexapod")
    tripod = regrowth_source(paper="tripod")
    assert tripod.robot == Robot.load(asset("robots", "paper", "tripod.npy"))
    alpha = tripod.state.alpha[0].numpy()
    assert np.array_equal(alpha, (tripod.robot.grid != 0).astype(np.float32))  # alpha 1
    assert tripod.label == "assets/robots/paper/tripod.npy" and tripod.start == "alpha 1"


def test_run_regrowth_returns_what_it_writes(tmp_path):
    physics = Physics().replace(settle_time=0.05)
    run = run_regrowth(source=regrowth_source(robot=WALKER_2D), out=tmp_path / "run",
                       ga=TINY_GA, seed=3, physics=physics, duration=0.05, progress=False)
    assert run.summary.generations == 2
    for role, robot in run.robots.items():
        assert Robot.load(tmp_path / "run" / f"{role}.npy") == robot
    assert run.robots["regrown"] == run.regrowth.robot()
    original = run.robots["original"].grid
    assert run.summary.best_fitness == similarity(run.regrowth.grids, original)[0]
    assert json.loads((tmp_path / "run" / "recovery.json").read_text()) == run.report.to_dict()
    config = json.loads((tmp_path / "run" / "config.json").read_text())
    assert config["task"]["damage"] == "paper cut"
    assert config["task"]["nca"] == NCAConfig(dim=2, kind="ff").to_dict()
    assert config["task"]["original"] == original.tolist()
    metadata = load_nca(tmp_path / "run" / "regrowth.npz")[1]  # what it regrows, as run
    for key in ("source", "start", "damage", "original", "damaged_state", "damaged_alpha"):
        assert metadata[key] == config["task"][key], key


def test_damage_seed_evolves_an_nca_that_grows_the_robot_from_the_seed(tmp_path):
    physics = Physics().replace(settle_time=0.05)
    run = run_regrowth(source=regrowth_source(robot=WALKER_2D), out=tmp_path / "run",
                       damage="seed", ga=TINY_GA, seed=1, physics=physics, duration=0.05,
                       progress=False)
    config = json.loads((tmp_path / "run" / "config.json").read_text())["task"]
    assert config["damage"] == "seed"
    assert np.count_nonzero(config["damaged_state"]) == 1  # the seed, at the centre
    assert config["damaged_state"][3][3] != 0
    # its regrowth NCA, given as a checkpoint, grows what the run regrew: a grown start
    grown = regrowth_source(checkpoint=tmp_path / "run" / "regrowth.npz")
    assert grown.start == "grown" and grown.robot == run.robots["regrown"]
    assert np.array_equal(grown.state.state[0].numpy(), run.robots["regrown"].grid)
