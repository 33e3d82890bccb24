"""The optional extras (``[project.optional-dependencies]`` of pyproject.toml), in one place.

``need`` imports what one extra provides, or raises ``MissingExtra`` whose one line says
which extra and how to install it.  Modules call it inside the function that uses the
extra, so a run that does not need it never imports it (tests check the CLI's imports).
"""

import importlib

from tactile.errors import MissingExtra

DISTRIBUTION = "tactile-shape"


def hint(extra, purpose):
    """The one line a user sees: '<purpose> needs the '<extra>' extra: pip install ...'."""
    return f"{purpose} needs the '{extra}' extra: pip install '{DISTRIBUTION}[{extra}]'"


def need(extra, purpose, *modules):
    """The ``modules`` imported (a tuple, in order), or ``MissingExtra`` (``hint``)."""
    try:
        return tuple(importlib.import_module(name) for name in modules)
    except ImportError:
        raise MissingExtra(hint(extra, purpose)) from None


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (files only, no display), or ``MissingExtra``."""
    (matplotlib,) = need("plot", "Plotting", "matplotlib")
    matplotlib.use("Agg")
    return need("plot", "Plotting", "matplotlib.pyplot")[0]
