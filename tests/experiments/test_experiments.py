"""The results tooling (#9): experiment definitions, the rerun script, shipping assets and
the report, on smoke-scale runs (2D evolutions of a few seconds; hand-made 3D run folders)."""

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from mjregen.cli import main as mjregen_main
from mjregen.experiments import paper as ex
from mjregen.experiments import regrowth
from mjregen.experiments import walkers as wk
from mjregen.grid import Robot, lay_flat
from mjregen.growth.checkpoint import load_nca, save_nca
from mjregen.growth.nca import NCA, NCAConfig, grow
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate
from mjregen.search.ga import PRESETS
from mjregen.search.runs import METRICS, RunFolderError
from mjregen.tasks.bodies import body_physics
from mjregen.tasks.fitness import locomotion_fitness
from mjregen.tasks.locomotion import LocomotionTask
from repo_modules import load_module

SMOKE = ex.SCALES["smoke"]



paper_experiments, ship_assets, results_report, snapshot_runs = (
    load_module(f"scripts/{n}.py")
    for n in ("paper_experiments", "ship_assets", "results_report", "snapshot_runs"))


def test_conditions_and_paper_scale_are_the_papers():
    assert list(ex.CONDITIONS) == ["2d_ff", "2d_lstm", "3d_ff", "3d_lstm"]
    jobs = ex.evolution_jobs(ex.SCALES["paper"], root="R")
    by_condition = {}
    for job in jobs:
        by_condition.setdefault(job.condition.name, []).append(job)
        assert job.ga == PRESETS[f"{job.condition.dim}d"]  # exactly the paper's GA
        assert job.out == Path("R") / job.condition.name / f"seed_{job.seed}"
        assert job.duration is None and job.physics == Physics()
    assert {n: len(j) for n, j in by_condition.items()} == {"2d_ff": 10, "2d_lstm": 10,
                                                            "3d_ff": 24, "3d_lstm": 24}
    quick = ex.evolution_jobs(ex.SCALES["quick"], conditions=["3d_ff"], population=50, runs=2)
    assert [j.seed for j in quick] == [0, 1]
    assert (quick[0].ga.population, quick[0].ga.truncation, quick[0].ga.elites) == (50, 10, 10)
    assert ex.scaled_ga(PRESETS["2d"], 20, 5).elites == 1  # the 2D preset's single elite stays
    with pytest.raises(ex.MjregenError, match="unknown condition"):
        ex.evolution_jobs(SMOKE, conditions=["4d_ff"])


def test_dry_run_prints_every_command_and_runs_nothing(tmp_path, capsys):
    assert paper_experiments.main(["--dry-run", "--root", str(tmp_path), "--workers", "2"]) == 0
    out = capsys.readouterr().out
    commands = [line for line in out.splitlines() if line.startswith("mjregen evolve")]
    assert len(commands) == 68
    assert (f"mjregen evolve --dim 3 --net lstm --preset 3d --pop 100 --gens 300 --truncation 20 "
            f"--elites 20 --sigma 0.1 --seed 23 --workers 2 --out {tmp_path}/3d_lstm/seed_23") in out
    assert "--pop 1000 --gens 1000 --truncation 200 --elites 200" in out  # the regrowth GA
    assert "4440000 evaluations" in out
    assert not any(tmp_path.iterdir())


def kill_after(job: ex.EvolutionJob, generation: int) -> None:
    """Run `job` and stop it, through run_evolution's hook, after `generation` is saved."""
    from mjregen.search.backends import SerialBackend
    from mjregen.search.runs import run_evolution

    class Killed(Exception):
        pass

    def kill(row):
        if row["generation"] == generation:
            raise Killed

    task = LocomotionTask(nca=job.condition.nca, physics=job.physics, duration=job.duration,
                          body=job.condition.body)
    with pytest.raises(Killed):
        run_evolution(task, job.ga, seed=job.seed, out=job.out, backend=SerialBackend(),
                      progress=False, on_generation=kill)


def test_tiny_run_resumes_and_matches_its_printed_command(tmp_path):
    job, = ex.evolution_jobs(SMOKE, root=tmp_path, conditions=["2d_ff"], runs=1)
    kill_after(job, 0)  # then resume with the job
    assert ex.read_run(job.out).generations_done == 1
    resumed = ex.run_evolution_job(job, progress=False)
    assert ex.read_run(job.out).complete
    # the printed `mjregen evolve` command writes the same run (config and results)
    cli_out = tmp_path / "cli"
    argv = job.argv()
    argv[argv.index("--out") + 1] = str(cli_out)
    assert mjregen_main(argv + ["--quiet"]) == 0
    a, b = (json.loads((p / "config.json").read_text()) for p in (job.out, cli_out))
    assert {**a, "created": None} == {**b, "created": None}
    assert np.array_equal(ex.read_run(cli_out).best, ex.read_run(job.out).best)
    assert ex.run_evolution_job(job, progress=False).best_fitness == resumed.best_fitness  # finished: no-op
    other = ex.evolution_jobs(SMOKE, root=tmp_path, conditions=["2d_ff"], runs=1, population=6)[0]
    with pytest.raises(RunFolderError, match="different settings"):
        ex.run_evolution_job(other, progress=False)


