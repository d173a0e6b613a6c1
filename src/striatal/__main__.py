"""``python -m striatal``."""

try:
    from striatal.cli import main
except KeyboardInterrupt:  # Ctrl-C in the first milliseconds: quiet, as later
    raise SystemExit(130) from None

raise SystemExit(main())
