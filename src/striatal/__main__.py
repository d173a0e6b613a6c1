"""``python -m striatal``."""

from striatal.cli import main

raise SystemExit(main())
