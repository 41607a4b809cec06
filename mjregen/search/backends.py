"""Evaluation backends: run one function over many items, serially, on local processes or
threads, or on a Ray cluster, behind one interface.

Every backend returns one `Outcome` per item, in item order, whatever order the work
finished in, so results never depend on the backend. A call that raises, or whose worker
process dies, is retried once; if it fails again its `Outcome` carries the error instead of
a value, and the other items are unaffected.
"""

from __future__ import annotations

import concurrent.futures as futures
import ctypes
import multiprocessing
import os
import signal
import socket
import sys
import threading
import time
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Generic, Sequence, TypeVar

from mjregen import interrupt
from mjregen.errors import MjregenError
from mjregen.search import BACKENDS

T = TypeVar("T")
R = TypeVar("R")

MAX_ATTEMPTS = 2  # the first try and one retry
RAY_CONNECT_TIMEOUT = 10.0  # s to reach a Ray cluster's address before giving up


class BackendError(MjregenError, ValueError):
    """A backend cannot be made: unknown name, bad worker count, Ray missing or unreachable."""


@dataclass(frozen=True)
class Outcome(Generic[R]):
    """Result of one item: `value` when it succeeded, else `error` (a one-line reason) and
    `trace` (its traceback, the worker's included where the backend sends it)."""

    value: R | None
    error: str | None
    attempts: int
    trace: str = ""

    @property
    def ok(self) -> bool:
        return self.error is None


def _describe(error: BaseException) -> str:
    last = traceback.format_exception_only(type(error), error)[-1].strip()
    return last.replace("\n", " ")


def _failed(error: BaseException, attempts: int, prefix: str = "") -> Outcome:
    """The Outcome of an item whose last attempt raised `error`."""
    reason = _describe(error)
    return Outcome(None, f"{prefix}({reason})" if prefix else reason, attempts,
                   "".join(traceback.format_exception(error)))


class Backend:
    """Common interface. Use as a context manager, or call `close()` when done."""

    name = "base"

    def __init__(self, workers: int = 1) -> None:
        if workers < 1:
            raise BackendError(f"workers must be at least 1, got {workers}")
        self.workers = workers

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[Outcome[R]]:
        """Apply `fn` (a picklable top-level function for process/Ray backends) to every item."""
        raise NotImplementedError

    def close(self) -> None:
        """Release workers; the backend cannot be used afterwards."""

    def __enter__(self) -> Backend:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class SerialBackend(Backend):
    """Everything in this process, one item after another."""

    name = "serial"

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[Outcome[R]]:
        outcomes = []
        for item in items:
            interrupt.check()
            error: BaseException | None = None
            for attempt in range(1, MAX_ATTEMPTS + 1):
                try:
                    outcomes.append(Outcome(fn(item), None, attempt))
                    break
                except Exception as exc:  # noqa: BLE001 - contained and reported per item
                    error = exc
            else:
                outcomes.append(_failed(error, MAX_ATTEMPTS))
        return outcomes


class _ExecutorBackend(Backend):
    """A `concurrent.futures` pool; rebuilt if a worker process dies."""

    def __init__(self, workers: int) -> None:
        super().__init__(workers)
        self._pool = self._make_pool()

    def _make_pool(self) -> futures.Executor:
        raise NotImplementedError

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[Outcome[R]]:
        """All items in parallel; then the failed ones again, one at a time, so that an item
        whose evaluation kills its worker cannot take other items down on its retry."""
        results: dict[int, Outcome[R]] = {}
        retry: list[int] = []
        submitted = {self._pool.submit(fn, item): i for i, item in enumerate(items)}
        broken = False
        for future in futures.as_completed(submitted):
            interrupt.check()
            try:
                results[submitted[future]] = Outcome(future.result(), None, 1)
            except futures.process.BrokenProcessPool:
                broken = True
                retry.append(submitted[future])
            except Exception:  # noqa: BLE001 - retried below, reported per item
                retry.append(submitted[future])
        if broken:
            self._restart()
        for index in sorted(retry):
            try:
                results[index] = Outcome(self._pool.submit(fn, items[index]).result(), None, MAX_ATTEMPTS)
            except futures.process.BrokenProcessPool as exc:
                self._restart()
                results[index] = _failed(exc, MAX_ATTEMPTS, prefix="worker process died ")
            except Exception as exc:  # noqa: BLE001 - contained and reported per item
                results[index] = _failed(exc, MAX_ATTEMPTS)
        return [results[i] for i in range(len(items))]

    def _restart(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)
        self._pool = self._make_pool()

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


