"""`mjregen evolve --optimizer map-elites` end to end: a tiny 3D run writes archive,
heatmap and gallery; a real SIGKILL mid-run and --resume give the uninterrupted run; serial
and process backends agree; `evolve-stats` draws QD score and coverage over runs."""

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
from mjregen.search.qd_runs import read_archive


def tiny(dim: int = 2, seed: int = 1) -> list[str]:
    return ["--optimizer", "map-elites", "--dim", str(dim), "--pop", "6", "--emitters", "2",
            "--settle", "0.02", "--duration", "0.02", "--seed", str(seed), "--quiet"]


def metrics(out):
    with open(out / "metrics.csv") as handle:
        return [(r["iteration"], r["qd_score"], r["coverage"], r["best"])
                for r in csv.DictReader(handle)]


def test_a_tiny_3d_run_writes_archive_heatmap_and_gallery(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["evolve", *tiny(dim=3), "--descriptors", "voxels,muscle,feet", "--cells",
                 "6,4,3", "--gens", "2", "--backend", "serial", "--out", str(out),
                 "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["iterations"] == 2 and report["elites"] >= 1
    archive = read_archive(out / "archive.npz")
    assert archive.descriptors == ("voxels", "muscle", "feet")
    assert archive.snapshot.cells == (6, 4, 3)
    assert report["best_fitness"] == pytest.approx(archive.snapshot.fitness.max())
    assert report["qd_score"] == pytest.approx((archive.snapshot.fitness + 21.0).sum())
    assert report["coverage"] == pytest.approx(len(archive.snapshot.index) / 72)
    for picture in ("heatmap.png", "qd.png", "gallery.png"):
        assert (out / picture).read_bytes()[:4] == b"\x89PNG"
    config = json.loads((out / "config.json").read_text())
    assert config["map_elites"]["batch"] == 6 and config["map_elites"]["sigma"] == 0.1
    # resuming with other settings, or as the GA, is refused
    assert main(["evolve", "--out", str(out), "--resume", "--cells", "5", "--quiet"]) == 1
    assert "--cells (5, 5, 5) (run has (6, 4, 3))" in capsys.readouterr().err
    assert main(["evolve", "--out", str(out), "--resume", "--optimizer", "ga"]) == 1
    assert "holds a map-elites run" in capsys.readouterr().err


def test_ga_and_map_elites_flags_are_not_mixed(tmp_path, capsys):
    assert main(["evolve", *tiny(), "--truncation", "3", "--out", str(tmp_path / "a")]) == 1
    assert "--truncation set the GA" in capsys.readouterr().err
    assert main(["evolve", "--dim", "2", "--cells", "4", "--out", str(tmp_path / "b")]) == 1
    assert "add --optimizer map-elites" in capsys.readouterr().err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_sigkill_mid_run_then_resume_equals_an_uninterrupted_run(tmp_path):
    full, killed = tmp_path / "full", tmp_path / "killed"
    common = [*tiny(), "--gens", "4", "--backend", "serial", "--no-gallery"]
    assert main(["evolve", *common, "--out", str(full)]) == 0
    process = subprocess.Popen([sys.executable, "-m", "mjregen.cli", "evolve", *common,
                                "--out", str(killed)],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline and process.poll() is None:
        path = killed / "metrics.csv"
        if path.is_file() and len(path.read_text().splitlines()) >= 2:  # one iteration done
            break
        time.sleep(0.05)
    if process.poll() is not None:
        pytest.fail("the run finished before it could be killed")
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    assert len(metrics(killed)) < 4
    assert main(["evolve", "--out", str(killed), "--resume", "--backend", "serial",
                 "--quiet", "--no-gallery"]) == 0
    assert metrics(killed) == metrics(full)
    a = read_archive(full / "archive.npz").snapshot
    b = read_archive(killed / "archive.npz").snapshot
    assert np.array_equal(a.index, b.index) and np.array_equal(a.genomes, b.genomes)


def test_process_and_serial_backends_give_the_same_run(tmp_path):
    serial, process = tmp_path / "serial", tmp_path / "process"
    common = [*tiny(), "--gens", "2", "--no-gallery"]
    assert main(["evolve", *common, "--backend", "serial", "--out", str(serial)]) == 0
    assert main(["evolve", *common, "--backend", "process", "--workers", "2",
                 "--out", str(process)]) == 0
    assert metrics(serial) == metrics(process)


def test_evolve_stats_of_map_elites_runs(tmp_path, capsys):
    runs = []
    for seed in (1, 2):
        out = tmp_path / f"run{seed}"
        assert main(["evolve", *tiny(seed=seed), "--gens", "3", "--backend", "serial",
                     "--no-gallery", "--out", str(out)]) == 0
        runs.append(str(out))
    capsys.readouterr()
    png = tmp_path / "qd.png"
    assert main(["evolve-stats", "--group", "me", *runs, "--out", str(png), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report) == {"qd_score", "coverage"}
    finals = [float(metrics(tmp_path / f"run{s}")[-1][1]) for s in (1, 2)]
    assert report["qd_score"]["me"]["runs"] == 2
    assert report["qd_score"]["me"]["mean"][-1] == pytest.approx(np.mean(finals))
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_starts_score_each_robot_and_a_resume_keeps_them(tmp_path, capsys):
    """`--starts K` reaches the MAP-Elites task (config.json, the fitness of K starts); a
    resume takes the run's starts, and refuses other ones."""
    out = tmp_path / "run"
    assert main(["evolve", *tiny(), "--gens", "1", "--starts", "2", "--backend", "serial",
                 "--no-gallery", "--out", str(out)]) == 0
    task = json.loads((out / "config.json").read_text())["task"]
    assert (task["starts"], task["start_seed"]) == (2, 1)
    assert main(["evolve", "--out", str(out), "--resume", "--starts", "3", "--quiet"]) == 1
    assert "--starts 3 (run has 2)" in capsys.readouterr().err
    assert main(["evolve", "--out", str(out), "--resume", "--quiet", "--no-gallery"]) == 0
