"""`mjregen regen` end to end on a tiny 2D run."""

import json

import numpy as np

from mjregen.cli import main
from mjregen.grid import Robot

WALKER_2D = "assets/robots/bimorph_walker_2d.npy"


def test_regen_writes_run_robots_and_recovery(tmp_path, capsys):
    out = tmp_path / "regen"
    args = ["regen", "--robot", WALKER_2D, "--pop", "8", "--gens", "2", "--truncation", "4",
            "--elites", "2", "--out", str(out), "--no-video", "--quiet", "--json"]
    assert main(args) == 0
    report = json.loads(capsys.readouterr().out)
    original = Robot.load(WALKER_2D)
    assert Robot.load(out / "original.npy") == original
    damaged = Robot.load(out / "damaged.npy")
    assert damaged == original.remove_half_space("x < 3").cleaned()  # the paper's cut in 2D
    regrown = Robot.load(out / "regrown.npy")
    assert report["similarity"]["regrown"] == int(np.sum(regrown.grid == original.grid))
    assert report["voxels"] == {"original": 10, "damaged": damaged.n_voxels, "regrown": regrown.n_voxels}
    assert report["distance"]["original"] > 0.1
    for name in ("recovery.md", "robots.png", "regrowth.png", "metrics.csv", "checkpoint.npz"):
        assert (out / name).is_file(), name
    assert main(args) == 1  # never overwrites a run
    assert "not empty" in capsys.readouterr().err


def test_regen_rejects_a_robot_of_the_wrong_size(tmp_path, capsys):
    Robot(np.pad([[1, 1], [3, 4]], 1)).save(tmp_path / "small.npy")
    assert main(["regen", "--robot", str(tmp_path / "small.npy"), "--out", str(tmp_path / "r")]) == 1
    assert "needs the NCA grid (7, 7)" in capsys.readouterr().err


def test_regen_replay_regrows_what_the_run_recorded(tmp_path, capsys):
    out = tmp_path / "regen"
    assert main(["regen", "--robot", WALKER_2D, "--pop", "8", "--gens", "2", "--truncation", "4",
                 "--elites", "2", "--out", str(out), "--no-video", "--quiet", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert main(["regen", "--replay", str(out / "regrowth.npz"), "--json"]) == 0
    replay = json.loads(capsys.readouterr().out)
    assert replay["similarity"] == replay["recorded_similarity"] == report["similarity"]["regrown"]
    assert replay["distance"] == report["distance"]
    assert replay["damage"] == "paper cut"


def test_regen_replay_refuses_an_nca_that_regrows_nothing(capsys):
    assert main(["regen", "--replay", "assets/nca/walker_3d.npz"]) == 1
    assert "not a regrowth NCA" in capsys.readouterr().err
    assert main(["regen", "--paper", "tripod"]) == 1
    assert "--out is required" in capsys.readouterr().err


def test_regen_replay_refuses_flags_it_would_ignore(capsys, tmp_path):
    for flags in (["--out", str(tmp_path / "x")], ["--damage", "x < 2"], ["--pop", "8"],
                  ["--force"]):
        assert main(["regen", "--replay", "assets/regen/tripod_ff.npz", *flags]) == 1
        assert "would be ignored" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_regen_refuses_damage_that_removes_nothing_or_everything(capsys, tmp_path):
    common = ["regen", "--pop", "8", "--gens", "1", "--truncation", "4", "--elites", "2",
              "--no-video", "--quiet"]
    for damage, message in (("x > 6", "removes no voxel"), ("z < 7", "removes every voxel")):
        out = tmp_path / damage.replace(" ", "")
        assert main([*common, "--robot", WALKER_2D, "--damage", damage, "--out", str(out)]) == 1
        assert message in capsys.readouterr().err
        assert not out.exists()
    empty = tmp_path / "empty.npy"
    Robot(np.zeros((7, 7), dtype=np.int8)).save(empty)
    assert main([*common, "--robot", str(empty), "--out", str(tmp_path / "e")]) == 1
    assert "empty robot" in capsys.readouterr().err
