"""Every command block of the README runs exactly as written.

The README opens with its ``# `` title line and then, as its first block, the two commands
(``make demo`` and ``make test``): that block is not run here (those two commands are what CI
runs), it is checked to be exactly those two lines. The other ```sh blocks run in order in
one fresh directory, as a newcomer pastes them into one terminal, with ``.venv`` pointing at
this interpreter's environment; the ```python block then runs in that directory, on the
recording the walkthrough made:

- A line marked ``# terminal 1`` (``tactile emulate``) runs in the background for the rest
  of the README and prints its pty.
- ``NAME=value`` sets a variable for the lines after it, as the shell does. The board's port
  has one definition, ``PORT=/dev/ttyACM0``: the test puts the emulator's pty in that one
  definition, and changes nothing else.
- The walkthrough's board is an emulated Raspberry Pi Pico (``--core rp2040``), flashed,
  configured and calibrated by the README's own lines; its flash file goes to a fresh
  ``$XDG_STATE_HOME`` in the test's directory, so each run starts from a new board.
- ``FT9999.cal`` is the transducer's calibration file, which its maker ships: the emulator
  writes its own (``--cal-file``); loading it must be verified by the board (id and
  checksum in INFO), and ``ep2 analyze`` must then find the scene's shape.
- ``tactile ports`` lists this machine's serial ports; where there are none it exits 1 with
  its one line, which the test accepts.

Every other line must exit 0 without a traceback, a NaN or a ``warning:``; ``record`` must
end on its own with nothing lost, and ``ep2 analyze`` and the Python example must name the
scene's shape.  The walkthrough runs twice in a row on one emulator (its second ``record``,
then a user going through it again: the emulator plays its scene again for each host), and
docs/cli.md's example of ``flash``'s line is what the emulated Pico printed.  The install
line names an extra that brings every other user extra, and the README and docs/cli.md list
them all; what the walkthrough writes is ignored by git at a clone's root; every figure's
caption names the commands that draw it (the README's is drawn again, pixel for pixel). The
EP2 sweep block of docs/cli.md runs the same way, and every link of the README and docs/
must resolve.  The demo's part of the README: tests/test_readme_demo.py.
"""

import os
import re
import shutil
import signal
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py

README = ROOT / "README.md"
DEMO_BEGIN = "<!-- bench/readme_demo.py writes from here"
DEMO_END = "<!-- bench/readme_demo.py writes up to here -->"
MAKE = ["make demo", "make test"]
SHAPE = {"ch5_convex": "cylinder", "ep2_sweep_sphere": "sphere", "explore_cylinder": "cylinder"}
ASSIGN = re.compile(r"^([A-Z_][A-Z0-9_]*)=(\S+)\s*(#.*)?$")
SOURCES = ("protocol", "firmware", "tools", "host", "sim", "studies")  # import roots


def _blocks():
    text = README.read_text(encoding="utf-8")
    return [b.strip().splitlines() for b in re.findall(r"```sh\n(.*?)```", text, re.S)]


def _python_blocks():
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)


def _commands(block):
    return [ln.strip() for ln in block if ln.strip() and not ln.strip().startswith("#")]


def test_the_readme_is_a_front_door():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 160
    blocks = _blocks()
    assert [ln.split("#")[0].strip() for ln in blocks[0]] == MAKE  # the two commands on top
    lines = text.splitlines()
    assert lines[0].startswith("# ") and lines[0][2:].strip()  # the title line, nothing above
    first = next(i for i, ln in enumerate(lines) if ln.startswith("```"))
    assert lines[first] == "```sh" and lines[first + 1].startswith("make demo")
    assert all(not ln.strip() for ln in lines[1:first])  # the block right under the title
    # no command hides in a fence the runner does not read, nor behind a placeholder
    fences = re.findall(r"^```(\w*)$", text, re.M)
    assert fences.count("sh") == len(blocks) and set(fences) <= {"sh", "python", "text", ""}
    assert fences.count("python") == len(_python_blocks()) == 1
    begin, end = text.index(DEMO_BEGIN), text.index(DEMO_END)  # the demo's output, only
    assert fences.count("text") == 1 and begin < text.index("```text") < end
    for line in (ln for b in blocks for ln in _commands(b)):
        command = line.split(" #")[0]
        assert not re.search(r"\[--|\w\|\w|\bDIR\b|\bP\b|<\w+>", command), line
    assert len([ln for b in blocks for ln in b if ASSIGN.match(ln.strip())]) == 1  # PORT=
    assert "../" not in text and "http" not in text  # the thesis is cited, not linked


