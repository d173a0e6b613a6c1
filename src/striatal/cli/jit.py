"""One line on stderr when a command compiles the simulation kernel.

Numba compiles the kernel on its first call and keeps the machine code in its cache
(``__pycache__`` beside the kernel's modules, or ``NUMBA_CACHE_DIR``); a later run loads
it in a fraction of a second. Numba's ``numba:compile`` event fires only on a cache
miss, just before it compiles, so listening to it says the line exactly when a command
is about to spend those seconds, and never on a warm cache.
"""

from __future__ import annotations

import sys
from typing import Any, TextIO

#: What a command says before its first compile of the kernel (``{where}``: the cache).
NOTICE = "striatal: compiling the simulation kernel (once, about 10-30 s; cached in {where})\n"


def cache_dir(dispatcher: Any) -> str | None:
    """The folder where Numba caches ``dispatcher``'s machine code, or None if it does not."""
    return getattr(getattr(dispatcher, "_cache", None), "_cache_path", None)


def announce_compiles(package: str = "striatal", stream: TextIO | None = None) -> None:
    """From now on, say :data:`NOTICE` once, before Numba compiles the first cached
    function of ``package`` (imports Numba). The worker processes of a sweep, forked
    with the listener, share its flag: one line in all, from whichever compiles first."""
    import multiprocessing

    from numba.core import event

    said = multiprocessing.Value("b", 0)

    class Notice(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            dispatcher = ev.data["dispatcher"]
            module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
            where = cache_dir(dispatcher)
            if where is None or module.partition(".")[0] != package:
                return
            with said.get_lock():
                if said.value:
                    return
                said.value = 1
            out = sys.stderr if stream is None else stream
            out.write(NOTICE.format(where=where))
            out.flush()

        def on_end(self, ev: event.Event) -> None:
            pass

    event.register("numba:compile", Notice())
