"""`benchmarks/speed.py`'s summary of the paper-size evolutions kept in records/."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from repo_modules import load_module

speed = load_module("benchmarks/speed.py")


def _record(folder: Path, seed: int, walls: list[float], distinct: list[int]) -> None:
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps(
        {"seed": seed, "ga": {"population": 10, "generations": 4}}))
    lines = ["generation,best,evaluations,distinct,wall_time,elapsed"]
    elapsed = 0.0
    for generation, (wall, count) in enumerate(zip(walls, distinct)):
        elapsed += wall
        lines.append(f"{generation},1.0,10,{count},{wall},{elapsed}")
    (folder / "metrics.csv").write_text("\n".join(lines) + "\n")


def test_rates_and_projection_come_from_the_generations_own_wall_times(tmp_path):
    _record(tmp_path / "3d_ff" / "seed_0", 0, [10.0, 20.0, 30.0, 40.0], [10, 9, 8, 7])
    _record(tmp_path / "3d_lstm" / "seed_3", 3, [50.0, 70.0], [10, 10])
    (tmp_path / "grow_regrow_ff" / "seed_0").mkdir(parents=True)  # not a paper-size condition
    (tmp_path / "3d_ff" / "seed_0" / "best").mkdir()
    last = np.zeros((3, 3, 3), dtype=np.int8)
    last[0, :, 0] = 1  # 3 voxels in its last generation's best robot
    np.save(tmp_path / "3d_ff" / "seed_0" / "best" / "gen_0003.npy", last)
    finished, unfinished = speed.recorded_evolutions(tmp_path, ("3d_ff", "3d_lstm"), "serial")
    assert finished["last_best_voxels"] == 3 and unfinished["last_best_voxels"] is None
    assert finished["run"] == "3d_ff seed 0" and finished["generations"] == 4
    assert finished["wall_h"] == pytest.approx(100.0 / 3600)
    assert finished["evaluations_per_s"] == pytest.approx(40 / 100.0)
    assert finished["simulated_per_s"] == pytest.approx(34 / 100.0)
    assert finished["planned_h"] == pytest.approx(finished["wall_h"])
    assert unfinished["run"] == "3d_lstm seed 3"
    assert (unfinished["generations"], unfinished["planned"]) == (2, 4)
    assert unfinished["planned_h"] == pytest.approx(2 * 120.0 / 3600)  # 4 generations at 60 s
    assert finished["median_generation_s"] == pytest.approx(25.0)
    assert finished["median_h"] == pytest.approx(4 * 25.0 / 3600)
    assert unfinished["median_h"] == pytest.approx(4 * 60.0 / 3600)


def test_only_the_given_conditions_count_and_bullets_cover_finished_runs(tmp_path, monkeypatch):
    monkeypatch.setattr(speed, "TWO_CORES", tmp_path / "none.json")  # no run on 2 cores
    _record(tmp_path / "3d_ff" / "seed_0", 0, [3600.0] * 4, [10] * 4)
    _record(tmp_path / "2d_ff" / "seed_1", 1, [900.0, 1800.0, 900.0, 900.0], [10] * 4)
    assert [r["run"] for r in speed.recorded_evolutions(tmp_path, ("2d_ff",))] == ["2d_ff seed 1"]
    both = speed.recorded_evolutions(tmp_path, ("3d_ff", "2d_ff"), "one run per core")
    bullets = speed.recorded_bullets(both)
    assert len(bullets) == 2
    assert "3D" in bullets[0] and "**4.00 h**" in bullets[0]
    assert "2D" in bullets[1] and "**1.25 h**" in bullets[1]  # 4500 s
    assert "median generation 1.00 h" in bullets[1]  # 4 x 900 s
    # a run that ran otherwise than its folder's others is named and counted apart
    monkeypatch.setitem(speed.RUN_SETTINGS, f"{tmp_path.name}/2d_ff/seed_1", "alone")
    apart = speed.recorded_evolutions(tmp_path, ("3d_ff", "2d_ff"), "one run per core")
    assert {r["run"]: r["how"] for r in apart} == {"3d_ff seed 0": "one run per core",
                                                   "2d_ff seed 1": "alone"}
    bullets = speed.recorded_bullets(apart)
    assert len(bullets) == 2
    assert any("one run per core): **4.00 h** of wall time; at its median" in b for b in bullets)
    assert any("alone): **1.25 h**" in b for b in bullets)
    assert "| alone |" in "\n".join(speed.recorded_section(apart))


def _metrics(folder: Path, rows: list[tuple[float, float, float, float]]) -> None:
    """metrics.csv of (best, mean, std, wall_time) per generation."""
    folder.mkdir(parents=True)
    lines = ["generation,best,mean,std,wall_time"]
    lines += [f"{g},{b},{m},{s},{w}" for g, (b, m, s, w) in enumerate(rows)]
    (folder / "metrics.csv").write_text("\n".join(lines) + "\n")


def test_a_run_evolved_again_is_compared_generation_by_generation(tmp_path, monkeypatch):
    first = [(1.0, 0.5, 0.1, 40.0), (2.0, 0.6, 0.2, 40.0), (3.0, 0.7, 0.3, 20.0)]
    _metrics(tmp_path / "3d_ff" / "seed_0", first)
    _metrics(tmp_path / "ga" / "seed_0", [(b, m, s, w / 2) for b, m, s, w in first[:2]])
    _metrics(tmp_path / "3d_ff" / "seed_1", first)
    _metrics(tmp_path / "ga" / "seed_1", [(1.0, 0.5, 0.1, 10.0), (2.0, 0.61, 0.2, 10.0)])
    monkeypatch.setattr(speed, "REPEATED", tmp_path / "ga")
    monkeypatch.setattr(speed, "ORIGINALS", tmp_path / "3d_ff")
    same, other = speed.repeated_runs()
    assert (same["run"], same["generations"], same["same"]) == ("3d_ff seed 0", 2, True)
    assert same["original_h"] == pytest.approx(80 / 3600)
    assert same["again_h"] == pytest.approx(40 / 3600)
    assert other["same"] is False  # its second generation's mean differs
    assert same["how"] == "one run per core, beside another"
    rerun = "/".join((tmp_path / "ga" / "seed_1").parts[-4:])  # as records/paper/qd/ga/seed_N
    monkeypatch.setitem(speed.RUN_SETTINGS, rerun, "2 worker processes, alone")
    assert speed.repeated_runs()[1]["how"] == "2 worker processes, alone"
    assert "| 2 worker processes, alone |" in "\n".join(speed.repeated_section())
    # a run's start on 2 cores: projected by the reference's share of time in those
    # generations (80 of 100 s)
    measured = {"what": "w", "date": "d", "commit": "c", "command": "x",
                "process_wall_s": 45.0, "process_cpu_s": 80.0,
                "reference": str(tmp_path / "3d_ff" / "seed_0"),
                "generations": [{**dict(zip(("best", "mean", "std"), map(str, row[:3]))),
                                 "wall_time": "20.0"} for row in first[:2]]}
    path = tmp_path / "two_cores.json"
    path.write_text(json.dumps([measured]))
    (run,) = speed.two_core_runs(path)
    assert run["wall_s"] == pytest.approx(40.0) and run["share"] == pytest.approx(0.8)
    assert run["projected_h"] == pytest.approx(50 / 3600)
    measured["generations"][1]["best"] = "2.5"
    path.write_text(json.dumps([measured]))
    with pytest.raises(ValueError, match="w: its generations are not those of"):
        speed.two_core_runs(path)
    assert speed.two_core_runs(tmp_path / "missing.json") == []


def test_a_measured_runs_workers_are_read_from_its_command():
    assert speed._workers("mjregen evolve --seed 7 --backend thread --workers 2") == "2 threads"
    assert speed._workers("python scripts/qd_comparison.py --seeds 2 --workers 2") == \
        "2 processes"  # the comparison's backend, and evolve's default
    assert speed._workers("mjregen evolve --backend process --workers 2") == "2 processes"
    assert speed._measured_part({"generations_done": 300, "planned": 300}) == "measured whole"
    assert speed._measured_part({"generations_done": 65, "planned": 300}) == \
        "65 generations measured"
