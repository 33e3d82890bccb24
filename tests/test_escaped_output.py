"""Every path and string from outside is escaped in every line the CLI prints.

A folder named with a terminal escape and a newline goes through the commands that name
files in their success lines (``record``'s summary, ``export``'s "wrote ...", ``plot``'s
PNGs, ``sim``'s "wrote ...", the studies' files) and their errors: no raw control
character reaches stdout or stderr, and the name is shown escaped.  Then the sources:
every ``print`` and stream ``write`` of ``tactile.cli`` passes its text through
``tactile.output.text`` (a literal needs nothing), so a new line cannot forget it.
"""

import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
EVIL = "ev\x1b[31mil\nx\u202e"  # ESC, a newline, a right-to-left override
SHOWN = r"ev\x1b[31mil\nx\u202e"


def assert_escaped(*texts):
    for text in texts:
        bad = sorted({ch for ch in text if not (ch.isprintable() or ch == "\n")})
        assert not bad, f"raw control characters {bad!r} in {text!r}"
        assert "Traceback" not in text


@pytest.fixture
def evil(tmp_path):
    folder = tmp_path / EVIL
    folder.mkdir()
    return folder


def run_clean(cli, *args, code=0):
    got, out, err = cli(*args)
    assert got == code, err
    assert_escaped(out, err)
    return out, err


def test_record_and_export_name_the_folder_escaped(cli, evil):
    run = evil / "run"
    out, _ = run_clean(cli, "record", "--port", "sim://press", "-o", run, "-q", "--duration", "0.3")
    assert f"-> {evil.parent}/{SHOWN}/run" in out
    out, _ = run_clean(cli, "export", run, "-o", evil / "r.mcap")
    assert out.startswith(f"wrote {evil.parent}/{SHOWN}/r.mcap: ")
    out, _ = run_clean(cli, "export", run, "--format", "parquet", "-o", evil / "r.parquet")
    assert out.startswith(f"wrote {evil.parent}/{SHOWN}/r.parquet: ")
    run_clean(cli, "decode", run / "capture.bin")
    _, err = run_clean(cli, "export", evil / "none", code=2)  # an error names it too
    assert SHOWN in err


def test_sim_analyze_and_plot_name_the_files_escaped(cli, evil):
    csv = evil / "c.csv"
    out, _ = run_clean(cli, "sim", "ep2", "--object", "cylinder", "-o", csv)
    assert out.startswith(f"wrote {evil.parent}/{SHOWN}/c.csv: ")
    run_clean(cli, "ep2", "analyze", csv)
    out, _ = run_clean(cli, "plot", csv, "--what", "contacts", "-o", evil / "png")
    assert f"{SHOWN}/png/" in out
    probes = evil / "p.csv"
    run_clean(cli, "sim", "ep1", "--object", "sphere", "--finger-radius", "1", "--dtheta",
              "0.2", "-o", probes)  # fmt: skip
    run_clean(cli, "ep1", "estimate", probes, "--finger-radius", "1")


def test_a_study_names_its_files_escaped(cli, evil):
    out, _ = run_clean(cli, "study", "ep1-arclength", "--no-plot", "-o", evil / "s", "-q")
    assert f"{SHOWN}/s/ep1-arclength.csv" in out


def test_an_unknown_option_is_escaped(capsys):
    from tactile.cli.main import main

    with pytest.raises(SystemExit) as exit_:
        main(["export", "run", "--\x1b[31m"])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.count("\n") == 1
    assert_escaped(err)
    assert r"--\x1b[31m" in err


# -- the sources: every print goes through the one helper -------------------------------

ESCAPERS = {"printable", "printable_lines", "dumps", "fields", "value"}
PRAGMA = "# escaped:"  # a line whose text was escaped where it was built, and says so


def _name(node):
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return None


def _is_output(call):
    """``print(...)`` or ``sys.stdout.write(...)`` / ``sys.stderr.write(...)``."""
    f = call.func
    if isinstance(f, ast.Name):
        return f.id == "print"
    return (
        isinstance(f, ast.Attribute)
        and f.attr == "write"
        and isinstance(f.value, ast.Attribute)
        and f.value.attr in ("stdout", "stderr")
    )


def _safe(node):
    if isinstance(node, ast.Constant):
        return True
    return isinstance(node, ast.Call) and _name(node.func) in ESCAPERS


def unescaped_prints(path):
    """(line, source) of each print in ``path`` whose text is not a literal or escaped."""
    text = path.read_text()
    lines = text.splitlines()
    found = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Call) and _is_output(node):
            span = lines[node.lineno - 1 : node.end_lineno]
            if any(PRAGMA in line for line in span):
                continue
            if not all(_safe(a) for a in node.args):
                found.append((node.lineno, lines[node.lineno - 1].strip()))
    return found


def cli_sources():
    yield from sorted((ROOT / "host" / "tactile" / "cli").glob("*.py"))
    yield from sorted((ROOT / "sim" / "tactile_sim").rglob("*.py"))
    yield from sorted((ROOT / "studies" / "tactile_studies").rglob("*.py"))


def test_every_print_of_the_cli_passes_through_the_escaper():
    found = {
        f"{p.relative_to(ROOT)}:{n}": src for p in cli_sources() for n, src in unescaped_prints(p)
    }
    assert not found, "\n".join(f"{k}: {v}" for k, v in found.items())


def test_the_source_check_finds_a_raw_print(tmp_path):
    p = tmp_path / "x.py"
    p.write_text(
        "print(f'wrote {path}')\nprint(printable(f'wrote {path}'))\nprint('done')\n"
        "sys.stderr.write(line)\nsys.stdout.write(x)  # escaped: built from escaped parts\n"
    )
    assert [n for n, _ in unescaped_prints(p)] == [1, 4]
