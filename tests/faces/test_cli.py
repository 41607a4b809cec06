"""The `mjregen` command: grow and show, their JSON, and one-line errors."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from mjregen.cli import main
from mjregen.grid import Robot
from mjregen.growth.checkpoint import save_nca
from mjregen.growth.nca import NCA, NCAConfig
from mjregen.physics import Physics


def test_grow_random_nca_json_matches_the_library(tmp_path, capsys):
    out = tmp_path / "robot.npy"
    assert main(["grow", "--dim", "2", "--net", "lstm", "--seed", "5", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    expected = NCA.random(NCAConfig(dim=2, kind="lstm"), seed=5).grow()
    assert len(report["steps"]) == 11
    assert [s["voxels"] for s in report["steps"]] == [int(np.count_nonzero(s)) for s in expected.states[0]]
    assert Robot.load(out) == expected.robot()
    assert report["robot"]["grid"] == expected.robot().grid.tolist()


def test_grow_from_checkpoint_prints_steps_and_robot(tmp_path, capsys):
    nca = NCA.random(NCAConfig(dim=3), seed=2)
    path = save_nca(tmp_path / "nca.npz", nca)
    assert main(["grow", "--checkpoint", str(path), "--steps", "3"]) == 0
    text = capsys.readouterr().out
    assert "step  3:" in text and "step  4:" not in text
    assert nca.grow(steps=3).robot().to_text() in text
    assert main(["grow", "--checkpoint", str(path), "--dim", "3", "--net", "ff"]) == 0  # agree
    capsys.readouterr()
    assert main(["grow", "--checkpoint", str(path), "--dim", "2", "--net", "lstm"]) == 1
    assert "--dim 2 (the checkpoint's: 3), --net lstm (the checkpoint's: ff)" in \
        capsys.readouterr().err


def test_grow_never_overwrites_without_force(tmp_path, capsys):
    out = tmp_path / "robot.npy"
    Robot(np.zeros((7, 7))).save(out)
    assert main(["grow", "--dim", "2", "--out", str(out)]) == 1
    assert "exists" in capsys.readouterr().err
    assert Robot.load(out).is_empty
    assert main(["grow", "--dim", "2", "--out", str(out), "--force"]) == 0


def test_show_text_and_json(tmp_path, capsys):
    robot = Robot.from_body(np.array([[[1, 2], [3, 4]]]))
    path = robot.save(tmp_path / "r.npy")
    assert main(["show", str(path)]) == 0
    assert capsys.readouterr().out.strip() == robot.to_text()
    assert main(["show", str(path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["voxels"] == 4 and report["materials"]["hard"] == 1 and report["shape"] == [3, 4, 4]


@pytest.mark.parametrize(
    "make, args, message",
    [
        (None, ["show", "{tmp}/missing.npy"], "not found"),
        (lambda p: np.save(p / "bad.npy", np.full((5, 5), 7)), ["show", "{tmp}/bad.npy"], "unknown material code 7"),
        (lambda p: np.save(p / "flat.npy", np.zeros(5)), ["show", "{tmp}/flat.npy"], "dimensions"),
        (lambda p: (p / "junk.npz").write_bytes(b"junk"), ["grow", "--checkpoint", "{tmp}/junk.npz"], "not a readable"),
        (None, ["grow", "--steps", "0"], "--steps"),
    ],
)
def test_bad_input_gives_one_line_error(tmp_path, capsys, make, args, message):
    if make is not None:
        make(tmp_path)
    assert main([a.format(tmp=tmp_path) for a in args]) == 1
    err = capsys.readouterr().err
    assert err.startswith("mjregen: error:") and message in err and err.count("\n") == 1


def test_console_entry_point_runs():
    result = subprocess.run([sys.executable, "-m", "mjregen.cli", "--help"], capture_output=True, text=True)
    assert result.returncode == 0 and "grow" in result.stdout and "show" in result.stdout
    result = subprocess.run([sys.executable, "-m", "mjregen.cli", "show"], capture_output=True, text=True)
    assert result.returncode == 2 and "Traceback" not in result.stderr


WALKER = "assets/robots/bimorph_walker_3d.npy"


def test_walk_json_equals_simulate(tmp_path, capsys):
    from mjregen.physics import Physics
    from mjregen.physics.simulation import simulate
    from mjregen.tasks.fitness import locomotion_fitness

    csv = tmp_path / "com.csv"
    assert main(["walk", WALKER, "--settle", "0.01", "--duration", "0.05", "--trajectory", str(csv), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    expected = simulate(Robot.load(WALKER), physics=Physics().replace(settle_time=0.01), duration=0.05)
    assert report["distance"] == expected.distance
    assert report["fitness"] == locomotion_fitness(expected)
    assert report["stable"] and report["steps"] == expected.steps
    rows = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert rows.shape == (expected.steps + 1, 4)
    # the planar displacement (voxel lengths) from the settle's end, and its heading
    settle = round(0.01 / expected.timestep)
    moved = (rows[-1, 1:3] - rows[settle, 1:3]) / 1e-3
    assert np.allclose(report["displacement"], moved, rtol=1e-6, atol=1e-9)
    assert math.hypot(*report["displacement"]) == pytest.approx(report["distance"], rel=1e-12)
    assert report["heading"] == pytest.approx(math.degrees(math.atan2(moved[1], moved[0])),
                                              abs=1e-4)
    assert main(["walk", WALKER, "--duration", "0.01", "--trajectory", str(csv)]) == 1  # exists
    assert "exists" in capsys.readouterr().err


def test_walk_from_shifted_starts_reports_what_they_keep(capsys):
    """The mirror walker, its own mirror image across y, keeps a fraction of its exact
    start's distance from shifted starts: the command says so, and its numbers are the
    library's."""
    from mjregen.tasks.starts import shifted_starts

    walker = "assets/robots/mirror_walker_3d.npy"
    assert main(["walk", walker, "--shifted-starts", "2", "--workers", "2", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)["shifted_starts"]
    expected = shifted_starts(Robot.load(walker), starts=2)
    assert report["distances"] == expected.distances.tolist() and report["seed"] == 0
    assert report["kept"] == expected.kept < 0.9 and report["depends_on_start"]
    assert report["mirror_axes"] == ["y"] and report["shift"] == 1e-4
    assert main(["walk", walker, "--shifted-starts", "2", "--start-seed", "1"]) == 0
    text = capsys.readouterr().out
    assert "2 shifted starts" in text and "mirror image across y" in text
    assert "walks partly by its exact start" in text


def test_walk_from_several_starts_reports_the_score_an_evolution_gives(capsys):
    """--starts K: the mean fitness of K starts, as `evaluate_robot` scores a robot."""
    from mjregen.tasks.evaluation import RobotJob, evaluate_robot

    robot = Robot.load(WALKER)
    assert main(["walk", WALKER, "--starts", "3", "--start-seed", "2", "--duration", "0.05",
                 "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    scored = evaluate_robot(RobotJob(np.asarray(robot.grid), Physics(), 0.05, 3, 2))
    assert report["starts"]["distances"] == list(scored.distances)
    assert report["starts"]["fitness"] == scored.fitness and report["starts"]["seed"] == 2
    assert report["distance"] == scored.distances[0]
    assert main(["walk", WALKER, "--starts", "2", "--shifted-starts", "2"]) == 1
    assert "not both" in capsys.readouterr().err


def test_walk_json_of_starts_that_did_not_walk_is_valid_json(capsys):
    """The shifted starts' numbers that are NaN (here the share: no walk to keep) are null."""
    assert main(["walk", WALKER, "--shifted-starts", "2", "--settle", "0.005", "--duration",
                 "0", "--json"]) == 0
    out = capsys.readouterr().out
    report = json.loads(out, parse_constant=lambda name: pytest.fail(f"{name} in JSON"))
    assert report["distance"] == 0.0 and report["shifted_starts"]["kept"] is None


@pytest.mark.parametrize("arguments, message", [
    (["--shifted-starts", "0"], "a count is a whole number >= 1"),
    (["--starts", "0"], "starts is a whole number from 1 to 1000"),
    (["--starts", "100000"], "starts is a whole number from 1 to 1000"),
    (["--shifted-starts", "2", "--workers", "0"], "--workers needs at least 1"),
])
def test_walk_refuses_a_bad_count_of_starts_or_workers(capsys, arguments, message):
    with pytest.raises(SystemExit) as exit_info:
        main(["walk", WALKER, *arguments])
    assert exit_info.value.code == 2 and message in capsys.readouterr().err


@pytest.mark.parametrize("arguments", [["--shift", "1e-6"], ["--workers", "2"]])
def test_walk_refuses_shifted_start_options_without_shifted_starts(capsys, arguments):
    assert main(["walk", WALKER, *arguments]) == 1
    assert "are for --shifted-starts N" in capsys.readouterr().err


@pytest.mark.parametrize("shift", ["nan", "0", "-1e-9"])
def test_walk_refuses_a_bad_shift(capsys, shift):
    assert main(["walk", WALKER, "--shifted-starts", "2", f"--shift={shift}"]) == 1
    assert "--shift must be a finite number of voxel lengths > 0" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["paper", "sphere"])
def test_walk_with_a_physics_preset(capsys, name):
    from mjregen import physics as presets
    from mjregen.physics.simulation import simulate

    assert main(["walk", WALKER, "--physics", name, "--settle", "0.01", "--duration", "0.03", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    physics = getattr(presets, f"{name}_physics")().replace(settle_time=0.01)
    expected = simulate(Robot.load(WALKER), physics=physics, duration=0.03)
    assert report["distance"] == expected.distance and report["steps"] == expected.steps


def test_walk_with_tendon_or_beam_bonds(capsys):
    from mjregen.physics import Physics
    from mjregen.physics.simulation import simulate

    assert main(["walk", WALKER, "--bonds", "beam", "--settle", "0.01", "--duration", "0.03",
                 "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    beam = Physics().replace(settle_time=0.01, bond_element="beam")
    expected = simulate(Robot.load(WALKER), physics=beam, duration=0.03)
    tendons = simulate(Robot.load(WALKER), physics=Physics().replace(
        settle_time=0.01, bond_element="tendons"), duration=0.03)
    assert report["distance"] == expected.distance != tendons.distance
    assert main(["walk", WALKER, "--bonds", "tendons", "--settle", "0.01", "--duration", "0.03",
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["distance"] == tendons.distance
    # the bond element is the voxel pipeline's: the pure-MuJoCo presets have 8 tendons
    assert main(["walk", WALKER, "--physics", "sphere", "--bonds", "beam", "--json"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("mjregen: error: --bonds") and "pure-MuJoCo" in err


def test_walk_with_either_timestep_rule(capsys):
    from mjregen.physics import Physics
    from mjregen.physics.simulation import simulate

    steps = {}
    for rule in ("network", "stiffest_bond"):
        assert main(["walk", WALKER, "--timestep-rule", rule, "--settle", "0.01",
                     "--duration", "0.03", "--json"]) == 0
        report = json.loads(capsys.readouterr().out)
        physics = Physics().replace(settle_time=0.01, timestep_rule=rule)
        expected = simulate(Robot.load(WALKER), physics=physics, duration=0.03)
        assert report["distance"] == expected.distance
        steps[rule] = report["steps"]
    assert steps["network"] < steps["stiffest_bond"]  # the robot's own limit is looser


def test_export_writes_mjcf_that_plain_mujoco_loads(tmp_path, capsys):
    import mujoco

    out = tmp_path / "robot.xml"
    assert main(["export", WALKER, "--out", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    assert model.nbody == 1 + Robot.load(WALKER).n_voxels
    assert main(["export", WALKER, "--out", str(out)]) == 1
    assert "exists" in capsys.readouterr().err


def test_export_writes_the_starts_a_walk_walks_from(tmp_path):
    """`export --start-seed S --starts K` holds the keyframes `walk --start-seed S --starts K`
    starts from; `--start-shift 0` none (the model starts on the grid)."""
    import mujoco

    from mjregen.physics.compile import compile_robot

    out = tmp_path / "robot.xml"
    assert main(["export", WALKER, "--out", str(out), "--start-seed", "5", "--starts", "2"]) == 0
    exported = mujoco.MjModel.from_xml_path(str(out))
    walked = compile_robot(Robot.load(WALKER), starts=(0, 1), start_seed=5).model
    assert exported.nkey == 2 and np.array_equal(exported.key_qpos, walked.key_qpos)
    assert main(["export", WALKER, "--out", str(out), "--force", "--start-shift", "0"]) == 0
    assert mujoco.MjModel.from_xml_path(str(out)).nkey == 0


def test_render_frames(tmp_path, capsys):
    frames = tmp_path / "frames"
    assert main(["render", WALKER, "--frames", str(frames), "--settle", "0.005", "--duration", "0.005",
                 "--width", "64", "--height", "48", "--fps", "10", "--quiet"]) == 0
    pngs = sorted(frames.glob("*.png"))
    assert len(pngs) == round(0.01 * 10 * 10) + 1  # sim time x slowdown x fps, + the first
    from PIL import Image

    assert Image.open(pngs[0]).size == (64, 48)
    assert main(["render", WALKER, "--out", str(tmp_path / "w.mp4"), "--width", "63"]) == 1
    assert "even" in capsys.readouterr().err


@pytest.mark.parametrize("command", [["walk"], ["export", "--out", "{tmp}/x.xml"], ["render", "--out", "{tmp}/x.mp4"]])
def test_robot_commands_reject_bad_files(tmp_path, capsys, command):
    np.save(tmp_path / "bad.npy", np.full((5, 5, 5), 9))
    np.save(tmp_path / "flat.npy", np.zeros(5))
    for robot, message in [("missing.npy", "not found"), ("bad.npy", "unknown material code 9"),
                           ("flat.npy", "dimensions")]:
        args = [command[0], str(tmp_path / robot)] + [a.format(tmp=tmp_path) for a in command[1:]]
        assert main(args) == 1
        err = capsys.readouterr().err
        assert err.startswith("mjregen: error:") and message in err and err.count("\n") == 1


def test_walk_refuses_several_exact_starts(capsys):
    assert main(["walk", WALKER, "--start-shift", "0", "--starts", "3"]) == 1
    assert "every start is the exact start" in capsys.readouterr().err


def test_walk_a_pattern_or_its_sheet_as_the_paper_2d_robot(tmp_path, capsys):
    from mjregen.grid import lay_flat
    from mjregen.physics.simulation import simulate

    pattern = np.zeros((5, 5), dtype=np.int8)
    pattern[1:4, 1:4] = 3
    pattern[2, 1:4] = 4
    np.save(tmp_path / "pattern.npy", pattern)
    np.save(tmp_path / "sheet.npy", lay_flat(pattern))
    reports = []
    for name in ("pattern.npy", "sheet.npy"):
        assert main(["walk", str(tmp_path / name), "--body", "sheet", "--duration", "0.05",
                     "--json"]) == 0
        reports.append(json.loads(capsys.readouterr().out))
    sheet_physics = Physics().replace(settle_time=1.0, settle_rest=1e-6)
    expected = simulate(lay_flat(pattern), physics=sheet_physics, duration=0.05)
    for report in reports:  # the 2D times and the 2D rule: the fitness is the distance
        assert report["distance"] == expected.distance == report["fitness"]
        assert report["sim_time"] == pytest.approx(1.05, abs=1e-4)  # whole steps
    # --settle-rest 0: the full settle
    assert main(["walk", str(tmp_path / "pattern.npy"), "--body", "sheet", "--duration", "0.05",
                 "--settle-rest", "0", "--json"]) == 0
    full = simulate(lay_flat(pattern), physics=sheet_physics.replace(settle_rest=0.0),
                    duration=0.05)
    assert json.loads(capsys.readouterr().out)["distance"] == full.distance
    assert main(["walk", WALKER, "--body", "sheet"]) == 1
    assert "is not a sheet: a 3D grid of" in capsys.readouterr().err
    # the exported model of the pattern is the sheet's, its muscles starting after 1 s
    xml = tmp_path / "sheet.xml"
    assert main(["export", str(tmp_path / "pattern.npy"), "--body", "sheet", "--out",
                 str(xml)]) == 0
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(xml))
    assert model.nbody == 1 + np.count_nonzero(pattern) and model.nq == 7 * model.nbody - 7
    assert 'key="start" value="1.0"' in xml.read_text()
    assert 'key="settle_rest" value="1e-06 0.005"' in xml.read_text()  # held at rest
