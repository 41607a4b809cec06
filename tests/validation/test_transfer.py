"""The transfer check (`mjregen.validation`): turned copies of a robot, the rule, and the
paper's engine as a user's folder holds it (here a stand-in runner and engine binary)."""

import sys

import numpy as np
import pytest

from mjregen.errors import MjregenError
from mjregen.grid import Material, Robot, lay_flat
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate, simulate_starts
from mjregen.resources import asset
from mjregen.validation.engine import PaperEngine
from mjregen.validation.transfer import (
    ENGINE,
    FINER_STEP,
    KEEP,
    Transfer,
    measure_transfer,
    read_measurements,
    rotations,
)

TRIPOD = Robot.load(asset("robots", "paper", "tripod.npy"))


STAND_IN_RUNNER = """
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
ENGINES = {{"O3": HERE / "engine"}}
DISTANCE = {distance!r}


def vxa_text(grid, folder):
    return ("<VXA><DtFrac>0.9</DtFrac><StopConditionValue>1</StopConditionValue>"
            "<InitCmTime>0</InitCmTime><SelfColEnabled>0</SelfColEnabled><Voxels>"
            + str(int((grid > 0).sum())) + "</Voxels></VXA>")


def run(grid):
    assert grid.ndim == 3 and grid.any()
    if DISTANCE is None:
        raise RuntimeError("the engine crashed")
    return {{"distance": DISTANCE, "cpu_s": 0.0}}
"""
# the engine binary's stand-in: its distance spells out the settings it was given
STAND_IN_ENGINE = """#!{python}
import re, sys
text = open(sys.argv[2]).read()
value = {{tag: float(re.search(f"<{{tag}}>([^<]*)<", text).group(1))
         for tag in ("DtFrac", "StopConditionValue", "InitCmTime", "SelfColEnabled")}}
distance = (100 * value["DtFrac"] + 10 * value["StopConditionValue"] + value["InitCmTime"]
            + 1000 * value["SelfColEnabled"])
if distance > 0:
    open("fitness.xml", "w").write(f"<NormFinalDist>{{distance!r}}</NormFinalDist>")
sys.exit(1)
"""


