"""Ctrl-C for the command line: the first SIGINT raises, the later ones are ignored.

Python's own handler raises KeyboardInterrupt on every SIGINT, so a second Ctrl-C
can land in the code that handles the first (an ``except`` clause, an import in
it, a worker pool's shutdown, the interpreter's exit) and end the process with a
traceback or by SIGINT instead of exit 130. ``python -m striatal`` and the
``striatal`` script install :func:`first_only` before anything heavy loads;
:func:`received` tells the command line that a Ctrl-C came, so that an error it
caused (an import cut short, reported by a C extension as an ImportError) still
exits 130. Only ``signal`` is imported here, to keep the window before it small.

A KeyboardInterrupt raised while C code runs a Python callback (llvmlite's object
cache hook while Numba compiles, for one) is swallowed there and reported as an
"Exception ignored" traceback; the command would then run on to exit 0 with the
Ctrl-C lost. :func:`install` also sets a ``sys.unraisablehook`` that re-arms the
handler and raises the signal again a moment later, so it lands outside the
callback.
"""

from __future__ import annotations

import signal

__all__ = ["first_only", "forget_unhandled", "install", "received"]

_state: dict[str, object] = {"received": False}


def first_only(signum: int, frame: object) -> None:
    """SIGINT handler: KeyboardInterrupt the first time, nothing afterwards."""
    if _state["received"]:
        return
    _state["received"] = True
    raise KeyboardInterrupt


def install() -> None:
    """Make :func:`first_only` the SIGINT handler (main thread only; else a no-op).

    A SIGINT that was ignored when the process started (``nohup``, a background
    job of a non-interactive shell) stays ignored.
    """
    import threading

    if threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        return
    import sys

    if sys.unraisablehook is not _redeliver:
        _state["previous_hook"] = sys.unraisablehook
        sys.unraisablehook = _redeliver
    signal.signal(signal.SIGINT, first_only)


def _redeliver(unraisable: object) -> None:
    """``sys.unraisablehook``: a Ctrl-C swallowed by a C callback is raised again.

    Any other unraisable exception goes to the hook that was there before.
    """
    if isinstance(getattr(unraisable, "exc_value", None), KeyboardInterrupt) and _state["received"]:
        _state["received"] = False  # first_only raises it again
        import threading

        # raised from a thread a moment later: the main thread then handles it at its
        # next bytecode, out of the callback and this hook (both of which swallow it)
        threading.Timer(0.02, signal.raise_signal, (signal.SIGINT,)).start()
        return
    previous = _state.get("previous_hook")
    if callable(previous):
        previous(unraisable)


def received() -> bool:
    """Whether a SIGINT reached :func:`first_only` in this process."""
    return bool(_state["received"])


def forget_unhandled() -> None:
    """Clear CPython's record of a KeyboardInterrupt that escaped C-level ``PyRun_*`` code.

    A Ctrl-C that lands while a C extension runs Python source through
    ``PyRun_String`` during its import (SciPy's and Numba's start-up do) sets a
    global flag that makes the interpreter end by SIGINT at exit, silently, even
    though striatal caught the KeyboardInterrupt and exits 130. Each ``PyRun_*``
    call resets that flag first; running an empty string through one does only
    that. Not CPython, or no ``ctypes``: nothing to do.
    """
    import sys

    if sys.implementation.name != "cpython":
        return
    try:
        import ctypes

        ctypes.pythonapi.PyRun_SimpleString(b"")
    except (ImportError, AttributeError, OSError):
        return
