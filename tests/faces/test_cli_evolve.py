"""`mjregen evolve` and `mjregen evolve-stats` end to end on tiny 2D runs, including a real
kill (SIGKILL) mid-run and --resume."""

import csv
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from mjregen.cli import main


# Tiny, fast runs: 2D, 6 individuals, short settle and walk.
def tiny(seed: int = 1) -> list[str]:
    return ["--dim", "2", "--pop", "6", "--truncation", "3", "--elites", "1", "--settle", "0.02",
            "--duration", "0.02", "--seed", str(seed), "--quiet"]


TINY = tiny()


def best_column(out):
    with open(out / "metrics.csv") as handle:
        return [(r["generation"], r["best"], r["mean"]) for r in csv.DictReader(handle)]


def test_evolve_writes_a_run_and_resume_with_no_flags(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["evolve", *TINY, "--gens", "2", "--backend", "serial", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["generations"] == 2 and (out / "best" / "gen_0001.npz").is_file()
    assert len(best_column(out)) == 2
    # a finished run resumes to itself; conflicting flags are refused
    assert main(["evolve", "--out", str(out), "--resume", "--backend", "serial", "--quiet"]) == 0
    assert main(["evolve", "--out", str(out), "--resume", "--pop", "7", "--quiet"]) == 1
    assert "--pop 7" in capsys.readouterr().err
    assert main(["evolve", "--out", str(out), "--resume", "--physics", "sphere", "--quiet"]) == 1
    assert "--physics sphere" in capsys.readouterr().err
    assert main(["evolve", "--out", str(out), "--resume", "--bonds", "tendons", "--quiet"]) == 1
    assert "--bonds tendons (run has beam)" in capsys.readouterr().err
    assert main(["evolve", "--out", str(out), "--resume", "--timestep-rule", "stiffest_bond",
                 "--quiet"]) == 1
    assert "--timestep-rule stiffest_bond (run has network)" in capsys.readouterr().err
    assert main(["evolve", *TINY, "--gens", "2", "--out", str(out)]) == 1
    error = capsys.readouterr().err
    assert "not empty" in error and "--resume" in error and "--force" in error


def test_sigkill_mid_run_then_resume_equals_an_uninterrupted_run(tmp_path):
    full, killed = tmp_path / "full", tmp_path / "killed"
    assert main(["evolve", *TINY, "--gens", "4", "--backend", "serial", "--out", str(full)]) == 0
    command = [sys.executable, "-m", "mjregen.cli", "evolve", *TINY, "--gens", "4",
               "--backend", "serial", "--out", str(killed)]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline and process.poll() is None:
        metrics = killed / "metrics.csv"
        if metrics.is_file() and len(metrics.read_text().splitlines()) >= 2:  # one generation done
            break
        time.sleep(0.05)
    if process.poll() is not None:
        pytest.fail("the run finished before it could be killed")
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    assert len(best_column(killed)) < 4
    assert main(["evolve", "--out", str(killed), "--resume", "--backend", "serial", "--quiet"]) == 0
    assert best_column(killed) == best_column(full)


@pytest.mark.parametrize("body", ["grid", "sheet"])
def test_process_and_serial_backends_give_the_same_run(tmp_path, body):
    serial, process = tmp_path / "serial", tmp_path / "process"
    flags = [*TINY, "--body", body, "--gens", "2"]
    assert main(["evolve", *flags, "--backend", "serial", "--out", str(serial)]) == 0
    assert main(["evolve", *flags, "--backend", "process", "--workers", "2",
                 "--out", str(process)]) == 0
    assert best_column(serial) == best_column(process)


def test_evolve_stats(tmp_path, capsys):
    runs = []
    for seed in (1, 2):
        out = tmp_path / f"run{seed}"
        assert main(["evolve", *tiny(seed), "--gens", "2", "--backend", "serial", "--out", str(out)]) == 0
        runs.append(str(out))
    capsys.readouterr()
    png = tmp_path / "curves.png"
    assert main(["evolve-stats", "--group", "ff", *runs, "--out", str(png), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["ff"]["runs"] == 2 and len(report["ff"]["mean"]) == 2
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert main(["evolve-stats", "--group", "a", runs[0], "--group", "b", runs[1], "--out",
                 str(png), "--force"]) == 0
    text = capsys.readouterr().out
    assert "Mann-Whitney U" in text and "the smallest Mann-Whitney p these sizes allow: 1" in text
    assert main(["evolve-stats", "--group", "a", runs[0], "--group", "b", runs[1], "--out",
                 str(png), "--force", "--json"]) == 0
    comparison = json.loads(capsys.readouterr().out)["comparison"]
    assert comparison["sizes"] == [1, 1] and comparison["p_mann_whitney"] == 1.0
    assert main(["evolve-stats", "--group", "x", str(tmp_path / "nope"), "--out", str(png)]) == 1
    assert main(["evolve-stats", "--group", "a", runs[0], "--group", "a", runs[1], "--out",
                 str(png), "--force"]) == 1
    assert "given more than once" in capsys.readouterr().err
    assert main(["evolve-stats", "--group", "a", *runs, "--out", str(tmp_path / "x.jpg")]) == 1
    assert "name a .png file" in capsys.readouterr().err and not (tmp_path / "x.jpg").exists()


def test_grow_regrow_runs_resume_and_refuse_other_settings(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["evolve", *TINY, "--task", "grow-regrow", "--cut", "z > 3", "--cell-cost",
                 "0.3", "--gens", "2", "--backend", "serial", "--out", str(out)]) == 0
    config = json.loads((out / "config.json").read_text())["task"]
    assert (config["task"], config["cut"], config["cell_cost"]) == ("grow-regrow", "z > 3", 0.3)
    with open(out / "metrics.csv") as handle:
        assert len(list(csv.DictReader(handle))) == 2
    assert main(["evolve", "--out", str(out), "--resume", "--backend", "serial", "--quiet"]) == 0
    assert main(["evolve", "--out", str(out), "--resume", "--cell-cost", "1", "--quiet"]) == 1
    assert "--cell-cost 1.0 (run has 0.3)" in capsys.readouterr().err
    assert main(["evolve", *TINY, "--cut", "x < 3", "--out", str(tmp_path / "b")]) == 1
    assert "--cut: grow-regrow settings; add --task grow-regrow" in capsys.readouterr().err


def test_grow_regrow_judged_by_the_regrown_walk_too(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["evolve", *TINY, "--task", "grow-regrow", "--regrown-weight", "0.5",
                 "--cell-cost", "0", "--gens", "1", "--backend", "serial", "--out",
                 str(out)]) == 0
    config = json.loads((out / "config.json").read_text())["task"]
    assert (config["regrown_weight"], config["cell_cost"]) == (0.5, 0.0)
    assert main(["evolve", "--out", str(out), "--resume", "--regrown-weight", "1",
                 "--quiet"]) == 1
    assert "--regrown-weight 1.0 (run has 0.5)" in capsys.readouterr().err
    assert main(["evolve", *TINY, "--task", "grow-regrow", "--regrown-weight", "2", "--out",
                 str(tmp_path / "b")]) == 1
    assert "regrown_weight must be in [0, 1], got 2.0" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()


def test_sheet_runs_store_their_body_resume_and_refuse_another(tmp_path, capsys):
    out = tmp_path / "sheet"
    assert main(["evolve", *TINY, "--body", "sheet", "--gens", "2", "--backend", "serial",
                 "--out", str(out)]) == 0
    config = json.loads((out / "config.json").read_text())
    assert config["task"]["body"] == "sheet"
    robot = np.load(out / "best" / "gen_0001.npy")
    assert robot.shape == (7, 7, 3) and not robot[:, :, [0, 2]].any()  # one layer
    assert main(["evolve", "--out", str(out), "--resume", "--backend", "serial", "--quiet"]) == 0
    assert main(["evolve", "--out", str(out), "--resume", "--body", "grid", "--quiet"]) == 1
    assert "--body grid (run has sheet)" in capsys.readouterr().err
    for flags in (["--dim", "3"], ["--dim", "2", "--task", "grow-regrow"]):
        assert main(["evolve", *flags, "--body", "sheet", "--out", str(tmp_path / "no")]) == 1
        assert "--body sheet lays a 2D pattern flat" in capsys.readouterr().err
    assert main(["evolve", "--dim", "2", "--body", "sheet", "--optimizer", "map-elites",
                 "--out", str(tmp_path / "no")]) == 1
    assert "--body sheet: MAP-Elites searches grown grids only" in capsys.readouterr().err
