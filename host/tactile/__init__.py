"""tactile host package: stream decoding, EP1/EP2 shape analysis and the CLI.

Imports stay lazy: ``import tactile`` pulls in nothing heavy.
"""

__version__ = "0.1.0"
