"""Walk timelines (`mjregen.validation.timeline`): sampled as the fitness measures, a resting
block's floor contacts and height, and the engine's answers read from its fitness file
(here a stand-in engine that writes them)."""

import math
import sys

import numpy as np
import pytest

from mjregen.errors import MjregenError
from mjregen.grid import Material, Robot
from mjregen.physics import PAPER_TIMES, Physics
from mjregen.physics.simulation import simulate
from mjregen.resources import asset
from mjregen.validation.engine import PaperEngine
from mjregen.validation.timeline import check_times, engine_timeline, mjregen_timeline

TRIPOD = Robot.load(asset("robots", "paper", "tripod.npy"))
SETTLE, MEASURED = PAPER_TIMES[3]


def test_the_timeline_ends_at_the_distance_simulate_measures():
    end = SETTLE + MEASURED
    points = mjregen_timeline(TRIPOD, [0.1, 0.3, end])
    walked = simulate(TRIPOD)  # the same physics and start (start 0 of seed 0)
    assert [p.time for p in points] == [0.1, 0.3, end]
    assert points[-1].distance == walked.distance  # bit for bit: the same steps
    assert points[-1].dy == walked.displacement[1]
    # the tripod walks: it is further at the end than after the first 50 ms
    assert points[-1].distance > 10 * points[0].distance > 0.0


def test_a_2d_timeline_measures_along_x_only():
    bimorph = Robot.load(asset("robots", "bimorph_walker_2d.npy"))  # in the x-z plane
    settle, measured = Physics().scene.timing(2)
    points = mjregen_timeline(bimorph, [settle + measured / 2, settle + measured])
    walked = simulate(bimorph)
    assert points[-1].distance == walked.distance and points[-1].dy == 0.0
    assert points[-1].on_floor >= 1  # it walks on the floor


def test_a_resting_block_stays_put_on_its_bottom_layer():
    block = Robot(np.pad(np.full((2, 2, 2), int(Material.SOFT), np.int8), 1))
    points = mjregen_timeline(block, [0.06, 0.1], physics=Physics().replace(start_shift=0.0))
    for point in points:
        assert point.on_floor == 4  # the bottom layer's voxels, centres below L/2
        assert point.distance < 1e-6 and abs(point.dy) < 1e-6
        # COM one voxel length up, less the floor spring's sag under the block's weight
        assert 0.97 < point.height < 1.0


@pytest.mark.parametrize("times, message", [
    ([], "at least one time"),
    ([0.01, 0.1], "after the settle"),
    ([0.1, math.nan], "after the settle"),
    ([0.2, 0.1], "must increase"),
    ([0.1, 0.1], "must increase"),
])
def test_bad_times_are_refused(times, message):
    with pytest.raises(MjregenError, match=message):
        check_times(times, SETTLE)


RUNNER = """
from pathlib import Path
HERE = Path(__file__).parent
ENGINES = {{"O3": HERE / "engine"}}


def vxa_text(grid, folder):
    return ("<VXA><DtFrac>0.9</DtFrac><StopConditionValue>1</StopConditionValue>"
            "<InitCmTime>0</InitCmTime></VXA>")
"""
# the engine's stand-in: the distance is the stop time x 10, the y distance its negative half,
# the voxels on the floor the stop time in centiseconds; `fields` chooses what it writes
ENGINE = """#!{python}
import re, sys
stop = float(re.search("<StopConditionValue>([^<]*)<", open(sys.argv[2]).read()).group(1))
fields = {{"NormFinalDist": 10 * stop, "finalDistY": -5 * stop, "NumTouchingFloor": 100 * stop}}
open("fitness.xml", "w").write("".join(f"<{{tag}}>{{fields[tag]!r}}</{{tag}}>" for tag in {fields}))
sys.exit(1)
"""


def stand_in(folder, fields) -> PaperEngine:
    folder.mkdir()
    (folder / "vxa.py").write_text(RUNNER.format())
    (folder / "engine").write_text(ENGINE.format(python=sys.executable, fields=fields))
    (folder / "engine").chmod(0o755)
    return PaperEngine(folder)


def test_the_engine_timeline_reads_distance_y_and_floor_contacts(tmp_path):
    engine = stand_in(tmp_path / "full", ["NormFinalDist", "finalDistY", "NumTouchingFloor"])
    points = engine_timeline(engine, TRIPOD, [0.1, 0.3])
    assert [(p.time, p.distance, p.dy, p.on_floor, p.height) for p in points] == [
        (0.1, pytest.approx(1.0), pytest.approx(-0.5), 10, None),
        (0.3, pytest.approx(3.0), pytest.approx(-1.5), 30, None)]
    only_distance = stand_in(tmp_path / "old", ["NormFinalDist"])
    with pytest.raises(MjregenError, match="no finalDistY or NumTouchingFloor"):
        engine_timeline(only_distance, TRIPOD, [0.1])
    with pytest.raises(MjregenError, match="runs 3D robots"):
        engine_timeline(engine, Robot(np.pad(np.full((3, 2), int(Material.SOFT), np.int8), 1)),
                        [0.1])
