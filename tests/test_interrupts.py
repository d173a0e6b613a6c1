"""striatal.interrupts: a Ctrl-C swallowed by a C callback is not lost."""

from __future__ import annotations

import subprocess
import sys
import textwrap

# A SIGINT that lands inside a ctypes callback raises KeyboardInterrupt there; ctypes
# swallows it ("Exception ignored on calling ctypes callback function"), as llvmlite's
# object-cache callback does while Numba compiles. The handler must deliver it again.
SCRIPT = textwrap.dedent(
    """
    import ctypes, signal, sys, time
    from striatal import interrupts
    interrupts.install()
    CALLBACK = ctypes.CFUNCTYPE(None)

    def inside_c():
        signal.raise_signal(signal.SIGINT)
        for _ in range(1000):  # the handler runs here, inside the callback
            pass

    fn = CALLBACK(inside_c)
    try:
        fn()
        for _ in range(100):
            time.sleep(0.01)
        print("lost")
        sys.exit(0)
    except KeyboardInterrupt:
        print("delivered", interrupts.received())
        sys.exit(130)
    """
)


def test_a_ctrl_c_swallowed_by_a_c_callback_is_raised_again() -> None:
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=60
    )
    assert done.stdout.strip() == "delivered True", (done.stdout, done.stderr)
    assert done.returncode == 130
    assert "Traceback" not in done.stderr


def test_other_unraisable_exceptions_still_reach_the_previous_hook() -> None:
    script = textwrap.dedent(
        """
        import ctypes
        from striatal import interrupts
        interrupts.install()
        CALLBACK = ctypes.CFUNCTYPE(None)

        def boom():
            raise ValueError("from a callback")

        CALLBACK(boom)()
        print("went on")
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0 and done.stdout.strip() == "went on"
    assert "ValueError: from a callback" in done.stderr