def stand_in_engine(folder, distance: float | None) -> PaperEngine:
    """A folder whose runner answers `distance` for any 3D robot (None: it fails) and whose
    engine binary reports the settings it was given."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "vxa.py").write_text(STAND_IN_RUNNER.format(distance=distance))
    engine = folder / "engine"
    engine.write_text(STAND_IN_ENGINE.format(python=sys.executable))
    engine.chmod(0o755)
    return PaperEngine(folder)


def test_turned_copies_are_the_same_robot_turned_about_z():
    turned = rotations(TRIPOD)
    assert len(turned) == 3
    grid = np.asarray(TRIPOD.grid)
    for k, robot in enumerate(turned, start=1):
        assert robot.n_voxels == TRIPOD.n_voxels
        assert np.array_equal(np.rot90(np.asarray(robot.grid), -k, axes=(0, 1)), grid)
        # turned about the vertical: every layer keeps its voxels
        assert np.array_equal(np.count_nonzero(robot.grid, axis=(0, 1)),
                              np.count_nonzero(grid, axis=(0, 1)))
    flat = np.zeros((4, 3), dtype=np.int8)
    flat[1:3, 1] = [3, 4]
    mirrored, = rotations(Robot(flat))
    assert np.array_equal(np.asarray(mirrored.grid), flat[::-1, :])


def test_the_rule_needs_fresh_starts_turns_a_finer_step_and_the_engine():
    walks = dict(name="r", voxels=1, mirror_axes=[], starts=[10.0, 10.0], fresh=[9.0, 9.0],
                 rotated=[9.0, 9.0, 9.0], exact=10.0, finer_step=[9.0, 9.0], engine=8.0)
    assert Transfer(**walks).transfers  # exactly at the thresholds
    assert (KEEP, ENGINE, FINER_STEP) == (0.9, 0.8, 0.5)
    for change in ({"fresh": [8.9, 9.0]}, {"rotated": [9.0, 9.0, 8.9]}, {"finer_step": [8.9, 9.0]},
                   {"engine": 7.9}, {"engine": None}):
        assert not Transfer(**{**walks, **change}).transfers, change


def test_measure_transfer_walks_every_way_and_asks_the_engine(tmp_path):
    engine = stand_in_engine(tmp_path / "engine", 36.5)
    row = measure_transfer(TRIPOD, name="tripod", starts=2, engine=engine)
    assert row.starts == [r.distance for r in simulate_starts(TRIPOD, starts=range(2))]
    assert row.fresh == [r.distance for r in simulate_starts(TRIPOD, start_seed=1,
                                                              starts=range(2))]
    assert row.rotated == [simulate(r).distance for r in rotations(TRIPOD)]
    safety = Physics().scene.timestep_safety
    finer = simulate_starts(TRIPOD, physics=Physics().replace(
        timestep_safety=safety * FINER_STEP), starts=range(2))  # the same starts
    assert finer[1].steps == pytest.approx(2 * simulate(TRIPOD, start=1).steps, abs=2)
    assert row.finer_step == [r.distance for r in finer]
    assert row.engine == 36.5 and row.engine_ratio == pytest.approx(36.5 / row.distance)
    # the tripod's gait is its own, not an artefact: it keeps its walk every way
    assert row.fresh_kept > KEEP and row.rotated_kept > KEEP and row.finer_step_kept > KEEP
    assert row.transfers
    assert measure_transfer(TRIPOD, starts=1).engine is None  # no engine: no verdict
    assert not measure_transfer(TRIPOD, starts=1).transfers


def test_a_window_run_gives_the_engine_its_step_duration_and_measurement(tmp_path):
    engine = stand_in_engine(tmp_path / "engine", 1.0)
    out = engine.run_window(TRIPOD.grid, dt_fraction=0.45, stop=0.55, measure_from=0.05)
    assert out["distance"] == pytest.approx(100 * 0.45 + 10 * 0.55 + 0.05)
    assert out["cpu_s"] >= 0.0
    assert out["dy"] is None and out["on_floor"] is None  # the stand-in writes only the distance
    with pytest.raises(MjregenError, match="wrote no distance .* at DtFrac 0.0"):
        engine.run_window(TRIPOD.grid, dt_fraction=0.0, stop=0.0, measure_from=0.0)
    # another element of the settings, by its tag
    on = engine.run_window(TRIPOD.grid, dt_fraction=0.45, stop=0.55, measure_from=0.05,
                           settings={"SelfColEnabled": 1})
    assert on["distance"] == pytest.approx(out["distance"] + 1000)
    with pytest.raises(MjregenError, match="have 0 <NoSuchTag> elements"):
        engine.run_window(TRIPOD.grid, dt_fraction=0.45, stop=0.55, measure_from=0.05,
                          settings={"NoSuchTag": 1})


def test_the_engine_is_refused_clearly_when_it_is_not_there_or_fails(tmp_path):
    with pytest.raises(MjregenError, match="holds no vxa.py"):
        PaperEngine(tmp_path)
    broken = stand_in_engine(tmp_path / "broken", None)
    with pytest.raises(MjregenError, match="failed: RuntimeError: the engine crashed"):
        broken.distance(TRIPOD)
    sheet = np.zeros((3, 3), dtype=np.int8)
    sheet[1, 1] = 1
    assert broken.distance(Robot(sheet)) is None  # 2D: not run


def test_the_engine_walks_a_robot_for_the_times_it_is_given(tmp_path):
    """A 2D run's sheet walks for the 2D times in the engine as in mjregen; the paper's 3D
    times are the runner's own run."""
    engine = stand_in_engine(tmp_path / "engine", 1.0)
    assert engine.distance(TRIPOD) == engine.distance(TRIPOD, times=(0.05, 0.5)) == 1.0
    assert engine.distance(TRIPOD, times=(1.0, 0.25)) == pytest.approx(100 * 0.9 + 10 * 1.25
                                                                        + 1.0)


def test_a_sheet_is_measured_for_its_times_in_mjregen_and_in_the_engine(tmp_path):
    engine = stand_in_engine(tmp_path / "engine", 1.0)
    sheet = Robot(lay_flat(np.pad(np.full((3, 3), Material.MUSCLE_PLUS, np.int8), 1)))
    quick = Physics().replace(settle_time=0.02, measured_time=0.03)
    row = measure_transfer(sheet, starts=1, engine=engine, physics=quick)
    assert row.starts == [simulate(sheet, physics=quick).distance]
    assert row.engine == pytest.approx(100 * 0.9 + 10 * 0.05 + 0.02)


def test_kept_measurements_are_read_by_name_and_anything_else_is_refused(tmp_path):
    path = tmp_path / "transfer.json"
    assert read_measurements(path) == {}  # nothing measured yet
    path.write_text('[{"name": "3d_ff/seed_0/best/gen_0001.npy", "engine": 2.0}, '
                    '{"name": "b", "engine": 1.0}]')
    kept = read_measurements(path)
    assert list(kept) == ["3d_ff/seed_0/best/gen_0001.npy", "b"] and kept["b"]["engine"] == 1.0
    for bad in ('{"name": "a"}', '[{"engine": 1.0}]', '[1, 2]'):
        path.write_text(bad)
        with pytest.raises(ValueError, match="transfer.json is not a list of transfer"):
            read_measurements(path)
