"""Shell completion (issue 15): ``tactile completion bash|zsh`` prints a script made by
shtab from the whole argparse tree; in bash it registers and completes commands, options
and choices, never an old (hidden) spelling."""

import os
import subprocess
import sys

import pytest
from conftest import ROOT

ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(str(ROOT / d) for d in ("protocol",
       "firmware", "tools", "host", "sim", "studies"))}  # fmt: skip
TACTILE = f"{sys.executable} -m tactile"


def _bash(script):
    return subprocess.run(
        ["bash", "-c", script], capture_output=True, text=True, timeout=120, env=ENV
    )


def _complete(script, words):
    """COMPREPLY of the completion ``script`` (a file: what ``tactile completion bash``
    printed) loaded in bash for the command line ``words`` (last completed)."""
    r = _bash(
        f"source {script} || exit 9\n"
        f"COMP_WORDS=({words}); COMP_CWORD=$((${{#COMP_WORDS[@]}} - 1))\n"
        '_shtab_tactile; printf "%s\\n" "${COMPREPLY[@]}"'
    )
    assert r.returncode == 0, r.stderr
    return set(r.stdout.split())


def test_bash_script_registers_the_completion():
    r = _bash(f"source <({TACTILE} completion bash); complete -p tactile")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().endswith("-F _shtab_tactile tactile")


def test_bash_completes_commands_options_and_choices(tmp_path):
    # the script printed once, as the line above sources it, then asked once per command line
    printed = _bash(f"{TACTILE} completion bash")
    assert printed.returncode == 0, printed.stderr
    script = tmp_path / "tactile.bash"
    script.write_text(printed.stdout)
    assert _complete(script, "tactile pl") == {"plot"}
    assert {"completion", "record", "study"} <= _complete(script, "tactile ''")
    options = _complete(script, "tactile plot -")
    assert {"-o", "--out", "--order", "--verbose"} <= options
    assert "--outdir" not in options  # the old spelling works but is not offered
    assert _complete(script, "tactile sim ep1 --object c") == {"cylinder", "concave_cylinder"}
    assert _complete(script, "tactile study ep2-t") == {"ep2-tables"}


def test_zsh_script(cli):
    code, out, err = cli("completion", "zsh")
    assert code == 0 and err == ""
    assert out.startswith("#compdef tactile") and "--order" in out and "--outdir" not in out


def test_unknown_shell_is_refused(cli, capsys):
    with pytest.raises(SystemExit) as exit_:
        cli("completion", "fish")
    assert exit_.value.code == 2
