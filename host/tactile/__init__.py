"""tactile host package: stream decoding, EP1/EP2 shape analysis and the CLI.

Imports stay lazy: ``import tactile`` pulls in nothing heavy.  ``tactile.load_recording``
(``tactile.recording.load``'s, with ``payload=`` from ``tactile.payload.apply``) imports
NumPy when first used.
"""

__version__ = "0.1.0"
__all__ = ["load_recording"]


def __getattr__(name):
    if name == "load_recording":
        from tactile.payload.apply import load_recording

        return load_recording
    raise AttributeError(f"module 'tactile' has no attribute {name!r}")
