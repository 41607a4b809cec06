"""The locomotion-recovery table comes from real simulations."""

import json

import pytest

from mjregen.experiments.recovery import measure_recovery, write_report
from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate

WALKER = Robot.load("assets/robots/paper/tripod.npy")  # walks 4.2 voxel lengths in 0.1 s
QUICK = Physics().replace(settle_time=0.01)


def test_recovery_table_from_real_simulations(tmp_path):
    damaged = WALKER.remove_half_space("x < 3")
    report = measure_recovery({"original": WALKER, "damaged": damaged, "regrown": WALKER},
                              physics=QUICK, duration=0.1)
    walked = simulate(WALKER, physics=QUICK, duration=0.1).distance
    assert walked > 1.0  # it really walks
    assert report.distance["original"] == walked == report.distance["regrown"]
    assert report.distance["damaged"] == simulate(damaged, physics=QUICK, duration=0.1).distance
    assert report.percent_of_original("regrown") == pytest.approx(100.0)
    assert report.similarity == {"original": 729, "damaged": 729 - (WALKER.n_voxels - damaged.n_voxels),
                                 "regrown": 729}
    assert report.robot_similarity["regrown"] == 1.0 and report.voxels["damaged"] < WALKER.n_voxels
    md, js = write_report(report, tmp_path, name="walker")
    assert "| walker | 729 (damaged" in md.read_text()
    assert json.loads(js.read_text())["percent_of_original"]["regrown"] == pytest.approx(100.0)


def test_recovery_needs_all_three_robots():
    with pytest.raises(ValueError, match="regrown"):
        measure_recovery({"original": WALKER, "damaged": WALKER})
