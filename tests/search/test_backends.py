"""Evaluation backends: same results in the same order, failures contained and retried."""

import os
import signal
import sys
import time
from pathlib import Path

import pytest

from mjregen import interrupt
from mjregen.search.backends import ProcessBackend, SerialBackend, ThreadBackend, make_backend


def square_slowly(x: int) -> int:
    time.sleep(0.002 * ((7 * x) % 5))  # finish out of order
    return x * x


def fail_on_three(x: int) -> int:
    if x == 3:
        raise RuntimeError("simulation exploded for item 3")
    return x


def flaky(job: tuple[str, int]) -> int:
    """Fails the first time it sees an item (a marker file remembers), then succeeds."""
    folder, x = job
    marker = Path(folder) / f"seen-{x}"
    if x % 2 == 0 and not marker.exists():
        marker.touch()
        raise OSError(f"transient failure of {x}")
    return x


def die_on_three(x: int) -> int:
    if x == 3:
        time.sleep(0.05)
        os._exit(13)  # the worker process dies, and the pool with it
    time.sleep(0.1)  # others are still running when it dies
    return x


def local_backends():
    return [SerialBackend(), ThreadBackend(2), ProcessBackend(2)]


@pytest.mark.parametrize("backend", local_backends(), ids=lambda b: b.name)
def test_results_come_back_in_item_order(backend):
    with backend:
        outcomes = backend.map(square_slowly, list(range(12)))
    assert [o.value for o in outcomes] == [x * x for x in range(12)]
    assert all(o.ok and o.attempts == 1 for o in outcomes)


@pytest.mark.parametrize("backend", local_backends(), ids=lambda b: b.name)
def test_an_exception_is_contained_and_retried_once(backend):
    with backend:
        outcomes = backend.map(fail_on_three, list(range(6)))
    assert [o.value for o in outcomes] == [0, 1, 2, None, 4, 5]
    assert outcomes[3].attempts == 2 and "simulation exploded for item 3" in outcomes[3].error
    assert "RuntimeError" in outcomes[3].error


@pytest.mark.parametrize("backend", local_backends(), ids=lambda b: b.name)
def test_a_transient_failure_succeeds_on_retry(backend, tmp_path):
    with backend:
        outcomes = backend.map(flaky, [(str(tmp_path), x) for x in range(5)])
    assert [o.value for o in outcomes] == list(range(5))
    assert [o.attempts for o in outcomes] == [2, 1, 2, 1, 2]


def test_a_dead_worker_process_does_not_kill_the_run():
    with ProcessBackend(2) as backend:
        outcomes = backend.map(die_on_three, list(range(8)))
        # items in flight when the pool broke are retried alone, so item 3 cannot kill them twice
        assert [o.value for o in outcomes if o.ok] == [0, 1, 2, 4, 5, 6, 7]
        assert "worker process died" in outcomes[3].error and outcomes[3].attempts == 2
        # the pool was rebuilt and still works
        assert [o.value for o in backend.map(square_slowly, [1, 2])] == [1, 4]


def test_make_backend_validates():
    assert make_backend("serial").workers == 1
    with pytest.raises(ValueError, match="unknown backend"):
        make_backend("gpu")
    with pytest.raises(ValueError, match="Ray backend only"):
        make_backend("process", address="ray://x:1")
    with pytest.raises(ValueError, match="at least 1"):
        ThreadBackend(0)


def test_ray_backend_locally():
    pytest.importorskip("ray")
    from ray import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # tests are not installed
    with make_backend("ray", workers=2) as backend:
        outcomes = backend.map(square_slowly, list(range(8)))
        assert [o.value for o in outcomes] == [x * x for x in range(8)]
        failed = backend.map(fail_on_three, list(range(5)))
        assert failed[3].error and "simulation exploded" in failed[3].error and failed[3].attempts == 2
        assert [o.value for o in failed if o.ok] == [0, 1, 2, 4]
        died = backend.map(die_on_three, list(range(5)))
        assert not died[3].ok and [o.value for o in died if o.ok] == [0, 1, 2, 4]


def test_ray_backend_without_ray_is_a_clear_error(monkeypatch):
    import sys

    from mjregen.search.backends import BackendError

    monkeypatch.setitem(sys.modules, "ray", None)  # as if Ray were not installed
    with pytest.raises(BackendError, match="pip install"):
        make_backend("ray", address="ray://127.0.0.1:10001")


def test_a_ctrl_c_that_a_finalizer_swallowed_still_stops_the_next_evaluation():
    """Python drops a KeyboardInterrupt raised inside __del__ (or a weakref callback); the
    installed handler remembers it, and the backend's loop raises it before the next item."""
    class Dropped:
        def __del__(self) -> None:
            signal.raise_signal(signal.SIGINT)  # the handler runs here; Python ignores it

    restore = interrupt.install()
    try:
        Dropped()  # freed at once: its interrupt is swallowed
        with pytest.raises(KeyboardInterrupt):
            SerialBackend().map(lambda x: x, [1, 2])
    finally:
        restore()
    interrupt.check()  # restored: nothing pending
    assert SerialBackend().map(lambda x: x + 1, [1])[0].value == 2
