"""Firmware code that runs under CPython only (a Linux controller), never on a board.

``tactile flash`` copies only the top level of ``tactile_fw``, so nothing here
reaches a MicroPython board; this is the one place that may import ``smbus2``.
"""
