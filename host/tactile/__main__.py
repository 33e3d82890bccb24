"""``python -m tactile``: the ``tactile`` command (``tactile.cli.main``)."""

from tactile.cli.main import main

raise SystemExit(main())
