"""Typed keys for TOML tables: the words ``scene_schema`` is written in.

Each key type checks one parsed TOML value and returns it normalised (ints given for
floats become floats, missing optional keys their default), or raises ``Bad`` with what it
must be (``must be finite and >= 0, got nan``).  ``Bad.where`` collects the path below the
key as the error travels up (``[2]`` for a list item, ``.a`` for a table entry), so the
scene loader can name file, section and key in one line.  Each type also describes itself
(``describe``) for the schema's documentation, so the docs and the checks cannot differ.
"""

import copy
import datetime
import difflib
import importlib
import math

REQUIRED = object()  # the default of a key that must be given


class Bad(ValueError):
    """A value that breaks its key's rule; ``where`` is the path below the key."""

    def __init__(self, why, where=""):
        super().__init__(why)
        self.why = why
        self.where = where

    def under(self, part):
        return Bad(self.why, part + self.where)


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


def _num(x):
    if isinstance(x, float) and not (x.is_integer() and abs(x) < 1e16):
        return f"{x:g}"
    return str(int(x))


def did_you_mean(name, known):
    """``' (did you mean X?)'`` for a near miss among ``known``, else the known names.

    A known name that begins with ``name`` (``rate`` for ``rate_hz``) wins over one that
    merely looks alike (``gate``).
    """
    name = str(name)
    stem = name.rstrip("]")
    close = [k for k in known if len(stem.strip("[")) > 1 and k.startswith(stem)]
    close = close or difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    if close:
        return f" (did you mean {close[0]}?)"
    return f" (known: {', '.join(known)})" if known else ""


class Key:
    """Base: a default (``REQUIRED`` if none), a unit and a sentence of documentation."""

    kind = "value"

    def __init__(self, default=REQUIRED, unit="", doc=""):
        self.default = default
        self.unit = unit
        self.doc = doc

    @property
    def required(self):
        return self.default is REQUIRED

    def check(self, value):
        raise NotImplementedError

    def describe(self):
        return self.kind


class Int(Key):
    """An integer from ``lo`` to ``hi`` (not a bool, though TOML's true is Python's 1)."""

    kind = "integer"

    def __init__(self, lo, hi, default=REQUIRED, unit="", doc=""):
        super().__init__(default, unit, doc)
        self.lo, self.hi = lo, hi

    def check(self, value):
        if not isinstance(value, int) or isinstance(value, bool):
            raise Bad(f"must be an integer, got {show(value)}")
        if not self.lo <= value <= self.hi:
            raise Bad(f"must be from {self.lo} to {self.hi}, got {show(value)}")
        return value

    def describe(self):
        return f"integer in [{self.lo}, {self.hi}]"


class Float(Key):
    """A finite number from ``lo`` to ``hi`` (``lo_open``: above ``lo``); ints accepted."""

    kind = "number"

    def __init__(self, lo, hi, default=REQUIRED, unit="", doc="", lo_open=False):
        super().__init__(default, unit, doc)
        self.lo, self.hi, self.lo_open = lo, hi, lo_open

    def check(self, value):
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise Bad(f"must be a number, got {show(value)}")
        try:
            x = float(value)
        except OverflowError:  # an integer beyond any float
            x = math.inf
        above = x > self.lo if self.lo_open else x >= self.lo
        if not (math.isfinite(x) and above and x <= self.hi):
            lo = f"{'>' if self.lo_open else '>='} {_num(self.lo)}"
            raise Bad(f"must be finite, {lo} and <= {_num(self.hi)}, got {show(value)}")
        return x

    def describe(self):
        return f"number in {'(' if self.lo_open else '['}{_num(self.lo)}, {_num(self.hi)}]"


class Bool(Key):
    kind = "true or false"

    def check(self, value):
        if not isinstance(value, bool):
            raise Bad(f"must be true or false, got {show(value)}")
        return value


class Text(Key):
    """A string of printable ASCII, at most ``max_len`` characters."""

    kind = "string"

    def __init__(self, max_len, default=REQUIRED, doc=""):
        super().__init__(default, "", doc)
        self.max_len = max_len

    def check(self, value):
        if not isinstance(value, str):
            raise Bad(f"must be a string, got {show(value)}")
        if not (value.isascii() and value.isprintable()) or not 0 < len(value) <= self.max_len:
            raise Bad(f"must be 1 to {self.max_len} printable ASCII characters, got {show(value)}")
        return value

    def describe(self):
        return f"string, 1 to {self.max_len} printable ASCII characters"


class Choice(Key):
    """One of a set of names; ``choices`` may be ``"module:NAME"``, imported only when a
    value is checked (so a scene imports the geometry of its own motion only)."""

    kind = "name"

    def __init__(self, choices, default=REQUIRED, doc=""):
        super().__init__(default, "", doc)
        self._choices = choices

    @property
    def choices(self):
        if isinstance(self._choices, str):
            module, name = self._choices.split(":")
            self._choices = tuple(getattr(importlib.import_module(module), name))
        return tuple(self._choices)

    def check(self, value):
        if not isinstance(value, str) or value not in self.choices:
            raise Bad(f"must be one of {', '.join(self.choices)}, got {show(value)}")
        return value

    def describe(self):
        return "one of " + ", ".join(self.choices)


