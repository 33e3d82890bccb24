"""What the host shows: ``textout`` (terminal text, device and file strings escaped),
``jsonout`` (JSON with null for what is not known, never NaN), ``plots`` (figures with
units on every axis)."""
