"""tactile firmware: MicroPython code for the F/T sampling board (also runs under CPython)."""
