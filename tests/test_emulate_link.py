"""``tactile emulate --link PATH`` replaces only an emulator's own link (issue 12).

It used to replace a regular file with a symlink (its content lost) and to traceback on
a directory, leaving its temporary symlink behind.  A table of what can be at PATH.
"""

import os

import pytest

from tactile.errors import InputError
from tactile_sim.emulator import load_scene, pty_link
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py


def _make(kind, path, tmp_path):
    if kind == "file":
        path.write_text("precious\n")
    elif kind == "empty file":
        path.write_text("")
    elif kind == "directory":
        path.mkdir()
        (path / "inside").write_text("kept\n")
    elif kind == "symlink to a file":
        (tmp_path / "target").write_text("kept\n")
        path.symlink_to(tmp_path / "target")
    elif kind == "symlink to a directory":
        path.symlink_to(tmp_path)
    elif kind == "dangling symlink":
        path.symlink_to(tmp_path / "nowhere")
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "stale emulator link":
        path.symlink_to("/dev/pts/9999")


def _snapshot(path):
    if path.is_symlink():
        return ("link", os.readlink(path))
    if path.is_dir():
        return ("dir", sorted(p.name for p in path.iterdir()))
    if path.is_file():
        return ("file", path.read_text())
    return ("other", path.exists())


REFUSED = ["file", "empty file", "directory", "symlink to a file", "symlink to a directory",
           "dangling symlink", "fifo"]  # fmt: skip


@pytest.mark.parametrize("kind", REFUSED)
def test_anything_but_an_emulator_link_is_refused_and_left_alone(cli, tmp_path, kind):
    link = tmp_path / "board"
    _make(kind, link, tmp_path)
    before = _snapshot(link)
    code, out, err = cli("emulate", "press", "--link", link, "--now", "--duration", "0.05")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"--link {link}: " in err and "only replaces its own link to a pty" in err
    assert _snapshot(link) == before
    assert sorted(p.name for p in tmp_path.iterdir() if ".tmp" in p.name) == []


@pytest.mark.parametrize("kind", ["stale emulator link", "nothing"])
def test_an_emulator_link_or_nothing_becomes_the_link_and_is_removed_at_exit(
    cli, tmp_path, mocker, kind
):
    link = tmp_path / "board"
    _make(kind, link, tmp_path)
    seen = []
    real_serve = PtyServer.serve

    def serve(server, *a, **k):  # where the link points while the board is served
        seen.append(os.readlink(link))
        return real_serve(server, *a, **k)

    mocker.patch.object(PtyServer, "serve", serve)
    code, out, err = cli("emulate", "press", "--link", link, "--now", "--duration", "0.05")
    assert code == 0, err
    assert out.strip() == str(link) and seen and seen[0].startswith("/dev/pts/")
    assert not os.path.lexists(link)  # ours: removed at exit
    assert [p.name for p in tmp_path.iterdir() if ".tmp" in p.name] == []


def test_a_missing_directory_is_one_line(cli, tmp_path):
    code, out, err = cli("emulate", "press", "--link", tmp_path / "no" / "board", "--now")
    assert code == 2 and err.count("\n") == 1 and "no directory" in err


def test_the_temporary_link_is_removed_when_the_rename_fails(tmp_path, mocker):
    link = tmp_path / "board"
    mocker.patch("os.replace", side_effect=OSError(13, "Permission denied"))
    with pytest.raises(InputError, match="cannot make the link: Permission denied"):
        pty_link.point(str(link), "/dev/pts/1")
    assert list(tmp_path.iterdir()) == []


def test_a_file_that_appears_before_the_rename_is_not_replaced(tmp_path, mocker):
    link = tmp_path / "board"
    real_symlink = os.symlink

    def symlink(target, name):  # another program writes the file meanwhile
        real_symlink(target, name)
        link.write_text("theirs\n")

    mocker.patch("os.symlink", side_effect=symlink)
    with pytest.raises(InputError, match="a file"):
        pty_link.point(str(link), "/dev/pts/1")
    assert link.read_text() == "theirs\n" and [p.name for p in tmp_path.iterdir()] == ["board"]


def test_the_server_refuses_before_serving_and_closes_its_pty(tmp_path):
    link = tmp_path / "board"
    link.write_text("precious\n")
    server = PtyServer(EmulatedBoard(load_scene("press")), link_path=str(link))
    fds = len(os.listdir("/proc/self/fd"))
    with pytest.raises(InputError):
        server.open()
    assert len(os.listdir("/proc/self/fd")) == fds and server.endpoint is None
    assert link.read_text() == "precious\n"
