"""What the host shows: ``text`` (terminal text, device and file strings escaped; JSON with
null for what is not known, never NaN; log lines escaped, a library's rate-limited),
``plots`` (figures with units on every axis)."""