class List(Key):
    """A list of ``item``, of exactly ``length`` items or ``min_len`` to ``max_len``."""

    kind = "list"

    def __init__(
        self,
        item,
        default=REQUIRED,
        unit="",
        doc="",
        *,
        length=None,
        min_len=0,
        max_len=10_000,
        unique=False,
    ):
        super().__init__(default, unit, doc)
        self.item = item
        self.min_len, self.max_len = (length, length) if length else (min_len, max_len)
        self.unique = unique

    def _size(self):
        if self.min_len == self.max_len:
            return f"{self.min_len}"
        return f"{self.min_len} to {self.max_len}"

    def check(self, value):
        if not isinstance(value, list) or not self.min_len <= len(value) <= self.max_len:
            what = f"a list of {self._size()} ({self.item.describe()})"
            raise Bad(f"must be {what}, got {show(value)}")
        out = []
        for i, v in enumerate(value):
            try:
                out.append(self.item.check(v))
            except Bad as bad:
                raise bad.under(f"[{i}]") from None
        if self.unique and len(set(map(repr, out))) != len(out):
            raise Bad(f"must not repeat an item, got {show(value)}")
        return out

    def describe(self):
        return f"list of {self._size()}: {self.item.describe()}"


class Map(Key):
    """An inline table of names to ``value`` (names checked by whoever uses them)."""

    kind = "table"

    def __init__(self, value, default=REQUIRED, unit="", doc="", *, max_len=16):
        super().__init__(default, unit, doc)
        self.value = value
        self.max_len = max_len

    def check(self, value):
        if not isinstance(value, dict) or len(value) > self.max_len:
            raise Bad(f"must be a table of at most {self.max_len} entries, got {show(value)}")
        out = {}
        for name, v in value.items():
            try:
                out[name] = self.value.check(v)
            except Bad as bad:
                raise bad.under(f".{name}") from None
        return out

    def describe(self):
        return f"table of names to {self.value.describe()}"


class Row(Key):
    """A fixed-length list whose items each have their own key (``[t_s, fx, ..., tz]``)."""

    kind = "list"

    def __init__(self, *items, names=None, default=REQUIRED, unit="", doc=""):
        super().__init__(default, unit, doc)
        self.items = items
        self.names = names

    def check(self, value):
        n = len(self.items)
        if not isinstance(value, list) or len(value) != n:
            raise Bad(f"must be a list of {n} numbers, got {show(value)}")
        out = []
        for i, (item, v) in enumerate(zip(self.items, value)):
            try:
                out.append(item.check(v))
            except Bad as bad:
                raise bad.under(f"[{i}]") from None
        return out

    def describe(self):
        if self.names:
            return f"[{', '.join(self.names)}]"
        return f"list of {len(self.items)}: {self.items[0].describe()}"


class Either(Key):
    """One number or a list (``bias_counts``): the option of the value's own type checks it."""

    def __init__(self, *options, default=REQUIRED, unit="", doc=""):
        super().__init__(default, unit, doc)
        self.options = options

    def check(self, value):
        for option in self.options:
            if isinstance(value, list) == isinstance(option, (List, Row)):
                return option.check(value)
        raise Bad(f"must be a {self.describe()}, got {show(value)}")

    def describe(self):
        return " or a ".join(o.describe() for o in self.options)


def check_table(keys, given):
    """``given`` (a TOML table) checked against ``keys`` (name -> Key), defaults filled in.

    Raises ``Bad`` whose ``where`` starts with the key's name.
    """
    out = {}
    for name in given:
        if name not in keys:
            raise Bad("unknown key" + did_you_mean(name, list(keys)), where=str(name))
    for name, key in keys.items():
        if name in given:
            try:
                out[name] = key.check(given[name])
            except Bad as bad:
                raise bad.under(name) from None
        elif key.required:
            raise Bad(f"required ({key.describe()})", where=name)
        else:
            out[name] = copy.deepcopy(key.default)
    return out


def _default(key):
    if key.required:
        return "required"
    if key.default is None:
        return "see meaning"
    if isinstance(key.default, bool):
        return f"`{str(key.default).lower()}`"
    if isinstance(key.default, str):
        return f'`"{key.default}"`'
    if isinstance(key.default, dict):
        return "`{ " + ", ".join(f"{k} = {v!r}" for k, v in key.default.items()) + " }`"
    return f"`{key.default!r}`".replace("'", '"')


def markdown_table(title, keys):
    """``keys`` (name -> Key) as a Markdown table under a ``### `title` `` heading."""
    lines = [f"### `{title}`", "", "| key | type and range | unit | default | meaning |"]
    lines.append("|---|---|---|---|---|")
    for name, key in keys.items():
        cells = (f"`{name}`", key.describe(), key.unit or "-", _default(key), key.doc)
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return lines
