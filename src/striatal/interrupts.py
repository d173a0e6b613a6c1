"""Ctrl-C for the command line: the first SIGINT raises, the later ones are ignored.

Python's own handler raises KeyboardInterrupt on every SIGINT, so a second Ctrl-C
can land in the code that handles the first (an ``except`` clause, an import in
it, a worker pool's shutdown, the interpreter's exit) and end the process with a
traceback or by SIGINT instead of exit 130. ``python -m striatal`` and the
``striatal`` script install :func:`first_only` before anything heavy loads;
:func:`received` tells the command line that a Ctrl-C came, so that an error it
caused (an import cut short, reported by a C extension as an ImportError) still
exits 130. Only ``signal`` is imported here, to keep the window before it small.

A KeyboardInterrupt must not be raised while Numba or llvmlite code runs (an
import of either, a compilation, a load from Numba's cache): LLVM objects made in
C and not yet owned by their Python wrappers are then freed twice, and the process
dies by SIGSEGV or SIGABRT ("double free detected") instead of exiting 130. The
handler therefore looks at the interrupted stack: inside either library it only
marks the Ctrl-C pending and raises the signal again a moment later, until the
main thread is out (:func:`raise_when_safe`).

A KeyboardInterrupt raised while C code runs a Python callback of another library
is swallowed there and reported as an "Exception ignored" traceback; the command
would then run on to exit 0 with the Ctrl-C lost. :func:`install` also sets a
``sys.unraisablehook`` that marks such a Ctrl-C pending and raises the signal again,
so that it lands outside the callback.
"""

from __future__ import annotations

import signal

# not ``typing.TYPE_CHECKING``: importing typing would widen the start-up window
TYPE_CHECKING = False
if TYPE_CHECKING:
    from types import FrameType

__all__ = ["first_only", "forget_unhandled", "install", "raise_when_safe", "received"]

_state: dict[str, object] = {"received": False, "pending": False}
# top-level packages whose Python code owns LLVM objects in C: never interrupted
_UNSAFE = frozenset({"numba", "llvmlite"})
# Numba's Python-level dispatch of a compiled ufunc (a ``@vectorize`` call such as the
# kernel's ``log10_libm``): it owns no LLVM object, and a compilation it starts runs in
# deeper frames of numba.core and llvmlite, which stay unsafe. Code that calls such a
# ufunc in a loop spends most of its bytecode there, so a Ctrl-C kept pending inside it
# would wait until the loop ends.
_SAFE_FRAMES = frozenset({("numba.np.ufunc.dufunc", "__call__")})
# seconds between two looks at the stack while a Ctrl-C is pending
RETRY_S = 0.02


def first_only(signum: int, frame: FrameType | None) -> None:
    """SIGINT handler: KeyboardInterrupt the first time (once it is safe), nothing afterwards."""
    if _state["received"] and not _state["pending"]:
        return
    _state["received"] = True
    raise_when_safe(frame)


def in_unsafe_code(frame: FrameType | None) -> bool:
    """Whether a frame of Numba or llvmlite is on the stack that ``frame`` ends."""
    while frame is not None:
        name = frame.f_globals.get("__name__")
        if (
            isinstance(name, str)
            and name.partition(".")[0] in _UNSAFE
            and (name, frame.f_code.co_name) not in _SAFE_FRAMES
        ):
            return True
        frame = frame.f_back
    return False


def raise_when_safe(frame: FrameType | None) -> None:
    """For a signal handler: raise KeyboardInterrupt now, or, while Numba or llvmlite
    code runs (:func:`in_unsafe_code`), mark it pending and raise SIGINT again in
    ``RETRY_S`` seconds, so that the handler looks again."""
    if in_unsafe_code(frame):
        _state["pending"] = True
        _signal_again()
        return
    _state["pending"] = False
    raise KeyboardInterrupt


def _signal_again() -> None:
    import threading

    # from a thread, a moment later: the main thread runs the handler at its next
    # bytecode; a daemon, so that a pending Ctrl-C never holds up the exit
    timer = threading.Timer(RETRY_S, signal.raise_signal, (signal.SIGINT,))
    timer.daemon = True
    try:
        timer.start()
    except RuntimeError:  # "can't create new thread at interpreter shutdown": ending anyway
        return


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
        # first_only raises it again, out of the callback and this hook (both swallow it)
        _state["pending"] = True
        _signal_again()
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
