"""Where the emulator's cores keep what they build once per source version: the C core's
shared library and its ADC bank (``cores``, ``adc_bank``), the QEMU image (``qemu_core``)
and the emulated Pico's npm packages (``pico_core``), under ``$XDG_CACHE_HOME/tactile``.

It sits below the cores and the module that builds them, so none of them imports another
for its folder.
"""

import os
import pathlib


def cache_dir():
    """``$XDG_CACHE_HOME/tactile/ccore`` (``~/.cache`` when the variable is unset or empty)."""
    root = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(root) / "tactile" / "ccore"
