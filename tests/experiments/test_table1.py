"""Table 1 from several regrowth runs per row (`mjregen.experiments.table1`): grouping, the
spreads, the paper engine's walks kept beside the runs, and the report's table."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from mjregen.experiments.table1 import (
    ENGINE_FILE,
    Spread,
    grows_exactly,
    list_table1_runs,
    measure_in_engine,
    read_engine_distances,
    read_table1_run,
    runs_under_way,
    seed_growth_runs,
    table1_rows,
)
from mjregen.grid import Material
from mjregen.validation.engine import PaperEngine
from repo_modules import load_module

# a runner that walks every robot as far as it has voxels and logs each call
COUNTING_RUNNER = """
from pathlib import Path
HERE = Path(__file__).parent
def run(grid):
    with open(HERE / "calls.log", "a") as log:
        log.write("x")
    return {"distance": float((grid > 0).sum()), "cpu_s": 0.0}
"""


def _grid(voxels: int) -> np.ndarray:
    interior = np.zeros((7, 7, 7), np.int8)
    interior.reshape(-1)[:voxels] = int(Material.SOFT)
    return np.pad(interior, 1)


def fake_run(root: Path, name: str, seed: int, *, net="ff", start="saved", damage="paper cut",
             regrown_cells=700, distances=(40.0, 20.0, 30.0), voxels=(30, 10, 20),
             finished=True) -> Path:
    """A regrowth run folder as `mjregen regen` leaves it (only what Table 1 reads)."""
    folder = root / "table1" / name / f"seed_{seed}"
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps({
        "seed": seed, "ga": {"population": 8, "generations": 2},
        "task": {"task": "regrowth", "nca": {"kind": net}, "start": start, "damage": damage}}))
    (folder / "metrics.csv").write_text("generation,best,elapsed\n0,1,1800\n1,2,3600\n")
    roles = ("original", "damaged", "regrown")
    for role, n in zip(roles, voxels):
        np.save(folder / f"{role}.npy", _grid(n))
    if finished:
        original = distances[0]
        (folder / "recovery.json").write_text(json.dumps({
            "grid_cells": 729, "similarity": {"original": 729, "damaged": 600,
                                              "regrown": regrown_cells},
            "distance": dict(zip(roles, distances)),
            "percent_of_original": {role: 100 * d / original
                                    for role, d in zip(roles[1:], distances[1:])}}))
    return folder


@pytest.fixture
def root(tmp_path):
    for seed, (cells, regrown) in enumerate([(700, 30.0), (710, 36.0), (720, 24.0)]):
        fake_run(tmp_path, "biped_ff", seed, regrown_cells=cells,
                 distances=(40.0, 20.0, regrown))
    fake_run(tmp_path, "biped_lstm", 0, net="lstm", regrown_cells=650)
    fake_run(tmp_path, "tripod_ff_grown", 0, start="grown")
    fake_run(tmp_path, "tripod_from_seed", 0, damage="seed")  # grows the tripod: not a row
    fake_run(tmp_path, "biped_ff", 3, finished=False)  # under way: not counted
    return tmp_path


def test_rows_group_finished_runs_by_robot_network_and_start(root):
    rows = table1_rows(list_table1_runs(root))
    assert [(r.robot, r.net, r.start, len(r.runs)) for r in rows] == [
        ("biped", "ff", "saved", 3), ("biped", "lstm", "saved", 1), ("tripod", "ff", "grown", 1)]
    biped = rows[0]
    assert biped.similarity() == Spread(710.0, 700.0, 720.0, 3)
    assert biped.distance("regrown") == Spread(30.0, 24.0, 36.0, 3)
    assert biped.percent("regrown") == Spread(75.0, 60.0, 90.0, 3)
    assert biped.percent("damaged") == Spread(50.0, 50.0, 50.0, 3)
    assert biped.runs[0].generations == 2 and biped.runs[0].population == 8
    assert [(r.folder.parent.name, r.seed, r.generations, r.planned)
            for r in runs_under_way(root)] == [("biped_ff", 3, 2, 2)]


def test_the_engine_walks_each_grid_once_and_its_distances_are_kept(root):
    engine_folder = root / "engine"
    engine_folder.mkdir()
    (engine_folder / "vxa.py").write_text(COUNTING_RUNNER)
    measured = measure_in_engine(root, PaperEngine(engine_folder), progress=lambda _: None)
    # 5 finished rows' runs x 3 robots, of 3 distinct grids (30, 10 and 20 voxels)
    assert len(measured) == 15 and len((engine_folder / "calls.log").read_text()) == 3
    assert measured["table1/biped_ff/seed_1/regrown.npy"] == 20.0
    assert read_engine_distances(root) == measured
    measure_in_engine(root, PaperEngine(engine_folder), progress=lambda _: None)
    assert len((engine_folder / "calls.log").read_text()) == 3  # nothing walked again
    biped = table1_rows(list_table1_runs(root))[0]
    assert biped.engine_distance(root, measured, "regrown") == Spread(20.0, 20.0, 20.0, 3)
    assert biped.engine_percent(root, measured, "regrown").mean == pytest.approx(100 * 20 / 30)
    assert math.isnan(biped.engine_percent(root, {}, "regrown").mean)  # none measured


def test_a_damaged_engine_file_is_refused_by_name(root):
    (root / ENGINE_FILE).write_text('{"table1/x/original.npy": "far"}')
    with pytest.raises(ValueError, match=ENGINE_FILE):
        read_engine_distances(root)
    (root / ENGINE_FILE).write_text("{not json")
    with pytest.raises(ValueError, match="is not JSON"):
        read_engine_distances(root)


def test_the_report_shows_each_rows_spread_beside_the_papers_table(root, tmp_path):
    report = load_module("scripts/results_report.py")
    (root / ENGINE_FILE).write_text(json.dumps(
        {f"table1/biped_ff/seed_{s}/{role}.npy": d for s in range(3)
         for role, d in (("original", 40.0), ("damaged", 30.0), ("regrown", 10.0 * (s + 1)))}))
    out = tmp_path / "out" / "results.md"
    assert report.main(["--root", str(root), "--assets", str(tmp_path), "--out", str(out),
                        "--no-render"]) == 0
    text = out.read_text()
    biped = next(line for line in text.splitlines() if line.startswith("| Biped (feed-forward) | saved"))
    cells = [c.strip() for c in biped.strip("|").split("|")]
    assert cells[2] == "3 (8 × 2, 3 h)"  # each run's wall time: 1 h
    assert cells[3] == "710 (700–720) / 718"  # the paper's similarity beside ours
    assert cells[4] == "40 / 40 / 40.4"
    assert cells[5] == "50 % / 75 % / 67 %"
    assert cells[6] == "30 (24–36), 75 (60–90) %"
    assert cells[7] == "20 (10–30), 50 (25–75) %"
    assert cells[8] == "35.1, 86 %"
    assert "Table 1, biped regrown by feed-forward NCAs from the saved state (n = 3 runs)" in text
    lstm = next(line for line in text.splitlines() if line.startswith("| Biped (LSTM) | saved"))
    assert "| 40 / – | 50 % / – | 30, 75 % | –, – | – |" in lstm  # no engine walk, no paper row
    assert "Under way, not counted: table1/biped_ff/seed_3 (generation 2 of 2)." in text
    # compute: all 7 run folders, the one that grows the tripod from its seed included
    assert ("Table 1 at the paper's scale: 7 runs, those that grow a robot from its seed and "
            "those under way included, 7 h of wall time.") in text


def test_runs_that_grow_a_robot_from_its_seed_say_whether_a_grown_start_can_be_had(root, tmp_path):
    fake_run(root, "multiped_from_seed", 0, net="lstm", damage="seed", regrown_cells=729)
    fake_run(root, "biped_from_seed", 0, damage="seed", finished=False)
    runs = seed_growth_runs(root)
    assert [(r.folder.parent.name, grows_exactly(r)) for r in runs] == [
        ("biped_from_seed", False), ("multiped_from_seed", True), ("tripod_from_seed", False)]
    multiped = read_table1_run(root / "table1" / "multiped_from_seed" / "seed_0")
    assert (multiped.robot, multiped.net, multiped.damage) == ("multiped", "lstm", "seed")
    assert multiped not in list_table1_runs(root)  # not a row of the table
    report = load_module("scripts/results_report.py")
    out = tmp_path / "out" / "results.md"
    assert report.main(["--root", str(root), "--assets", str(tmp_path), "--out", str(out),
                        "--no-render"]) == 0
    text = out.read_text()
    assert ("- Tripod, grown from the seed (feed-forward NCA, 8 × 2, 1 h): 700 of 729 cells, "
            "29 wrong: no grown state of it, no grown row.") in text
    assert ("- Multiped, grown from the seed (LSTM NCA, 8 × 2, 1 h): 729 of 729 cells: exact, "
            "the start of the grown row.") in text
    assert "- Biped, grown from the seed (feed-forward NCA, 8 × 2): under way, generation 2." in text
    assert ("Tripod grown from the paper's seed (n = 1 run, feed-forward): 700 of 729 cells, so "
            "no grown start of it can be had.") in text
