"""Text the host prints: safe for a terminal, and the same numbers as JSON.

Nothing from outside is trusted: a device's strings (``sensor_model``), a file's text, a
path the user gave (a folder may be named ``"\\x1b[31m\\n"``).  One carrying ESC sequences
or a newline would repaint the user's terminal or forge output lines.
``printable`` escapes every non-printable character (``\\x1b``, ``\\n``, ``\\x7f``,
``\\u2028``...) of a line; ``printable_lines`` does so line by line.  ``value`` applies the
project's one rule for numbers as well: a non-finite float is ``null`` in text as in
``--json`` (``tactile.output.jsonout.clean``).  Every line the CLI prints goes through
here (``tests/test_escaped_output.py`` reads the sources for it); JSON output is escaped
by ``json`` itself.
"""

from tactile.output.jsonout import clean


def printable(text):
    """``text`` (a ``str``, or any value such as a path, as ``str``) with every non-printable
    character written as a Python escape: one line, whatever it holds."""
    if not isinstance(text, str):
        text = str(text)
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode() for ch in text)


def printable_lines(lines):
    """``lines`` (an iterable of one-line texts) joined by newlines, each one escaped: a
    newline inside a line is shown as ``\\n``, not obeyed."""
    return "\n".join(printable(line) for line in lines)


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