def test_a_snapshot_of_an_unfinished_run_resumes_to_the_uninterrupted_run(tmp_path):
    job, = ex.evolution_jobs(SMOKE, root=tmp_path / "killed", conditions=["2d_ff"], runs=1,
                              generations=4)
    kill_after(job, 2)
    saved = snapshot_runs.snapshot(job.out, tmp_path / "records")
    assert saved == tmp_path / "records" / "2d_ff" / "seed_0"
    assert (saved / "checkpoint.npz").is_file()
    kept = sorted(p.name for p in (saved / "best").iterdir())
    assert ex.read_run(job.out).best_generation == 1  # not the last: both NCAs are kept
    assert kept == ["gen_0000.npy", "gen_0001.npy", "gen_0001.npz", "gen_0002.npy",
                    "gen_0002.npz"]  # the best's NCA, and the last one's, which a resume reads
    # the snapshot, copied to a fresh machine's results folder, resumes to the uninterrupted run
    fresh, = ex.evolution_jobs(SMOKE, root=tmp_path / "fresh", conditions=["2d_ff"], runs=1,
                              generations=4)
    fresh.out.parent.mkdir(parents=True)
    shutil.copytree(saved, fresh.out)
    resumed = ex.run_evolution_job(fresh, progress=False)
    whole, = ex.evolution_jobs(SMOKE, root=tmp_path / "whole", conditions=["2d_ff"], runs=1,
                              generations=4)
    uninterrupted = ex.run_evolution_job(whole, progress=False)
    assert np.array_equal(ex.read_run(fresh.out).best, ex.read_run(whole.out).best)
    assert np.array_equal(resumed.best_genome, uninterrupted.best_genome)
    # a finished run's record has no checkpoint, and resuming it returns its summary at once
    record = snapshot_runs.snapshot(fresh.out, tmp_path / "records")
    assert not (record / "checkpoint.npz").exists()
    again, = ex.evolution_jobs(SMOKE, root=tmp_path / "again", conditions=["2d_ff"], runs=1,
                               generations=4)
    again.out.parent.mkdir(parents=True)
    shutil.copytree(record, again.out)
    before = (again.out / "metrics.csv").read_text()
    summary = ex.run_evolution_job(again, progress=False)
    assert (again.out / "metrics.csv").read_text() == before  # nothing evaluated again
    assert (summary.best_fitness, summary.best_generation) == (
        uninterrupted.best_fitness, uninterrupted.best_generation)
    assert np.array_equal(summary.best_genome, uninterrupted.best_genome)
    with pytest.raises(FileNotFoundError, match="config.json"):
        snapshot_runs.snapshot(tmp_path / "nothing", tmp_path / "records")


def test_snapshot_command_keeps_a_record_where_into_says(tmp_path, capsys):
    job, = ex.evolution_jobs(SMOKE, root=tmp_path / "paper", conditions=["2d_ff"], runs=1,
                             generations=2)
    ex.run_evolution_job(job, progress=False)
    into = tmp_path / "records" / "paper"
    assert snapshot_runs.main(["--into", str(into), str(job.out)]) == 0
    record = into / "2d_ff" / "seed_0"
    assert ex.read_run(record).complete
    assert (record / "metrics.csv").read_text() == (job.out / "metrics.csv").read_text()
    assert f"-> {record} (finished)" in capsys.readouterr().out


def test_keep_after_leaves_out_young_unfinished_runs_only(tmp_path, capsys):
    young, = ex.evolution_jobs(SMOKE, root=tmp_path / "young", conditions=["2d_ff"], runs=1,
                               generations=3)
    kill_after(young, 0)
    done, = ex.evolution_jobs(SMOKE, root=tmp_path / "done", conditions=["2d_ff"], runs=1,
                              generations=1)
    ex.run_evolution_job(done, progress=False)
    into = tmp_path / "records"
    runs = [str(young.out), str(done.out)]
    assert snapshot_runs.main(["--into", str(into), "--keep-after", "3600", *runs]) == 0
    assert f"{young.out}: left out, 1 of 3 generations in" in capsys.readouterr().out
    assert sorted(p.parent.name for p in into.glob("*/seed_0")) == ["2d_ff"]
    assert ex.read_run(into / "2d_ff" / "seed_0").complete  # the finished one, from done/
    assert snapshot_runs.main(["--into", str(into / "all"), "--keep-after", "0", runs[0]]) == 0
    assert (into / "all" / "2d_ff" / "seed_0" / "checkpoint.npz").is_file()  # young, kept


