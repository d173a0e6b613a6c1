"""``python -m striatal``."""

try:
    from striatal import interrupts

    interrupts.install()  # from here on a second Ctrl-C cannot cut the handling of the first
    from striatal.cli import main
except KeyboardInterrupt:  # Ctrl-C in the first milliseconds: quiet, as later
    if "interrupts" in globals():
        interrupts.forget_unhandled()
    raise SystemExit(130) from None

raise SystemExit(main())
