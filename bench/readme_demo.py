"""The README's demo part: ``tactile demo``'s own output, as ``make demo`` prints it, and what
its numbers say (the radii's errors beside the thesis's, the labels, how far another run
moves them).

    .venv/bin/python bench/readme_demo.py           # run the demo, print the part
    .venv/bin/python bench/readme_demo.py --write   # ... and paste it into README.md

The part sits between the README's ``BEGIN`` and ``END`` lines and is written whole; the rest
of the README is left as it is.  A run differs from another by at most ``TOLERANCE`` per
column (the TARE lands at another instant of the board's time over the pty), which the part
says; ``tests/test_readme_demo.py`` runs the demo once and fails when the README's table is
further from it, or when the README's sentences are not what ``part`` makes of its table.
"""

import argparse
import pathlib
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
BEGIN = "<!-- bench/readme_demo.py writes from here to its end line: tactile demo's output -->"
END = "<!-- bench/readme_demo.py writes up to here -->"
COLUMNS = ("S", "sd S", "R 1/cm", "sd 1/cm", "r cm")
TOLERANCE = dict(zip(COLUMNS, (0.005, 0.005, 0.002, 0.002, 0.15)))  # another run, at most
TRUE_CM = {"cylinder": 6.6, "concave_cylinder": 11.25}
NUMBER = re.compile(r"-?\d+\.\d+|-(?=\s|$)")  # a cell: a number, or '-' (none)


def run_demo():
    """``tactile demo``'s stdout as ``make demo`` prints it (its folder named demo-out)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = subprocess.run(
            [sys.executable, "-m", "tactile.cli.main", "demo", "-o", "demo-out"],
            cwd=tmp, capture_output=True, text=True, check=True, timeout=1800,
        ).stdout  # fmt: skip
    return out


def rows(text):
    """(surface, fit, who) -> the five cells (float or None) of each table row."""
    found, surface, fit = {}, None, None
    for line in text.splitlines():
        m = re.match(r"^(\S*)\s+(?:(tangent|position)\s+)?(ours|thesis)\s", line)
        if not m or (m[1] and not m[2]):
            continue
        surface, fit = (m[1], m[2]) if m[1] else (surface, fit)
        cells = NUMBER.findall(line[m.end() - 1 :])
        found[surface, fit, m[3]] = [None if c == "-" else float(c) for c in cells]
    return found


def shape(text):
    """The output with every number a placeholder and runs of blanks as one: two runs'
    shapes must be equal."""
    return re.sub(r"[ \t]+", " ", NUMBER.sub("#", text))


def differences(text, other):
    """Where ``other``'s table is further from ``text``'s than ``TOLERANCE`` (or shaped
    otherwise): a list of (row, column, this, that)."""
    if shape(text) != shape(other):
        return [("the table's shape", None, shape(text), shape(other))]
    a, b = rows(text), rows(other)
    out = []
    for key in a:
        for col, x, y in zip(COLUMNS, a[key], b[key]):
            if (x is None) != (y is None) or (x is not None and abs(x - y) > TOLERANCE[col]):
                out.append((key, col, x, y))
    return out


def _off(r, true):
    return f"{(r - true) / true * 100:+.0f} %"


def labels(text):
    """surface -> the label EP2 gave it (the line under its rows)."""
    found, surface = {}, None
    for line in text.splitlines():
        m = re.match(r"^(\S+)\s+(tangent|position)\s", line)
        surface = m[1] if m else surface
        label = re.search(r"label (\w+);", line)
        if label and surface:
            found[surface] = label[1]
    return found


def says(text):
    """What the numbers of ``text`` say, in sentences."""
    table, given = rows(text), labels(text)
    right = sum(surface == label for surface, label in given.items())
    radii = []
    for surface, true in TRUE_CM.items():
        ours, thesis = ([table[surface, fit, who][4] for fit in ("tangent", "position")]
                        for who in ("ours", "thesis"))  # fmt: skip
        radii.append(
            f"off {true} cm by {_off(ours[0], true)} and {_off(ours[1], true)} (the thesis's"
            f" {_off(thesis[0], true)} and {_off(thesis[1], true)})"
        )
    tol = TOLERANCE
    return [
        f"{right} of {len(given)} labels are right; r is {radii[0]} on the convex cylinder,"
        f" {radii[1]} on the concave one (tangent, position weights).",
        f"Another run differs from this one by at most {tol['S']} in S and sd S,"
        f" {tol['R 1/cm']} 1/cm in R and sd R, {tol['r cm']} cm in r.",
    ]


def part(text):
    """The README's part for the demo output ``text``: the output, then what it says."""
    body = "```text\n" + text.rstrip("\n") + "\n```\n\n" + _wrap(" ".join(says(text)))
    return f"{BEGIN}\n{body}\n{END}"


def _wrap(text, width=96):
    words, lines, line = text.split(), [], ""
    for word in words:
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}" if line else word
    return "\n".join([*lines, line])


def of_readme(readme):
    """(the README's part, the demo output it quotes)."""
    start, end = readme.index(BEGIN), readme.index(END) + len(END)
    found = readme[start:end]
    quoted = re.search(r"```text\n(.*?)```", found, re.S)
    return found, quoted[1] if quoted else ""


def paste(readme, text):
    """``readme`` with its part written for the demo output ``text``."""
    found, _ = of_readme(readme)
    return readme.replace(found, part(text))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="paste the part into README.md")
    args = parser.parse_args(argv)
    text = run_demo()
    print(part(text))
    if args.write:
        README.write_text(paste(README.read_text(encoding="utf-8"), text), encoding="utf-8")
        print(f"wrote {README}", file=sys.stderr)


if __name__ == "__main__":
    main()
