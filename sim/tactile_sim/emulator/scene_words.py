"""A scene's types and values in words, for its errors and docs/scenes.md: a type's range
(``describe``), a choice's names (``choices``), a TOML value shown short (``show``) and the
key a misspelt one meant (``did_you_mean``).
"""

import datetime
import difflib
import importlib


def show(value, width=40):
    """A short, one-line rendering of a TOML value for error messages."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, (datetime.date, datetime.time)):
        return f"a date or time ({value.isoformat()})"
    text = repr(value)
    if isinstance(value, list) and len(text) > width:
        return f"a list of {len(value)}"
    return text if len(text) <= width else text[: width - 3] + "..."


def did_you_mean(name, known):
    """``' (did you mean X?)'`` for a near miss among ``known``, else the known names; one
    that begins with ``name`` (``rate_hz`` for ``rate``) wins over a look-alike (``gate``)."""
    name = str(name)
    stem = name.rstrip("]")
    close = [k for k in known if len(stem.strip("[")) > 1 and k.startswith(stem)]
    close = close or difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    if close:
        return f" (did you mean {close[0]}?)"
    return f" (known: {', '.join(known)})" if known else ""


def choices(t):
    """The names a ``choice`` type takes (its module imported now if it names one)."""
    if isinstance(t.of, str):
        module, name = t.of.split(":")
        return tuple(getattr(importlib.import_module(module), name))
    return tuple(t.of)


def describe(t):
    """``t`` in words, for an error and the docs (``number in (0, 1]``)."""
    k, item = t.kind, t.of
    if k in ("int", "number"):
        lo, hi = (t.lo, t.hi) if k == "int" else (number_text(t.lo), number_text(t.hi))
        return f"{'integer' if k == 'int' else 'number'} in {'(' if t.open else '['}{lo}, {hi}]"
    if k == "row" and t.names:
        same = all(i == item[0] for i in item)
        return f"[{', '.join(t.names)}]" + (f", each a {describe(item[0])}" if same else "")
    if k == "row":
        return f"list of {len(item)}: {describe(item[0])}"
    if k in ("list", "table"):
        head = f"list of {size_text(t)}: " if k == "list" else "table of names to "
        return head + describe(item)
    if k == "either":
        return " or a ".join(map(describe, item))
    if k == "choice":
        return "one of " + ", ".join(choices(t))
    return "true or false" if k == "bool" else f"string, 1 to {t.hi} printable ASCII characters"


def size_text(t):
    return f"{t.lo}" if t.lo == t.hi else f"{t.lo} to {t.hi}"


def number_text(x):
    if isinstance(x, float) and not (x.is_integer() and abs(x) < 1e16):
        return f"{x:g}"
    return str(int(x))