class ProcessBackend(_ExecutorBackend):
    """Local worker processes (started with 'spawn': safe with torch and MuJoCo loaded)."""

    name = "process"

    def _make_pool(self) -> futures.Executor:
        return futures.ProcessPoolExecutor(
            max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
            initializer=_worker_init, initargs=(os.getpid(),),
        )


def _worker_init(parent: int) -> None:
    """In a worker process: leave Ctrl-C to the parent (it stops the run and says how to
    resume), and exit when the parent dies (Linux: a death signal; elsewhere a watcher
    thread that polls the parent's pid)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != parent:  # it died before the death signal was armed
        os._exit(1)
    if not sys.platform.startswith("linux"):
        def watch() -> None:
            while os.getppid() == parent:
                time.sleep(1.0)
            os._exit(1)

        threading.Thread(target=watch, daemon=True).start()


class ThreadBackend(_ExecutorBackend):
    """Local threads (MuJoCo releases the GIL inside `mj_step`)."""

    name = "thread"

    def _make_pool(self) -> futures.Executor:
        return futures.ThreadPoolExecutor(max_workers=self.workers)


class RayBackend(Backend):
    """Ray tasks: a local Ray instance, or a cluster at `address` (``ray://host:port`` or
    ``auto``). Needs ``pip install 'mjregen[ray]'``."""

    name = "ray"

    def __init__(self, workers: int | None = None, *, address: str | None = None) -> None:
        try:
            import ray
        except ImportError:
            raise BackendError(
                "the Ray backend needs Ray: pip install 'mjregen[ray]' (or pip install ray)"
            ) from None
        if address is not None and address != "auto":
            _check_reachable(address)
        self._ray = ray
        self._started_here = not ray.is_initialized()
        if self._started_here:
            kwargs: dict[str, Any] = {"address": address, "include_dashboard": False,
                                      "log_to_driver": False}
            if address is None:
                kwargs["num_cpus"] = workers or os.cpu_count() or 1
            ray.init(**kwargs)
        super().__init__(int(ray.cluster_resources().get("CPU", 1)) if workers is None else workers)
        self._remote: dict[Callable, Any] = {}

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[Outcome[R]]:
        ray = self._ray
        remote = self._remote.setdefault(fn, ray.remote(num_cpus=1, max_retries=0)(fn))
        results: dict[int, Outcome[R]] = {}
        errors: dict[int, BaseException] = {}
        pending = list(range(len(items)))
        for attempt in range(1, MAX_ATTEMPTS + 1):
            refs = {i: remote.remote(items[i]) for i in pending}
            pending = []
            for index, ref in refs.items():
                try:
                    results[index] = Outcome(ray.get(ref), None, attempt)
                except Exception as exc:  # noqa: BLE001 - task errors and dead workers alike
                    cause = getattr(exc, "cause", None)
                    errors[index] = cause if isinstance(cause, BaseException) else exc
                    pending.append(index)
            if not pending:
                break
        for index in pending:
            results[index] = _failed(errors[index], MAX_ATTEMPTS)
        return [results[i] for i in range(len(items))]

    def close(self) -> None:
        if self._started_here and self._ray.is_initialized():
            self._ray.shutdown()




def _check_reachable(address: str) -> None:
    """Raise BackendError unless a TCP connection to the Ray address (``[ray://]host:port``)
    opens within RAY_CONNECT_TIMEOUT s (``ray.init`` itself can wait for minutes)."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        raise BackendError(f"Ray address {address!r} is not [ray://]host:port or 'auto'")
    try:
        socket.create_connection((host, int(port)), timeout=RAY_CONNECT_TIMEOUT).close()
    except OSError as error:
        raise BackendError(f"cannot reach the Ray cluster at {address} within "
                           f"{RAY_CONNECT_TIMEOUT:g} s: {error}") from None


def make_backend(name: str, *, workers: int | None = None, address: str | None = None) -> Backend:
    """Backend by name; `workers` defaults to all cores (serial: 1).

    Raises:
      BackendError: unknown name, `workers` < 1, `address` without Ray or unreachable.
    """
    if address is not None and name != "ray":
        raise BackendError("--address is for the Ray backend only")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise BackendError(f"workers must be a whole number >= 1 (omit it for all cores), "
                           f"got {workers!r}")
    cores = os.cpu_count() or 1
    if name == "serial":
        return SerialBackend()
    if name == "process":
        return ProcessBackend(workers or cores)
    if name == "thread":
        return ThreadBackend(workers or cores)
    if name == "ray":
        return RayBackend(workers, address=address)
    raise BackendError(f"unknown backend {name!r}; choose one of {', '.join(BACKENDS)}")