def test_the_install_extra_brings_every_user_extra():
    text = README.read_text(encoding="utf-8")
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = extras["optional-dependencies"]
    (named,) = set(re.findall(r"pip install '?tactile-shape\[(\w+)\]'", text))
    users = set().union(*(extras[k] for k in extras if k not in ("test", named)))
    assert users and set(extras[named]) == users  # no more, no less
    assert set(extras[named]) <= set(extras["test"])  # and make test installs them
    # the README's list of them and docs/cli.md's name every one (foxglove was left out)
    listed = re.search(r"brings every extra: (.*?)\.\s", " ".join(text.split()))[1]
    cli = " ".join((ROOT / "docs" / "cli.md").read_text(encoding="utf-8").split())
    cli = re.search(r"Dependencies: .*?; extras (.*?)\. Nothing", cli)[1]
    for extra in set(extras) - {"test", named}:
        assert f"`{extra}`" in listed and f"`{extra}`" in cli, extra


def test_the_walkthroughs_outputs_are_ignored_at_the_root_of_a_clone():
    """What the README's commands write into a clone (the emulator's log and calibration
    file, the runs, docs/cli.md's sweep) is ignored by git there, and only there."""
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    text = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")  # and its sweep block
    sweep = [b for b in re.findall(r"```sh\n(.*?)```", text, re.S) if "ep2_sweep_sphere" in b]
    written = set()
    for line in [ln for b in _blocks() for ln in b] + "".join(sweep).splitlines():
        for path in re.findall(r"(?:-o|--pose-log|--cal-file) (\S+)", line.split(" #")[0]):
            written.add(path.split("/")[0])
    assert {"poses.csv", "FT9999.cal", "run1", "run2", "run3", "sweep.csv"} <= written

    def ignored(path):  # (a file, or a folder's file: /run1/ names a folder)
        return any(
            subprocess.run(["git", "check-ignore", "--no-index", "-q", p], cwd=ROOT).returncode == 0
            for p in (path, f"{path}/contacts.csv")
        )

    for path in sorted(written):
        assert ignored(path) and not ignored(f"docs/{path}"), path


@pytest.mark.slow
def test_every_block_runs_as_written_twice_in_a_row_on_one_emulator(tmp_path):
    """The walkthrough as written (two runs of the robot, run1 and run2), then again on the
    same emulator, in the same folder once its runs are cleared, as a user who goes through
    it a second time: the board flashed again, its calibration now 9999, configured,
    calibrated and TAREd again, and the robot's run recorded and analysed on it.  The second
    pass ends there: after that TARE the board is as the first pass left it at its own, so
    the lines after the first ``analyze`` (plot, export, live, run2) would meet what they met
    then."""
    blocks = _blocks()
    first, again = _run_blocks(blocks[1:], tmp_path, passes=2, again_until=" analyze ")
    # every line of every block but the two make commands (terminal 1 and PORT= set up)
    lines = [ln for b in blocks[1:] for ln in _commands(b) if not _sets_up(ln)]
    assert first == lines and len(first) >= 12
    assert again == lines[: next(i for i, ln in enumerate(lines) if " analyze " in ln) + 1]
    assert any(" flash " in ln for ln in again) and any(" record " in ln for ln in again)
    # the Python example, on the recording the walkthrough made (run1)
    (python,) = _python_blocks()
    roots = [str(ROOT / d) for d in SOURCES]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(roots))
    r = subprocess.run([sys.executable, "-c", python], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=120)  # fmt: skip
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert not re.search(r"\b(nan|inf|infinity|none)\b", r.stdout, re.I), r.stdout
    out = r.stdout.splitlines()
    assert re.fullmatch(r"\d+ readings from sensors \[0\], peak \|F\| \d+\.\d\d N", out[0])
    found = re.fullmatch(r"cylinder: S (\S+), radius (\S+) cm at the patch centre", out[1])
    assert found, out  # the scene's shape, S of a cylinder, its radius (6.6 cm) within 20 %
    assert abs(float(found[1]) - 0.5) < 0.05 and abs(float(found[2]) - 6.6) < 1.32, out


@pytest.mark.slow
def test_the_cli_reference_sweep_runs_as_written(tmp_path):
    """docs/cli.md's EP2 sweep (the second block test_readme_record.py ran): its pty is the
    ``/dev/pts/N`` of its lines, and every ``record`` stops with the sweep."""
    text = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    blocks = [b.strip().splitlines() for b in re.findall(r"```sh\n(.*?)```", text, re.S)]
    sweeps = [b for b in blocks if "emulate ep2_sweep_sphere" in b[0]]
    assert len(sweeps) == 1 and any("sim://ep2_sweep_sphere" in ln for ln in sweeps[0])
    (ran,) = _run_blocks(sweeps, tmp_path)
    assert ran == [ln for ln in _commands(sweeps[0]) if not _sets_up(ln)] and ran


