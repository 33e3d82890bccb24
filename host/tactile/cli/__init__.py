"""The ``tactile`` command line.  Each subcommand is its own module, imported only when run."""
