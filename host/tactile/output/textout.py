"""Text output of what a device said: safe for a terminal, and the same numbers as JSON.

A device's strings (``sensor_model``) are not trusted: one carrying ESC sequences
or a newline would repaint the user's terminal or forge output lines.
``printable`` escapes every non-printable character (``\\x1b``, ``\\n``, ``\\x7f``,
``\\u2028``...).  ``value`` applies the project's one rule for numbers as well: a
non-finite float is ``null`` in text as in ``--json`` (``tactile.output.jsonout.clean``).
Every text output of device data goes through here; JSON output is escaped by
``json`` itself.
"""

from tactile.output.jsonout import clean


def printable(text):
    """``text`` with every non-printable character written as a Python escape."""
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode() for ch in text)


def value(v):
    """One value as text: strings escaped, non-finite floats ``null`` (as in JSON)."""
    v = clean(v)
    if v is None:
        return "null"
    if isinstance(v, str):
        return printable(v)
    if isinstance(v, list):
        return "[" + ", ".join(value(x) for x in v) + "]"
    return str(v)


def fields(d, skip=("type",)):
    """``key=value`` pairs of a message dictionary, space separated."""
    return " ".join(f"{k}={value(v)}" for k, v in d.items() if k not in skip)