def _run_blocks(blocks, cwd, passes=1, again_until=None):
    """Run ``blocks`` in order in ``cwd``, as one terminal session, ``passes`` times with the
    same emulator (terminal 1 is started once; a later pass first removes the folders the
    first wrote with -o, as ``record`` refuses to overwrite a run, and ends after the first
    line holding ``again_until``); the lines run, per pass (terminal 1 and PORT= set up)."""
    os.symlink(Path(sys.executable).absolute().parents[1], cwd / ".venv")
    roots = [str(ROOT / d) for d in SOURCES]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(roots))  # this tree, from any cwd
    env["XDG_STATE_HOME"] = str(cwd / "state")  # a new emulated Pico's flash for this run
    emulators, pty, ran, scene, flashed, arm, arm_pty = [], None, [], None, [], None, None
    try:
        for n in range(passes):
            ran.append([])
            for line in (ln for block in blocks for ln in _commands(block)):
                if "# terminal 1" in line:
                    if n == 0:
                        scene = re.search(r" emulate (\S+)", line).group(1)
                        emulators.append(_background(line, cwd, env))
                        pty = emulators[-1].stdout.readline().strip()
                        assert pty.startswith("/dev/"), emulators[-1].stderr.read()
                    continue
                if "# terminal 2" in line:  # the commanded arm's board: its own pty
                    if n == 0:
                        arm = re.search(r" emulate (\S+)", line).group(1)
                        emulators.append(_background(line, cwd, env))
                        arm_pty = emulators[-1].stdout.readline().strip()
                        assert arm_pty.startswith("/dev/"), emulators[-1].stderr.read()
                        assert emulators[-1].stdout.readline().strip() in line  # its address
                    continue
                assign = ASSIGN.match(line)
                if assign:
                    assert assign.group(1) == "PORT" and pty, line  # the one definition changed
                    env["PORT"] = pty
                    continue
                if n and " record " in line:
                    shutil.rmtree(cwd / re.search(r" -o (\S+)", line).group(1), True)
                ran[-1].append(line)
                line = line.replace("--port /dev/pts/N", f"--port {pty}")
                if "--port /dev/pts/M" in line:
                    line = line.replace("--port /dev/pts/M", f"--port {arm_pty}")
                    out = _run(line, cwd, env, arm)
                else:
                    out = _run(line, cwd, env, scene, calibrated=n > 0)
                if " flash " in line:
                    flashed.append(out)
                if n and again_until and again_until in line:
                    break
    finally:  # the shell and the emulator it started: no emulator outlives its test
        for emulator in emulators:
            os.killpg(emulator.pid, signal.SIGTERM)
            emulator.wait(10)
    _check_flash_example(flashed)
    return ran


def _sets_up(line):
    """Terminal 1's or 2's emulator or the PORT definition: what the runner sets up."""
    return "# terminal 1" in line or "# terminal 2" in line or bool(ASSIGN.match(line))


def _background(line, cwd, env):
    pipe = subprocess.PIPE
    return subprocess.Popen(line, shell=True, cwd=cwd, env=env, text=True, stdout=pipe,
                            stderr=pipe, start_new_session=True)  # fmt: skip


