"""The report of one NCA that grows and regrows: its cuts, regrowth and recovery walks."""

import numpy as np

from mjregen.experiments.self_regrowth import random_cuts, self_regrowth_report
from mjregen.grid import half_space_mask
from mjregen.growth.nca import NCA, NCAConfig
from mjregen.physics import Physics
from mjregen.search.backends import SerialBackend
from mjregen.tasks.grow_regrow import GrowRegrowTask


def test_report_of_a_grow_regrow_nca():
    nca = NCA.random(NCAConfig(dim=3, kind="ff"), seed=5)
    physics = Physics().replace(settle_time=0.01)
    # walked as the fitness of a run of seed 3 walks them: from start 0 of start seed 3
    report = self_regrowth_report(nca, physics=physics, duration=0.02, cuts=["z > 4", "y < 3"],
                                  start_seed=3)
    assert list(report.similarity) == ["paper", "z > 4", "y < 3"] and report.cells == 729
    task = GrowRegrowTask(nca=nca.config, physics=physics, duration=0.02, start_seed=3,
                          regrown_weight=0.5)
    evaluated = task.evaluate(nca.genome[None], SerialBackend())
    assert report.similarity["paper"] == evaluated.details["similarity"][0]
    recovery = report.recovery
    assert recovery.similarity["regrown"] == report.similarity["paper"]
    original = nca.grow().robot()
    assert recovery.voxels["original"] == original.n_voxels
    assert recovery.distance["original"] == evaluated.details["distance"][0]
    assert recovery.distance["regrown"] == evaluated.details["regrown_distance"][0]
    assert recovery.distance["original"] != self_regrowth_report(
        nca, physics=physics, duration=0.02, cuts=[]).recovery.distance["original"]
    damaged_cells = np.count_nonzero(original.grid[half_space_mask((9, 9, 9), "x < 4")])
    assert recovery.voxels["damaged"] <= original.n_voxels - damaged_cells


def test_random_cuts_are_distinct_valid_and_repeatable():
    cuts = random_cuts(8, dim=3, grid_size=9, seed=1)
    assert len(set(cuts)) == 8 and cuts == random_cuts(8, dim=3, grid_size=9, seed=1)
    for cut in cuts:
        mask = half_space_mask((9, 9, 9), cut)
        assert 0 < np.count_nonzero(mask[1:-1, 1:-1, 1:-1]) < 343  # cuts into the interior
    assert all(cut.split()[0] in "xz" for cut in random_cuts(5, dim=2, grid_size=7))