def test_a_snapshot_that_fails_leaves_the_earlier_record_whole(tmp_path):
    record = tmp_path / "records" / "2d_ff" / "seed_0"
    record.mkdir(parents=True)
    (record / "metrics.csv").write_text("earlier\n")

    def broken(staging: Path) -> None:
        (staging / "metrics.csv").write_text("half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        snapshot_runs._replace(record, broken)
    assert (record / "metrics.csv").read_text() == "earlier\n"
    # the swap itself: the new record replaces it, nothing of either is left beside it
    snapshot_runs._replace(record, lambda staging: (staging / "metrics.csv").write_text("new\n"))
    assert (record / "metrics.csv").read_text() == "new\n"
    assert sorted(p.name for p in record.parent.iterdir()) == ["seed_0"]
    # a swap interrupted after moving the earlier record aside: the next snapshot finishes it
    record.rename(record.with_name("seed_0.previous"))
    snapshot_runs._replace(record, lambda staging: (staging / "metrics.csv").write_text("3\n"))
    assert (record / "metrics.csv").read_text() == "3\n"
    assert sorted(p.name for p in record.parent.iterdir()) == ["seed_0"]


def test_a_finished_record_without_its_best_nca_is_a_clear_error(tmp_path):
    job, = ex.evolution_jobs(SMOKE, root=tmp_path / "runs", conditions=["2d_ff"], runs=1,
                             generations=2)
    ex.run_evolution_job(job, progress=False)
    record = snapshot_runs.snapshot(job.out, tmp_path / "records")
    nca = ex.read_run(record).best_files()[0]
    nca.unlink()
    with pytest.raises(RunFolderError, match=f"best NCA cannot be read.*{nca.name}"):
        ex.run_evolution_job(dataclasses.replace(job, out=record), progress=False)


def test_a_run_resumed_from_its_record_snapshots_without_the_ncas_the_record_left_out(tmp_path):
    """Generations 1-4 tie in metrics.csv (an elite kept); the record kept generation 1's NCA
    only, so the resumed run has no files for 2 and 3; generation 4's file has the higher
    fitness behind the rounding. The snapshot keeps 1 and 4; without 1 it is an error."""
    from types import SimpleNamespace

    best = tmp_path / "best"
    best.mkdir()
    nca = NCA.random(NCAConfig(dim=2, kind="ff"), seed=0)
    save_nca(best / "gen_0001.npz", nca, metadata={"fitness": 2.0})
    save_nca(best / "gen_0004.npz", nca, metadata={"fitness": 2.0000004})
    info = SimpleNamespace(best=np.array([1.0, 2.0, 2.0, 2.0, 2.0]),
                           best_files=lambda g: (best / f"gen_{g:04d}.npz", best / f"gen_{g:04d}.npy"))
    assert snapshot_runs.best_ncas(info) == [best / "gen_0001.npz", best / "gen_0004.npz"]
    (best / "gen_0001.npz").unlink()
    with pytest.raises(FileNotFoundError, match="gen_0001.npz"):
        snapshot_runs.best_ncas(info)


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    """Smoke runs: 2D ff (2 seeds) and lstm (1 seed) evolved for real; hand-made 3D ff runs
    whose best robots are random NCAs' robots (no 3D evolution: too slow for a test); the
    first picked walker regrown."""
    root = tmp_path_factory.mktemp("results")
    assert paper_experiments.main(["--scale", "smoke", "--only", "2d_ff", "--root", str(root),
                                   "--quiet"]) == 0
    assert paper_experiments.main(["--scale", "smoke", "--only", "2d_lstm", "--runs", "1",
                                   "--root", str(root), "--quiet"]) == 0
    config = NCAConfig(dim=3, kind="ff")
    rng = np.random.default_rng(5)
    genomes = rng.normal(0.0, 0.1, size=(24, config.genome_size)).astype(np.float32)
    grids = grow(config, genomes).grids
    usable = [i for i in np.argsort([np.count_nonzero(g) for g in grids])
              if np.count_nonzero(grids[i]) and wk.pieces(Robot(grids[i])) == 1][:4]
    assert len(usable) == 4
    for seed, picks in enumerate((usable[:2], usable[2:])):
        run = ex.run_folder(root, "3d_ff", seed)
        (run / "best").mkdir(parents=True)
        physics = SMOKE.physics(3)
        (run / "config.json").write_text(json.dumps({
            "format": "mjregen-run-1", "seed": seed, "ga": ex.scaled_ga(PRESETS["3d"], 4, 2).to_dict(),
            "task": LocomotionTask(config, physics, SMOKE.duration(3)).to_config()}))
        rows = []
        for generation, i in enumerate(picks):
            result = simulate(grids[i], physics=physics, duration=SMOKE.duration(3))
            fitness = locomotion_fitness(result)
            stem = run / "best" / f"gen_{generation:04d}"
            save_nca(stem.with_suffix(".npz"), NCA(config, genomes[i]),
                     metadata={"generation": generation, "fitness": fitness,
                               "distance": result.distance + 1.0, "voxels": result.n_voxels})
            Robot(grids[i]).save(stem.with_suffix(".npy"))
            rows.append({k: 0 for k in METRICS} | {"generation": generation, "best": fitness})
        with (run / "metrics.csv").open("w") as handle:
            handle.write(",".join(METRICS) + "\n")
            handle.writelines(",".join(str(r[k]) for k in METRICS) + "\n" for r in rows)
    job, = regrowth.regen_jobs(SMOKE, wk.load_or_pick_walkers(root)[:1], root=root)
    assert regrowth.run_regen_job(job, progress=False) is not None  # regrowth of the first walker
    return root


def test_list_runs_and_walkers(results):
    runs = ex.list_runs(results)
    assert {n: len(r) for n, r in runs.items()} == {"2d_ff": 2, "2d_lstm": 1, "3d_ff": 2}
    assert all(r.complete for rs in runs.values() for r in rs)
    walkers = wk.load_or_pick_walkers(results)
    assert len(walkers) == 3 and len({w["npz"] for w in walkers}) == 3
    farthest = max(wk.walker_candidates(results), key=lambda c: c.distance)
    assert (walkers[0]["run"], walkers[0]["generation"]) == (str(farthest.run), farthest.generation)
    for w in walkers:
        assert Robot.load(w["npy"]) == load_nca(w["npz"])[0].grow().robot()
    assert wk.load_or_pick_walkers(results) == walkers  # picked once


def test_regrowth_job_writes_recovery(results):
    walkers = wk.load_or_pick_walkers(results)
    job, = regrowth.regen_jobs(SMOKE, walkers[:1], root=results)
    assert job.net == "ff" and job.out == results / "regen_walker_1_ff" / "seed_0"
    assert job.complete  # run by the fixture; running it again is a no-op
    assert regrowth.run_regen_job(job, progress=False) is None  # finished: left alone
    report = json.loads((job.out / "recovery.json").read_text())
    assert report["grid_cells"] == 729 and job.complete
    assert ex.list_regen_runs(results) == [("walker_1", "ff", job.out)]


def test_ship_assets_matches_resimulation_and_never_overwrites(results, tmp_path, capsys):
    assets = tmp_path / "assets"
    (assets / "nca").mkdir(parents=True)
    (assets / "nca" / "manifest.json").write_text(json.dumps({"walker_3d.npz": {"placeholder": True}}))
    args = ["--root", str(results), "--assets", str(assets), "--best"]
    assert ship_assets.main(args + ["--condition", "2d_ff", "--condition", "2d_lstm"]) == 0
    manifest = json.loads((assets / "nca" / "manifest.json").read_text())
    assert manifest["walker_3d.npz"] == {"placeholder": True}  # merged, not replaced
    runs = ex.list_runs(results)
    for name in ("2d_ff", "2d_lstm"):
        entry = manifest[f"walker_{name}.npz"]
        best = ex.best_run(runs[name])
        assert (entry["source"]["seed"], entry["source"]["generation"]) == (best.seed, best.best_generation)
        assert entry["source"]["matches_run"] and entry["scale"] == "smoke"
        assert entry["placeholder"] is False and entry["versions"]["mjregen"]
        nca, _ = load_nca(assets / "nca" / entry["file"])
        robot = Robot(lay_flat(nca.grow().robot().grid))  # the paper's 2D robot: a sheet
        assert robot == Robot.load(assets / "nca" / entry["robot_file"])
        evaluation = entry["evaluation"]  # as the run scored it: its starts and their seed
        assert (evaluation["starts"], evaluation["start_seed"]) == (1, best.seed)
        assert evaluation["body"] == "sheet"
        physics = body_physics(Physics.from_dict(evaluation["physics"]), "sheet")
        assert physics.scene.timing(3)[0] == evaluation["settle_s"]
        result = simulate(robot, physics=physics, duration=evaluation["duration_s"],
                          start_seed=evaluation["start_seed"])
        assert locomotion_fitness(result, rule=2) == pytest.approx(entry["fitness"], rel=1e-6,
                                                                   abs=1e-9)
        assert entry["robot"]["voxels"] == robot.n_voxels
        assert entry["sha256"] == ship_assets.sha256(assets / "nca" / entry["file"])
    before = (assets / "nca" / "manifest.json").read_bytes()
    capsys.readouterr()
    assert ship_assets.main(args + ["--condition", "2d_ff"]) == 1
    assert "--overwrite" in capsys.readouterr().err
    assert (assets / "nca" / "manifest.json").read_bytes() == before
    assert ship_assets.main(["--root", str(results), "--assets", str(assets), "--walkers"]) == 0
    shipped = json.loads((assets / "robots" / "walkers" / "walkers.json").read_text())
    assert [w["name"] for w in shipped["walkers"]] == ["walker_1", "walker_2", "walker_3"]
    assert "ff" in shipped["walkers"][0]["regrowth"]  # the regrowth run's recovery is attached
    assert ship_assets.main(["--root", str(results), "--assets", str(assets), "--walkers"]) == 1


def test_ship_assets_with_the_engine_ships_the_farthest_robot_that_transfers(
        results, tmp_path, monkeypatch, capsys):
    from mjregen.validation.transfer import Transfer

    def walks(seed: int, distance: float, engine: float) -> Transfer:
        return Transfer(name=f"seed {seed}", voxels=1, mirror_axes=[], starts=[distance] * 2,
                        fresh=[distance] * 2, rotated=[distance] * 3, exact=distance,
                        finer_step=[distance] * 2, engine=engine)

    measured = {}  # robot file -> its walks: seed 0 walks farther but not in the engine

    def stand_in(robot, *, name, starts, engine, physics):
        seed = int(name.split()[-1])
        measured[seed] = (robot, starts)
        return walks(seed, 9.0, 1.0) if seed == 0 else walks(seed, 6.0, 5.5)

    monkeypatch.setattr(ship_assets, "measure_transfer", stand_in)
    engine = tmp_path / "engine"
    engine.mkdir()
    (engine / "vxa.py").write_text("")
    assets = tmp_path / "assets"
    (assets / "nca").mkdir(parents=True)
    (assets / "nca" / "manifest.json").write_text("{}")
    args = ["--root", str(results), "--assets", str(assets), "--best", "--condition", "3d_ff",
            "--voxelyze", str(engine), "--starts", "4"]
    assert ship_assets.main(args) == 0
    entry = json.loads((assets / "nca" / "manifest.json").read_text())["walker_3d_ff.npz"]
    runs = ex.list_runs(results)["3d_ff"]
    assert entry["source"]["seed"] == 1 and entry["transfer"]["transfers"]
    assert entry["transfer"]["distance"] == 6.0 and entry["transfer"]["starts"] == 4
    for run in runs:  # each run's best robot was checked, from the starts asked
        assert measured[run.seed][0] == Robot.load(run.best_files()[1])
        assert measured[run.seed][1] == 4
    # no robot that transfers: an error naming each, and nothing shipped
    monkeypatch.setattr(ship_assets, "measure_transfer",
                        lambda robot, *, name, starts, engine, physics: walks(0, 9.0, 1.0))
    before = (assets / "nca" / "manifest.json").read_bytes()
    capsys.readouterr()
    assert ship_assets.main(args + ["--overwrite"]) == 1
    assert "no best robot of the 2 runs of 3d_ff transfers" in capsys.readouterr().err
    assert (assets / "nca" / "manifest.json").read_bytes() == before


def test_results_report_writes_every_section(results, tmp_path, monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "egl")  # recorded, so that teardown restores the original
    monkeypatch.delenv("MUJOCO_GL")  # the report picks the backend and sets MUJOCO_GL itself
    assets = tmp_path / "assets"
    (assets / "nca").mkdir(parents=True)
    (assets / "nca" / "manifest.json").write_text(json.dumps({"walker_3d.npz": {"placeholder": True}}))
    assert ship_assets.main(["--root", str(results), "--assets", str(assets), "--best",
                             "--condition", "2d_ff"]) == 0
    out = tmp_path / "docs" / "results.md"
    # the paper engine's measurement of 3d_ff's best robot, as transfer.py --best-of keeps it
    best = ex.best_robots(results)
    name = next(n for n in best if n.startswith("3d_ff/"))
    assert best[name][0] == ex.best_run(ex.list_runs(results)["3d_ff"]).best_files()[1]
    transfer = results / results_report.TRANSFER_FILE
    each = ex.finished_runs_robots(results)  # every finished run's best robot, named alike
    assert name in each and all(n.startswith(("2d_", "3d_")) for n in each)
    assert {n for n in each if n.startswith("3d_ff/")} == {
        run.best_files()[1].relative_to(results).as_posix()
        for run in ex.list_runs(results)["3d_ff"]}
    other = next(n for n in each if n.startswith("3d_ff/") and n != name)
    transfer.write_text(json.dumps([
        {"name": name, "engine": 12.5, "distance": 13.0, "transfers": True},
        {"name": other, "engine": 1.0, "distance": 20.0, "transfers": False},
        {"name": "3d_ff/seed_9/best/gen_0001.npy", "engine": 1.0, "distance": 30.0,
         "transfers": False}]))
    try:
        assert results_report.main(["--root", str(results), "--assets", str(assets),
                                    "--out", str(out)]) == 0
    finally:
        transfer.unlink()
    text = out.read_text()
    rows = {line.split(" | ")[0]: line for line in text.splitlines()
            if line.startswith(("| 3d_ff | 2 |", "| 2d_ff | 2 |"))}
    assert "| 12.5 (transfers) | 1 of 2 |" in rows["| 3d_ff"]  # the other run's does not
    assert "| not measured | not measured |" in rows["| 2d_ff"]
    # the farthest walker that transfers, not the one that walks farther but does not
    top = ex.read_run(results / name.split("/best/")[0])
    assert (f"Farthest 3D walker whose robot transfers (3d_ff seed {top.seed}, generation "
            f"{top.best_generation}): 13 voxel lengths in 0.5 s from fresh starts, 12.5 in "
            "the paper's engine") in text
    assert "the farthest 3D walker that transfers, 12.5 voxel lengths in the paper's engine" in text
    # how to reproduce the runs of a root that is not the default, with their numbers
    assert f"--root {results} --only 3d_ff --runs 2 --workers 1" in text
    for heading in ("## How to reproduce", "## Settings", "## Fitness over generations",
                    "## Shipped NCAs", "## Regeneration", "The paper's Table 1", "## Discussion"):
        assert heading in text, heading
    assert "| 3d_lstm | 100 × 300 × 24 | not run |" in text
    hours = sum(r.elapsed for r in ex.list_runs(results)["2d_ff"]) / 3600
    assert hours > 0
    settings_2d = next(line for line in text.splitlines() if line.startswith("| 2d_ff | 300 ×"))
    assert settings_2d.endswith(f"| {hours:.2g} h |")
    assert "one-layer sheets on the floor" in settings_2d
    assert "ending once at rest (`settle_rest` 1e-06)" in settings_2d  # sheets' default
    assert "at rest" not in next(line for line in text.splitlines()
                                 if line.startswith("| 3d_ff | 100 ×"))
    assert "| Tripod (feed forward) | 99 % (728/729) | 44.5 | 1.63 (3.6 %) | 20.3 (45 %) |" in text
    assert "walker_1 (feed-forward)" in text
    # 2D: two feed-forward runs, one LSTM run: no comparison of the networks is claimed
    assert "no difference this n can show" in text and "(n=2) vs LSTM" in text
    figures = out.parent / "results"
    for name in ("fitness_2d.png", "fitness_3d.png", "growth_walker_2d_ff.png",
                 "gallery_walker_2d_ff.png", "gallery_best_2d_ff.png", "gallery_best_3d_ff.png"):
        assert (figures / name).read_bytes()[:4] == b"\x89PNG", name
    assert (figures / "best_3d_walker.mp4").read_bytes()[4:8] == b"ftyp"  # an MP4 file
    assert "[Video](results/best_3d_walker.mp4) of the best robot of 3d_ff seed" in text
    # the paper's table parses the same from the embedded copy and from a LaTeX file
    copy = results_report.parse_table_1(results_report.TABLE_1_LATEX)
    assert [r["robot"] for r in copy] == ["Biped", "Tripod", "Multiped"]
    assert copy[2] | {} == {"robot": "Multiped", "network": "recurrent", "similarity_percent": 91.0,
                            "similarity": 667, "grid_cells": 729, "original": 42.7, "damaged": 5.36,
                            "damaged_percent": 12.0, "regrown": 9.6, "regrown_percent": 22.0}


def test_report_distances_show_a_robot_at_rest_as_zero_not_as_rounding_noise():
    # a damaged robot that does not move ends 1e-13 voxel lengths from its start
    assert results_report.fmt_distance(1.091e-13, 4) == "0"
    assert results_report.fmt_distance(-2e-9) == "0"
    assert results_report.fmt_distance(0.0061) == "0.0061"
    assert results_report.fmt_distance(5.73327, 3) == "5.73"
    assert results_report.fmt_distance(float("nan")) == results_report.fmt_distance(None) == "–"


def test_the_network_comparison_tests_the_runs_at_their_common_generation():
    """Exact tests of each run's best at the last generation all reached, with what n allows:
    3 runs against 2 can never show a difference at 5 %; 8 against 8 can."""
    from types import SimpleNamespace

    def runs(*curves):
        return [SimpleNamespace(best=np.asarray(c, dtype=float)) for c in curves]

    ff, lstm = runs([1, 2, 30, 40], [1, 3, 31], [1, 4, 32]), runs([1, 5], [1, 6])
    text = results_report._network_comparison(3, ff, lstm)  # at generation 1, where LSTM leads
    assert "generation 1" in text and "(n=3) vs LSTM" in text and "(n=2)" in text
    assert "no difference this n can show" in text
    many_ff = runs(*[[0, 10 + k] for k in range(8)])
    many_lstm = runs(*[[0, k] for k in range(8)])
    assert "a difference at the 5 % level" in results_report._network_comparison(
        3, many_ff, many_lstm)


def test_curves_and_comparisons_count_the_finished_runs_once_any_has_finished():
    """A run under way would cut every curve and the comparison to its few generations."""
    from types import SimpleNamespace

    done = [SimpleNamespace(complete=True, seed=s) for s in (0, 1)]
    going = SimpleNamespace(complete=False, seed=2, generations_done=10, generations_planned=300)
    assert results_report._finished_or_all(done + [going]) == (done, [going])
    assert results_report._finished_or_all([going]) == ([going], [])
    assert results_report._under_way([going]) == "seed 2 at generation 10 of 300"
    text = results_report._network_comparison(
        3, [SimpleNamespace(best=np.ones(3))], [SimpleNamespace(best=np.ones(3))], left_out=2)
    assert "(the last all runs reached; 2 runs under way not counted)" in text


def test_the_records_of_a_results_folder_regenerate_its_report(results, tmp_path):
    records = tmp_path / "records"
    for run in sorted(results.glob("*/seed_*")):
        snapshot_runs.snapshot(run, records)
    snapshot_runs.snapshot_walkers(wk.walkers_folder(results), records)
    restored = tmp_path / "restored"
    shutil.copytree(records, restored)
    assert not list(restored.rglob("checkpoint.npz"))  # every run is finished
    # the walkers' paths point into the results folder they were picked in
    index = restored / "walkers" / "walkers.json"
    index.write_text(index.read_text().replace(str(results), str(restored)))
    job, = regrowth.regen_jobs(SMOKE, wk.load_or_pick_walkers(restored)[:1], root=restored)
    assert regrowth.run_regen_job(job, progress=False) is None  # a finished record
    reports = []
    for root in (results, restored):
        out = tmp_path / "reports" / root.name / "results.md"
        assert results_report.main(["--root", str(root), "--assets", str(tmp_path / "none"),
                                    "--out", str(out), "--no-render"]) == 0
        text = out.read_text().split("\n", 3)[3]  # past the line naming the root
        reports.append(text.replace(str(out.parent), "OUT").replace(str(root), "ROOT"))
    assert "walker_1 (feed-forward)" in reports[1]
    assert reports[1] == reports[0]


def test_the_report_by_default_is_docs_results_md_from_the_records_in_git():
    repository = Path(results_report.__file__).resolve().parents[1]
    args = results_report.build_parser().parse_args([])
    assert args.root == repository / "records" / "paper"
    assert args.out == repository / "docs" / "results.md"
    assert sorted(p.name for p in args.root.glob("3d_*")) == ["3d_ff", "3d_lstm"]


def test_the_report_checks_that_an_evolution_run_again_repeated(results, tmp_path):
    """The GA runs of the GA against MAP-Elites are the 3D feed-forward runs evolved again:
    the report compares their best fitness generation by generation."""
    root = tmp_path / "root"
    shutil.copytree(results, root)
    for seed in (0, 1):
        shutil.copytree(root / "3d_ff" / f"seed_{seed}", root / "qd" / "ga" / f"seed_{seed}")
    metrics = root / "qd" / "ga" / "seed_1" / "metrics.csv"
    header, first, *rest = metrics.read_text().splitlines()
    cells = first.split(",")
    cells[1] = repr(float(cells[1]) + 1.0)  # its generation 0 went otherwise
    metrics.write_text("\n".join([header, ",".join(cells), *rest]) + "\n")
    out = tmp_path / "docs" / "results.md"
    assert results_report.main(["--root", str(root), "--assets", str(tmp_path), "--out", str(out),
                                "--no-render"]) == 0
    facts = [line for line in out.read_text().splitlines() if " evolves 3d_ff/" in line]
    assert len(facts) == 2
    assert facts[0].startswith("- qd/ga/seed_0 evolves 3d_ff/seed_0 again") and (
        "generations 0-1 is the same as the first run's" in facts[0])
    assert facts[1].startswith("- qd/ga/seed_1 evolves 3d_ff/seed_1 again") and (
        "NOT the same" in facts[1])


def test_results_report_on_nothing_says_not_run(tmp_path):
    out = tmp_path / "results.md"
    assert results_report.main(["--root", str(tmp_path / "none"), "--assets", str(tmp_path),
                                "--out", str(out), "--no-render"]) == 0
    text = out.read_text()
    assert text.count("not run") >= 4 and "No evolved NCA is shipped yet" in text


def test_the_quality_diversity_section_is_the_page_in_the_reports_own_figures_folder(tmp_path):
    out, root = tmp_path / "docs" / "page.md", tmp_path / "none"
    argv = ["--root", str(root), "--assets", str(tmp_path), "--out", str(out), "--no-render"]
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "quality_diversity.md").write_text("# Another page's comparison\n")
    assert results_report.main(argv) == 0
    text = out.read_text()
    assert "Another page's comparison" not in text  # a page beside it belongs to no report
    assert f"Not run on `{root}`" in text and f"--root {root}/qd" in text
    (tmp_path / "docs" / "page" / "quality_diversity.md").write_text(
        "# Quality diversity: a test\n\n## Runs\n\n![curves](quality_diversity/curves.png)\n")
    assert results_report.main(argv) == 0
    text = out.read_text()
    assert "## Quality diversity: a test\n\n### Runs" in text  # one blank line, as written
    assert "![curves](page/quality_diversity/curves.png)" in text  # relative to the report


