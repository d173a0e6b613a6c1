"""``python -m striatal``."""

try:
    from striatal.cli import main
except KeyboardInterrupt:  # Ctrl-C in the first milliseconds: quiet, as later
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # and a second one too
    raise SystemExit(130) from None

raise SystemExit(main())
