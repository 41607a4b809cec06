"""Every shipped NCA in assets/nca/manifest.json reproduces its manifest when grown and
simulated by today's code with the manifest's stated settings.

Evaluation is deterministic (same code, same physics → same trajectory; the native and
tendon bond backends agree to ~1e-15 m), so the fitness must match to RTOL. A failure means
the physics or growth code changed what a shipped walker does: re-ship the assets
(scripts/ship_assets.py --overwrite) or find the regression. Placeholders are only checked
for their file hash and their flag; with no real entries the placeholder flag is asserted,
so this file never passes by skipping.
"""

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from mjregen.grid import Material, Robot
from mjregen.growth.checkpoint import load_nca
from mjregen.physics import Physics, migrate_physics
from mjregen.physics.migrate import OLDEST_FORMAT, PHYSICS_FORMAT
from mjregen.physics.simulation import simulate
from mjregen.tasks.bodies import body_physics, body_robot
from mjregen.tasks.evaluation import RobotJob, evaluate_robot

ASSETS = Path(__file__).resolve().parents[1] / "assets"
NCA_DIR = ASSETS / "nca"
MANIFEST = json.loads((NCA_DIR / "manifest.json").read_text())
REAL = sorted(k for k, v in MANIFEST.items() if not v.get("placeholder", False))
RTOL, ATOL = 1e-6, 1e-9  # fitness; deterministic evaluation
NO_REAL = "no-real-entries"


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_every_entry_says_whether_it_is_a_placeholder():
    assert MANIFEST, "assets/nca/manifest.json is empty"
    for key, entry in MANIFEST.items():
        assert isinstance(entry.get("placeholder"), bool), f"{key}: 'placeholder' must be true/false"
        assert (NCA_DIR / key).is_file(), f"{key} is in the manifest but not in assets/nca"
        assert sha256(NCA_DIR / key) == entry["sha256"], f"{key}: file differs from its sha256"
    for path in NCA_DIR.glob("*.npz"):
        assert path.name in MANIFEST, f"{path.name} is shipped without a manifest entry"


@pytest.mark.parametrize("key", REAL or [NO_REAL])
def test_shipped_nca_reproduces_its_manifest(key):
    if key == NO_REAL:
        # nothing evolved is shipped yet: the default walker must say it is a placeholder
        assert MANIFEST["walker_3d.npz"]["placeholder"] is True
        return
    entry = MANIFEST[key]
    npz = NCA_DIR / key
    robot_file = NCA_DIR / entry["robot_file"]
    assert sha256(npz) == entry["sha256"]
    assert sha256(robot_file) == entry["robot_sha256"]
    if "same_as" in entry:  # a copy of another entry (the default walker): same files, same facts
        other = MANIFEST[entry["same_as"]]
        assert entry["sha256"] == other["sha256"] and entry["fitness"] == other["fitness"]
        return
    nca, _ = load_nca(npz)
    assert nca.config.to_dict() == entry["nca"]
    evaluation = entry["evaluation"]
    body = evaluation.get("body", "grid")  # a 2D run of the paper's: its sheet
    robot = body_robot(nca.grow().robot(), body)
    assert robot == Robot.load(robot_file), "the NCA no longer grows the shipped robot"
    assert robot.n_voxels == entry["robot"]["voxels"]
    counts = robot.material_counts()
    for material in Material:
        if material != Material.EMPTY:
            assert counts.get(material, 0) == entry["robot"][material.name.lower()]
    physics = body_physics(Physics.from_dict(evaluation["physics"]), body)  # migrated
    # as its run scored it (entries from before the start shift: one exact start)
    result = evaluate_robot(RobotJob(np.asarray(robot.grid), physics, evaluation["duration_s"],
                                     evaluation.get("starts", 1), evaluation.get("start_seed", 0),
                                     rule=nca.config.dim))
    assert result.stable == entry["stable"]
    fitness = result.fitness
    assert fitness == pytest.approx(entry["fitness"], rel=RTOL, abs=ATOL)
    if entry["distance"] is not None:
        assert result.distance == pytest.approx(entry["distance"], rel=RTOL, abs=ATOL)
    assert np.isfinite(fitness)


@pytest.mark.parametrize("key", REAL or [NO_REAL])
def test_shipped_physics_descriptions_are_read_as_they_were_written(key):
    """Every manifest description has a format this mjregen reads (OLDEST_FORMAT or later)
    and migrates to today's with its own scene and pipeline, the fields added since set to
    what its evaluation did (before format 5: the exact start; before 6: the settle rest
    unset, the body's), and round-trips."""
    if key == NO_REAL:
        assert MANIFEST["walker_3d.npz"]["placeholder"] is True
        return
    old = MANIFEST[key]["evaluation"]["physics"]
    assert OLDEST_FORMAT <= old["format"] <= PHYSICS_FORMAT
    added = {"start_shift": 0.0} if old["format"] < 5 else {}
    if old["format"] < 6:
        added["settle_rest"] = None
    migrated = migrate_physics(old)
    assert migrated["scene"] == {**old["scene"], **added}
    assert migrated["pipeline"] == old["pipeline"] and migrated["format"] == PHYSICS_FORMAT
    physics = Physics.from_dict(old)
    assert Physics.from_dict(json.loads(json.dumps(physics.to_dict()))) == physics