def _as_grow_regrow_run(root: Path, condition: str, **objective) -> Path:
    """ROOT/<condition>/seed_0: a copy of the growth-only run 3d_ff/seed_1 whose task is a
    grow-regrow task with `objective` (its best NCA is judged as a growth-only one is)."""
    from mjregen.tasks.grow_regrow import GrowRegrowTask

    run = root / condition / "seed_0"
    shutil.copytree(root / "3d_ff" / "seed_1", run)
    config = json.loads((run / "config.json").read_text())
    task = LocomotionTask.from_config(config["task"])
    config["task"] = GrowRegrowTask(nca=task.nca, physics=task.physics, duration=task.duration,
                                    regrown_weight=0.5, **objective).to_config()
    config["seed"] = 0
    (run / "config.json").write_text(json.dumps(config))
    return run


def _voxel_counting_engine(folder: Path):
    """A stand-in for the paper's engine in `folder` that walks each robot as far as it has
    voxels."""
    from mjregen.validation.engine import PaperEngine

    folder.mkdir()
    (folder / "vxa.py").write_text("def run(grid):\n"
                                   "    return {'distance': float((grid > 0).sum()), 'cpu_s': 0}\n")
    return PaperEngine(folder)


def test_grow_regrow_runs_are_judged_beside_growth_only_runs_here_and_in_the_engine(
        results, tmp_path):
    from mjregen.experiments import self_regrowth

    root = tmp_path / "root"
    shutil.copytree(results, root)
    # a grow-regrow run whose best NCA is a growth-only run's (its judging is the same)
    run = _as_grow_regrow_run(root, "grow_regrow_walk_ff", cell_cost=0.0)
    engine = _voxel_counting_engine(tmp_path / "engine")
    measured = self_regrowth.measure_in_engine(root, engine, progress=lambda _: None)
    # two growth-only runs and the grow-regrow run, three robots each, walked as far as voxels
    nca, _ = load_nca(ex.read_run(run).best_files()[0])
    robots = self_regrowth.self_regrowth_robots(nca)
    assert {k: v for k, v in measured.items() if k.startswith("grow_regrow_walk_ff/")} == {
        f"grow_regrow_walk_ff/seed_0/{role}": float(robot.n_voxels) for role, robot in robots.items()}
    assert len(measured) == 9 and robots["original"].n_voxels > robots["damaged"].n_voxels
    out = tmp_path / "docs" / "results.md"
    assert results_report.main(["--root", str(root), "--assets", str(tmp_path), "--out", str(out),
                                "--no-render"]) == 0
    text = out.read_text()
    row = next(line for line in text.splitlines() if line.startswith("| grow_regrow_walk_ff seed 0"))
    assert "| 0, 0.5 |" in row and f"| {robots['original'].n_voxels} / " in row
    alone = next(line for line in text.splitlines() if line.startswith("| 3d_ff seed 1 | 4 × 2, "))
    assert "| growth only |" in alone
    hours = ex.read_run(run).elapsed / 3600
    assert f"- grow_regrow_walk_ff: 1 run (1 finished), {hours:.2g} h of wall time." in text
    # the same NCA judged twice: the same regrowth, the same walks, the same engine distances
    assert row.split(" | ")[3:] == alone.split(" | ")[3:]
    assert ("(grow_regrow_walk_ff) against growth-only NCAs of the same evaluations, the "
            "grown robot's distance "
            "(what walking the regrown robot too costs): grow-regrow") in text
    assert "(n=1) vs growth-only" in text and "no difference this n can show" in text