def _run(line, cwd, env, scene, calibrated=False):
    r = subprocess.run(["bash", "-c", line], cwd=cwd, env=env, capture_output=True,
                       text=True, timeout=300)  # fmt: skip
    if " ports" in line and r.returncode == 1:
        assert "no serial ports found" in r.stderr, r.stderr
        return
    assert r.returncode == 0 and "Traceback" not in r.stderr, (line, r.stdout, r.stderr)
    assert not re.search(r"\b(nan|inf|infinity)\b", r.stdout, re.I), (line, r.stdout)
    assert "warning:" not in r.stderr, (line, r.stderr)
    if " flash " in line:  # copied, reset, and the firmware answered
        assert re.search(r"it answers: tactile firmware \S+ \(protocol", r.stdout), r.stdout
    if " info " in line:  # as the README says: 0 until the sensor is calibrated
        assert f"calibration ids [{9999 if calibrated else 0}]" in r.stdout, r.stdout
    if " config " in line:
        assert re.search(r"^rate +250 Hz", r.stdout, re.M), r.stdout
    if " calibrate " in line:  # the board stored the file's matrix and says so
        assert re.search(
            r"calibration 9999 loaded and verified \(INFO reports id 9999", r.stdout
        ), r.stdout
    if " record " in line:
        assert re.search(r"\(stopped by (the pose log's end|its --contacts)\)", r.stdout), r.stdout
        assert "lost 0 frames" in r.stdout, r.stdout
    if " analyze " in line:
        assert f" {SHAPE[scene]} " in r.stdout, r.stdout
    if " explore " in line:  # the label on one line, confident (exit 0 above)
        assert r.stdout.startswith(f"{SHAPE[scene]} (confidence "), r.stdout
        assert ", confident) after " in r.stdout, r.stdout
    if " plot " in line:
        out = Path(cwd, re.search(r" -o (\S+)", line).group(1))
        assert len(list(out.glob("*.png"))) == 3, r.stdout
    if " export " in line:
        assert Path(cwd, re.search(r" -o (\S+)", line).group(1)).stat().st_size > 0
    if " live " in line:
        assert "sensor 0" in r.stdout, r.stdout
    return r.stdout


def _check_flash_example(lines):
    """docs/cli.md's example of flash's success line is what an emulated Pico printed: as
    many files, the same firmware, sensors and rates."""
    if not lines:
        return
    text = " ".join((ROOT / "docs" / "cli.md").read_text(encoding="utf-8").split())
    (example,) = re.findall(r"flashed \d+ files as .*? \(ceiling \d+ Hz\)", text)
    said = re.search(r"flashed \d+ files as .*? \(ceiling \d+ Hz\)", lines[0])[0]  # a new board
    mask = lambda t: re.sub(r"/dev/\S+|\(\d+ stale removed\) ", "", t)  # noqa: E731
    assert mask(example) == mask(said), (example, said)


def _figures():
    """(page, png path, the file its caption names, the commands it names) per figure of the
    README and docs/: the caption is the italic paragraph right under the image."""
    for page in [README, *sorted((ROOT / "docs").glob("*.md"))]:
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r"^!\[[^\]]*\]\(([^)\s]+\.png)\)$", text, re.M):
            caption = " ".join(text[m.end() :].strip("\n").split("\n\n")[0].split())
            assert caption.startswith("*") and caption.endswith("*"), (page.name, m[1])
            named = re.search(r"`([\w.-]+\.png)` of ", caption)
            commands = re.findall(r"`(tactile [^`]+)`", caption)
            assert named and commands, (page.name, m[1], caption)  # the file, the commands
            yield page, page.parent / m[1], named[1], commands


def test_every_figure_caption_names_the_command_that_draws_it(cli, tmp_path, monkeypatch):
    """Each figure's caption names the commands that draw it and the file they write; the
    README's figure (docs/plot.md's too) is drawn again here by them, pixel for pixel."""
    from matplotlib.image import imread

    figures = list(_figures())
    assert {page.name for page, *_ in figures} >= {"README.md", "plot.md", "ep1.md"}
    monkeypatch.chdir(tmp_path)
    drawn = {}
    for page, png, named, commands in figures:
        if page.name not in ("README.md", "plot.md"):  # (a study's figures take minutes:
            assert png.name == named, (page.name, png)  # the file named, not drawn here)
            continue
        if tuple(commands) not in drawn:
            for command in commands:
                code, out, err = cli(*command.split()[1:])
                assert code == 0, (command, err)
            drawn[tuple(commands)] = imread(tmp_path / named)
        assert np.array_equal(drawn[tuple(commands)], imread(png)), (page.name, png)


def _slug(heading):
    """GitHub's anchor for a Markdown heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_every_link_of_the_readme_and_docs_resolves():
    """Moving the reference into docs/ must leave no link pointing at nothing."""
    pages = [README, *sorted((ROOT / "docs").glob("*.md"))]
    strip = lambda p: re.sub(r"```.*?```", "", p.read_text(encoding="utf-8"), flags=re.S)  # noqa: E731
    broken = []
    for page in pages:
        for target in re.findall(r"\]\(([^)\s]+)\)", strip(page)):
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            if target.startswith(("http:", "https:")) or not dest.exists():
                broken.append((page.name, target))
            elif anchor and dest.suffix == ".md":
                headings = re.findall(r"^#+\s+(.*)$", strip(dest), re.M)
                if anchor not in {_slug(h) for h in headings}:
                    broken.append((page.name, target))
    assert not broken
