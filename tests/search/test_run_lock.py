"""One writer per run folder, a configuration checked against the one the run started with,
and a folder that disagrees with itself refused: nothing saved is lost or silently mixed."""

import json
import signal
import subprocess
import sys
import textwrap

import pytest
from test_runs import GA, Killed, SphereTask, metrics, run  # the same tiny run

from mjregen.search.backends import SerialBackend
from mjregen.search.run_folder import RunFolderError
from mjregen.search.run_lock import LOCK_FILE, RunFolderBusyError, RunLock
from mjregen.search.runs import run_evolution

HOLD = textwrap.dedent("""
    import sys, time
    from mjregen.search.run_lock import RunLock
    with RunLock(sys.argv[1]):
        print("held", flush=True)
        time.sleep(120)
""")


def holder(folder):
    """A second process holding `folder`'s lock (until killed)."""
    process = subprocess.Popen([sys.executable, "-c", HOLD, str(folder)], stdout=subprocess.PIPE,
                               text=True)
    assert process.stdout.readline().strip() == "held"
    return process


def test_a_folder_held_by_another_process_is_refused_even_with_force(tmp_path):
    out = tmp_path / "run"
    run(out)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    process = holder(out)
    try:
        for kwargs in ({"force": True}, {"resume": True}, {}):
            with pytest.raises(RunFolderBusyError, match=f"process {process.pid} on .*started"):
                run(out, **kwargs)
    finally:
        process.kill()
        process.wait()
    after = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file() and p.name != LOCK_FILE}
    assert after == {k: v for k, v in before.items() if k != LOCK_FILE}  # nothing touched
    run(out, force=True)  # the holder died: its lock is taken over
    assert (out / LOCK_FILE).is_file() and len(metrics(out)) == GA.generations


def test_the_lock_of_a_killed_process_is_taken_over(tmp_path):
    process = holder(tmp_path / "run")
    process.send_signal(signal.SIGKILL)
    process.wait()
    with RunLock(tmp_path / "run") as lock:
        assert json.loads(lock.path.read_text())["pid"] != process.pid


def test_the_lock_is_reentrant_in_a_process_and_a_refused_run_leaves_nothing(tmp_path):
    with RunLock(tmp_path / "a"), RunLock(tmp_path / "a"):
        pass
    with RunLock(tmp_path / "a"):  # released by both
        pass
    with pytest.raises(RunFolderError, match="nothing to resume"):
        run(tmp_path / "never", resume=True)
    assert not (tmp_path / "never").exists()


def test_a_config_edited_during_the_run_is_refused_on_resume(tmp_path):
    """The checkpoints carry the hash of the config.json the run started with: an edit made
    while it ran (here the seed, and then resumed with the edited seed) is caught."""
    out = tmp_path / "run"

    def edit_then_die(row):
        if row["generation"] == 0:
            config = json.loads((out / "config.json").read_text())
            (out / "config.json").write_text(json.dumps({**config, "seed": 4}))
        if row["generation"] == 1:
            raise Killed

    with pytest.raises(Killed):
        run(out, on_generation=edit_then_die)
    with pytest.raises(RunFolderError, match="changed since the run wrote"):
        run_evolution(SphereTask(), GA, seed=4, out=out, backend=SerialBackend(),
                      progress=False, resume=True)


def killed_after_two(out):
    def die(row):
        if row["generation"] == 1:
            raise Killed

    with pytest.raises(Killed):
        run(out, on_generation=die)


@pytest.mark.parametrize("damage, message", [
    (lambda out: (out / "metrics.csv").unlink(), "metrics.csv lists no generation but "
                                                  "checkpoint.npz is at generation 2"),
    (lambda out: (out / "checkpoint.npz").unlink(), "checkpoint.npz is missing but metrics.csv "
                                                     "lists 2 finished generations"),
    (lambda out: (out / "best" / "gen_0001.npz").unlink(), "gen_0001.npz is missing"),
    (lambda out: (out / "metrics.csv").write_text("generation,best\nzero,1\n"),
     "not a readable metrics file"),
])
def test_a_folder_that_disagrees_with_itself_is_refused_and_left_as_it_is(tmp_path, damage,
                                                                          message):
    out = tmp_path / "run"
    killed_after_two(out)
    damage(out)
    def contents():  # the lock file records its last holder: not the run's
        return {p.relative_to(out): p.read_bytes() for p in out.rglob("*")
                if p.is_file() and p.name != LOCK_FILE}

    before = contents()
    with pytest.raises(RunFolderError, match=message):
        run(out, resume=True)
    assert contents() == before


def test_a_run_killed_in_its_first_generation_starts_again(tmp_path):
    out = tmp_path / "run"

    def die_at_once(row):
        raise Killed

    with pytest.raises(Killed):
        run(out, on_generation=die_at_once)
    (out / "checkpoint.npz").unlink()  # as if killed before the first checkpoint
    (out / "metrics.csv").unlink()
    summary = run(out, resume=True)
    assert summary.generations == GA.generations


@pytest.mark.parametrize("force", [False, True])
def test_a_run_killed_inside_its_first_config_write_starts_again_without_its_debris(
        tmp_path, force):
    out = tmp_path / "run"
    out.mkdir()
    (out / ".config.json.k1ll3d00").write_text('{"half": ')  # what the killed write left
    summary = run(out, force=force)
    assert summary.generations == GA.generations
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == [LOCK_FILE]