REGEN_DIR = NCA_DIR.parent / "regen"
REGEN = json.loads((REGEN_DIR / "manifest.json").read_text())
PAPER_ROBOTS = ("biped", "tripod", "multiped")


def test_every_shipped_regrowth_nca_has_a_manifest_entry():
    shipped = {p.name for p in REGEN_DIR.glob("*.npz")}
    assert shipped == set(REGEN)
    robots = {entry["robot"] for entry in REGEN.values()}
    assert set(PAPER_ROBOTS) <= robots  # Table 1's three, and the evolved walkers


@pytest.mark.parametrize("key", sorted(REGEN))
def test_shipped_regrowth_nca_reproduces_its_manifest(key):
    """Replayed as scripts/ship_regrowth.py replayed it: the recorded damaged state regrown
    by the NCA (the cells exactly), the three robots walked with the recorded physics (the
    default of the day it was walked)."""
    from mjregen.experiments.regrowth import replay_regrowth

    entry = REGEN[key]
    path = REGEN_DIR / entry["file"]
    assert sha256(path) == entry["sha256"]
    replay = replay_regrowth(path, physics=Physics.from_dict(entry["physics"]))
    assert replay.similarity == entry["similarity"] == replay.metadata["similarity"]
    assert replay.metadata["robot"] == entry["robot"] and replay.metadata["start"] == entry["start"]
    for role, distance in replay.report.distance.items():
        assert distance == pytest.approx(entry["distance"][role], rel=RTOL, abs=ATOL), role


def shipped_walkers() -> dict[str, tuple[Path, dict]]:
    """Each distinct evolved 3D walker robot that assets/ ships: name -> (robot file, its
    "transfer" record)."""
    found, robots = {}, set()
    walkers = json.loads((ASSETS / "robots" / "walkers" / "walkers.json").read_text())["walkers"]
    entries = [(Path(k).stem, NCA_DIR / e["robot_file"], e) for k, e in MANIFEST.items()
               if not e.get("placeholder") and e["nca"]["dim"] == 3]
    entries += [(w["name"], ASSETS / "robots" / "walkers" / w["robot_file"], w) for w in walkers]
    for name, path, entry in entries:
        if sha256(path) not in robots:
            robots.add(sha256(path))
            found[name] = (path, entry["transfer"])
    return found


WALKERS = shipped_walkers()


@pytest.mark.parametrize("name", sorted(WALKERS))
def test_shipped_walkers_keep_their_walk_from_fresh_starts_and_turned(name):
    """The mjregen side of the transfer check (benchmarks/transfer.py): with today's default
    physics the walker's starts of seed 0 walk what its record says, three fresh starts
    (seed 1), its grid turned by 90, 180 and 270 degrees about z and its starts at half the
    time step keep >= 90 % of its recorded distance, and the paper's engine walked it >=
    80 % as far (recorded: the engine is not part of the package)."""
    from mjregen.physics.simulation import simulate_starts
    from mjregen.validation.transfer import ENGINE, FINER_STEP, KEEP, TRANSFER_RULE, rotations

    path, record = WALKERS[name]
    robot = Robot.load(path)
    assert Physics.from_dict(record["physics"]) == Physics() and record["transfers"]
    assert record["rule"] == TRANSFER_RULE
    distance = record["distance"]
    assert distance == pytest.approx(np.mean(record["distances"]), rel=1e-12)
    again = [r.distance for r in simulate_starts(robot, starts=range(2))]
    assert again == pytest.approx(record["distances"][:2], rel=1e-9)
    fresh = [r.distance for r in simulate_starts(robot, start_seed=1, starts=range(3))]
    assert np.mean(fresh) >= KEEP * distance
    turned = [simulate(r).distance for r in rotations(robot)]
    assert turned == pytest.approx(record["rotated"], rel=1e-9)
    assert np.mean(turned) >= KEEP * distance
    finer = [r.distance for r in simulate_starts(robot, physics=Physics().replace(
        timestep_safety=FINER_STEP * Physics().scene.timestep_safety), starts=range(2))]
    assert finer == pytest.approx(record["finer_step_distances"][:2], rel=1e-9)
    assert record["finer_step"] == pytest.approx(np.mean(record["finer_step_distances"]))
    assert record["finer_step"] >= KEEP * distance
    assert record["engine"] >= ENGINE * distance


@pytest.mark.parametrize("key", REAL or [NO_REAL])
def test_shipped_nca_is_its_source_runs_recorded_best(key):
    """A shipped NCA's source run is kept in git (records/), whose best NCA of the stated
    generation is the shipped genome: anyone can trace it to its evolution."""
    if key == NO_REAL:
        assert MANIFEST["walker_3d.npz"]["placeholder"] is True
        return
    source = MANIFEST[key]["source"]
    record = ASSETS.parent / source["run"] / source["file"]
    assert source["run"].startswith("records/") and record.is_file(), (
        f"{key}: its source {source['run']} is not a record in git")
    with np.load(NCA_DIR / key) as shipped, np.load(record) as recorded:
        np.testing.assert_array_equal(shipped["genome"], recorded["genome"])
