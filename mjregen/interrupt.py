"""Ctrl-C that is never lost.

Python turns SIGINT into KeyboardInterrupt wherever the main thread happens to be; when that
is inside a finalizer or a weakref callback (freeing a MuJoCo model, say), Python prints
"Exception ignored ... KeyboardInterrupt" and the interrupt is gone, so a long run would go
on. `install` replaces the handler with one that also remembers the request (and keeps such
swallowed interrupts off stderr); long loops call `check` at safe points (between
evaluations, between generations), which raises KeyboardInterrupt again if the first one
was swallowed.
"""

from __future__ import annotations

import signal
import sys
import threading
from typing import Callable

_requested = threading.Event()


def _handler(signum: int, frame: object) -> None:
    _requested.set()
    raise KeyboardInterrupt


def install() -> Callable[[], None]:
    """Handle SIGINT as described above (main thread only); returns a function that
    restores the previous handler and hook and forgets any request."""
    previous, hook = signal.signal(signal.SIGINT, _handler), sys.unraisablehook

    def quiet(unraisable: object) -> None:
        if not (_requested.is_set() and unraisable.exc_type is KeyboardInterrupt):
            hook(unraisable)

    sys.unraisablehook = quiet

    def restore() -> None:
        signal.signal(signal.SIGINT, previous)
        sys.unraisablehook = hook
        _requested.clear()

    return restore


def check() -> None:
    """Raise KeyboardInterrupt if Ctrl-C was pressed since `install` (no-op otherwise)."""
    if _requested.is_set():
        raise KeyboardInterrupt