def test_a_grow_regrow_condition_is_judged_after_its_own_damage_and_so_are_the_others(
        results, tmp_path):
    from mjregen.experiments import self_regrowth

    root = tmp_path / "root"
    shutil.copytree(results, root)
    run = _as_grow_regrow_run(root, "grow_regrow_half_ff", cut="half")
    engine = _voxel_counting_engine(tmp_path / "engine")
    measured = self_regrowth.measure_in_engine(root, engine, progress=lambda _: None)
    nca, _ = load_nca(ex.read_run(run).best_files()[0])
    half = self_regrowth.self_regrowth_robots(nca, damage="half")
    assert {k: v for k, v in measured.items() if k.startswith("grow_regrow_half_ff/")} == {
        f"grow_regrow_half_ff/seed_0/half/{role}": float(robot.n_voxels)
        for role, robot in half.items()}
    # the growth-only runs: after the paper's cut and after each robot's own half
    assert "3d_ff/seed_1/damaged" in measured and "3d_ff/seed_1/half/damaged" in measured
    assert measured["3d_ff/seed_1/half/damaged"] == float(half["damaged"].n_voxels)
    out = tmp_path / "docs" / "results.md"
    assert results_report.main(["--root", str(root), "--assets", str(tmp_path), "--out", str(out),
                                "--no-render"]) == 0
    text = out.read_text()
    assert "**grow_regrow_half_ff** (damage: each robot's own lower half" in text
    table = text.split("**grow_regrow_half_ff**")[1]
    row = next(line for line in table.splitlines() if line.startswith("| grow_regrow_half_ff"))
    alone = next(line for line in table.splitlines() if line.startswith("| 3d_ff seed 1 | 4 × 2, "))
    assert row.split(" | ")[3:] == alone.split(" | ")[3:]  # the same NCA, the same damage
    assert f"| {half['original'].n_voxels} / {half['damaged'].n_voxels} (" in row


def test_the_networks_are_also_compared_by_their_robots_walks_in_the_engine(results, tmp_path):
    root = tmp_path / "root"
    shutil.copytree(results, root)
    shutil.copytree(root / "3d_ff", root / "3d_lstm")
    (root / "transfer.json").unlink(missing_ok=True)
    out = tmp_path / "docs" / "results.md"
    argv = ["--root", str(root), "--assets", str(tmp_path), "--out", str(out), "--no-render"]
    assert results_report.main(argv) == 0
    assert "walked in the paper's engine (voxel lengths" not in out.read_text()  # unmeasured
    runs = ex.list_runs(root)
    engine = {"3d_ff": [12.0, 14.0], "3d_lstm": [2.0, 4.0]}
    (root / "transfer.json").write_text(json.dumps([
        {"name": ex.robot_name(root, run), "engine": engine[condition][i], "transfers": False}
        for condition in engine for i, run in enumerate(runs[condition])]))
    assert results_report.main(argv) == 0
    assert ("3D, each finished run's best robot walked in the paper's engine (voxel lengths; "
            "what transfers, not the fitness an artefact can win): feed-forward 13 (n=2) vs "
            "LSTM 3 (n=2): Mann-Whitney U = 4") in out.read_text()
