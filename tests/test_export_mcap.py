"""``tactile export RUN --format mcap`` (issue 14, part 5): read back with ``mcap``'s reader
and ``mcap_ros2``'s decoder, every message against the recording.  The ``export`` extra is
part of the ``test`` extra, so these run wherever the tests do (``make test``, CI)."""

import json
import subprocess
import sys

import numpy as np
import pytest
from recorded import HOST_HEADER, LEGACY_HEADER, frame_line, variant

import tactile
from tactile.foxglove.scene import normal_quaternions


def _rows(recorded_msgs, host=None):
    head = LEGACY_HEADER if host is None else HOST_HEADER
    lines = [frame_line(m, None if host is None else host(m)) for m in recorded_msgs]
    return "\n".join([head, *lines]) + "\n"


def read_mcap(path):
    """(metadata by name, {topic: [(schema, log time ns, sequence, decoded message)]})."""
    from mcap.decoder import DecoderFactory as JsonFactory
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    class Json(JsonFactory):  # and protobuf as its bytes (test_foxglove_scene reads them)
        def decoder_for(self, message_encoding, schema):
            return {"json": json.loads, "protobuf": bytes}.get(message_encoding)

    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory(), Json()])
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        topics = {}
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            entry = (schema.name, message.log_time, message.sequence, decoded)
            topics.setdefault(channel.topic, []).append(entry)
    return meta, topics


def _vector(v):
    return [v.x, v.y, v.z]


def _stamp_ns(header):
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def test_a_wrenchstamped_per_frame_on_a_topic_per_sensor_in_board_time(
    recorded_run, recorded_msgs, tmp_path, cli
):
    board = variant(
        recorded_run, tmp_path / "board", _rows(recorded_msgs), meta_change=lambda d: None
    )
    code, out, err = cli("export", board, "-o", tmp_path / "b.mcap")
    assert code == 0 and err == "" and out.count("\n") == 1
    assert out.startswith(
        f"wrote {tmp_path / 'b.mcap'}: {len(recorded_msgs)} WrenchStamped (N, N*m)"
    )
    assert "on 3 topics" in out and "stamps: board clock" in out
    assert "did not map the board's clock" in out
    meta, topics = read_mcap(tmp_path / "b.mcap")
    assert meta["tactile"]["stamps"].startswith("board clock")
    assert meta["tactile"]["units"].startswith("force N, torque N*m, position m")
    for s in range(3):
        mine = [m for m in recorded_msgs if m.sensor == s]
        got = topics[f"/tactile/sensor{s}/wrench"]
        assert len(got) == len(mine) > 400
        for m, (schema, log_ns, _, w) in zip(mine, got):
            assert schema == "geometry_msgs/msg/WrenchStamped"
            assert w.header.frame_id == f"tactile_sensor{s}"
            assert _stamp_ns(w.header) == log_ns == m.timestamp_us * 1000  # no wrap here
            assert _vector(w.wrench.force) == [m.fx / 1e6, m.fy / 1e6, m.fz / 1e6]  # N
            assert _vector(w.wrench.torque) == [m.tx / 1e6, m.ty / 1e6, m.tz / 1e6]  # N*m
    assert json.loads(meta["tactile"]["topics"])["/tactile/sensor1/wrench"] == len(got)


def _rotate_x(q):
    """R(q) applied to the x axis, q = (x, y, z, w)."""
    x, y, z, w = q
    return np.array([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)])


def test_contacts_are_one_scene_of_arrows_in_metres_along_the_normals(recorded_run, tmp_path, cli):
    from test_foxglove_scene import arrows, patch

    code, out, err = cli("export", recorded_run, "-o", tmp_path / "c.mcap")
    assert code == 0, err
    meta, topics = read_mcap(tmp_path / "c.mcap")
    contacts = tactile.load_recording(recorded_run).contacts
    [(schema, log_ns, _, update)] = topics["/tactile/contacts"]
    assert schema == "foxglove.SceneUpdate"
    first = min(e[1] for t, es in topics.items() if not t.startswith("/tactile/") or
                t.endswith("/wrench") for e in es)  # fmt: skip
    assert log_ns == first  # shown from the recording's start
    [rows] = arrows(update).values()
    assert len(rows) == len(contacts.points_m) > 1000
    np.testing.assert_array_equal([p for p, _ in rows], contacts.points_m)  # m, exact
    np.testing.assert_allclose([n for _, n in rows], contacts.normals, atol=1e-12)
    assert meta["tactile"]["contacts"].startswith(f"{len(rows)} contacts from contacts.csv")

    [(schema, log_ns, _, update)] = topics["/tactile/patch"]
    assert schema == "foxglove.SceneUpdate" and log_ns == first
    code, analysed, err = cli("ep2", "analyze", recorded_run / "contacts.csv", "--json")
    expected = json.loads(analysed.splitlines()[0])
    shape, text, mesh = patch(update)
    assert shape["shape"] == expected["shape"] and mesh == (expected["shape"] != "uncertain")
    assert f"EP2: {expected['shape']}" in text and f"their EP2 patch ({expected['shape']})" in out


def test_contacts_written_in_cm_are_exported_in_metres(recorded_run, tmp_path, cli):
    from test_foxglove_scene import arrows

    metres = tactile.load_recording(recorded_run).contacts.points_m
    cm = variant(recorded_run, tmp_path / "cm")
    lines = (recorded_run / "contacts.csv").read_text().splitlines()[1:]  # below "# units: m"
    scaled = [",".join(str(float(v) * 100) if i < 3 else v for i, v in enumerate(ln.split(",")))
              for ln in lines[1:]]  # fmt: skip
    (cm / "contacts.csv").write_text("\n".join(["# units: cm", lines[0], *scaled]) + "\n")
    assert cli("export", cm, "-o", tmp_path / "cm.mcap")[0] == 0
    meta, topics = read_mcap(tmp_path / "cm.mcap")
    [rows] = arrows(topics["/tactile/contacts"][0][3]).values()
    np.testing.assert_allclose([p for p, _ in rows], metres, rtol=1e-14, atol=1e-18)
    assert "written in cm, here in m" in meta["tactile"]["contacts"]


def test_with_host_time_the_stamps_are_host_utc(recorded_run, recorded_msgs, tmp_path, cli):
    def host(m):  # a host clock 50 ppm fast of the board's, in Unix time
        mono = 500.0 + m.timestamp_us * 1e-6 * (1 + 50e-6)
        return mono, mono + 1_763_900_000.0

    timed = variant(
        recorded_run, tmp_path / "host", _rows(recorded_msgs, host), meta_change=lambda d: None
    )
    code, out, _ = cli("export", timed, "-o", tmp_path / "h.mcap")
    assert code == 0 and "stamps: host UTC, Unix time (from frames.csv)" in out
    meta, topics = read_mcap(tmp_path / "h.mcap")
    assert meta["tactile"]["stamps"] == "host UTC, Unix time (from frames.csv)"
    for s in range(3):
        mine = [m for m in recorded_msgs if m.sensor == s]
        for m, (_, log_ns, _, w) in zip(mine, topics[f"/tactile/sensor{s}/wrench"]):
            written_us = round(float(f"{host(m)[1]:.6f}") * 1e6)  # frames.csv: to the us
            assert _stamp_ns(w.header) == log_ns == written_us * 1000


def test_default_output_and_bad_input(recorded_run, tmp_path, cli):
    code, out, _ = cli("export", recorded_run)
    assert code == 0 and (recorded_run / f"{recorded_run.name}.mcap").is_file()
    assert out.startswith(f"wrote {recorded_run / recorded_run.name}.mcap: ")
    (recorded_run / f"{recorded_run.name}.mcap").unlink()
    code, out, err = cli("export", tmp_path / "nothing")
    assert code == 2 and out == "" and err.count("\n") == 1 and "not a directory" in err
    code, out, err = cli("export", recorded_run, "-o", tmp_path / "no" / "such" / "dir.mcap")
    assert code == 2 and err.count("\n") == 1 and "cannot write: no directory" in err
    assert "Traceback" not in err and not (tmp_path / "no").exists()


def test_help_shows_the_defaults(capsys):
    from tactile.cli.main import main

    with pytest.raises(SystemExit):
        main(["export", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(default mcap)" in text and "(default: RUN/NAME.mcap or RUN/NAME.parquet, NAME" in text


def test_without_the_extra_the_command_says_how_to_install_it(
    recorded_run, tmp_path, cli, monkeypatch
):
    monkeypatch.setitem(sys.modules, "foxglove", None)  # import -> ImportError: the writer
    code, out, err = cli("export", recorded_run, "-o", tmp_path / "x.mcap")
    assert code == 2 and out == ""
    assert err == "tactile export: error: MCAP export needs the 'export' extra:" \
        " pip install 'tactile-shape[export]'\n"  # fmt: skip
    assert not (tmp_path / "x.mcap").exists()
    monkeypatch.undo()
    monkeypatch.setitem(sys.modules, "foxglove.messages", None)  # the scene's schemas
    assert cli("export", recorded_run, "-o", tmp_path / "x.mcap")[1:] == ("", err)


def test_other_commands_and_the_loader_do_not_import_mcap(recorded_run):
    code = (
        "import sys, tactile\n"
        "from tactile.cli.main import main\n"
        f"main(['decode', {str(recorded_run / 'capture.bin')!r}])\n"
        f"tactile.load_recording({str(recorded_run)!r})\n"
        "print('mcap' in sys.modules, 'mcap_ros2' in sys.modules, 'foxglove' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.splitlines()[-1] == "False False False"


def test_normal_quaternions_turn_x_onto_any_normal():
    rng = np.random.default_rng(5)
    n = rng.normal(size=(200, 3))
    n = np.vstack([n / np.linalg.norm(n, axis=1)[:, None], [[1, 0, 0], [-1, 0, 0], [0, 0, -1]]])
    q = normal_quaternions(n)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, rtol=1e-14)
    np.testing.assert_allclose([_rotate_x(v) for v in q], n, atol=1e-14)


def test_each_frame_has_its_contact_state_beside_its_wrench(recorded_run, tmp_path, cli):
    """``/tactile/sensorN/contact``: the live server's JSON schema
    (``tactile.foxglove.topics``), one message per frame at the wrench's stamp, with the
    frame's sequence number and the gate's thresholds in N."""
    assert cli("export", recorded_run, "-o", tmp_path / "s.mcap")[0] == 0
    _, topics = read_mcap(tmp_path / "s.mcap")
    rec = tactile.load_recording(recorded_run)
    device = rec.meta["device"]
    for s in rec.sensors:
        rows = np.flatnonzero(rec.sensor == s)
        states = topics[f"/tactile/sensor{s}/contact"]
        wrenches = topics[f"/tactile/sensor{s}/wrench"]
        assert len(states) == len(wrenches) == len(rows)
        for i, (schema, log_ns, _, c), w in zip(rows, states, wrenches):
            assert schema == "tactile/ContactState" and log_ns == w[1]
            assert c["seq"] == rec.seq[i] and c["sensor"] == s
            assert c["timestamp"]["sec"] * 10**9 + c["timestamp"]["nsec"] == log_ns
            assert c["frame"] == ("contact" if rec.is_contact[i] else "sample")
            if rec.is_contact[i]:
                assert c["in_contact"] == (c["phase"] != "end") and c["contact_id"] >= 0
            assert c["enter_threshold_N"] == device["enter_threshold_N"] > 0
            assert c["exit_threshold_N"] == device["exit_threshold_N"]
            assert c["gate"] == device["gate"] and c["debounce_readings"] == device["debounce"]
        assert any(c[3]["in_contact"] for c in states)


@pytest.mark.parametrize("sensor", [0, 7, 10, 123, 99_999])  # frame ids of 15 to 19 bytes
@pytest.mark.parametrize("ns", [0, 1_763_900_000_123_456_789, 2**31 * 10**9 - 1])
def test_the_wrench_is_the_cdr_ros2_decodes(sensor, ns):
    """``wrench_cdr`` against ``mcap_ros2``'s public decoder: the padding before the float64s
    follows the frame id's length, every value comes back to the last bit."""
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    from tactile.foxglove.topics import WRENCH_STAMPED, WRENCH_STAMPED_DEF, wrench_cdr

    schema = Schema(id=1, data=WRENCH_STAMPED_DEF.encode(), encoding="ros2msg", name=WRENCH_STAMPED)
    decode = DecoderFactory().decoder_for("cdr", schema)
    w = [1.5, -2.25, 1e-300, -0.0, 3.0e7, np.nextafter(1.0, 2.0)]  # N, N*m
    msg = decode(wrench_cdr(sensor, ns, w))
    assert msg.header.frame_id == f"tactile_sensor{sensor}" and _stamp_ns(msg.header) == ns
    got = [*_vector(msg.wrench.force), *_vector(msg.wrench.torque)]
    assert np.array_equal(np.array(got).view(np.int64), np.array(w).view(np.int64))


def _private_modules(source):
    """Each private module of another package that ``source`` imports or asks ``need`` for,
    and each ``._writer`` it reaches into."""
    import ast

    names = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names += [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Call) and getattr(node.func, "id", None) == "need":
            names += [a.value for a in node.args if isinstance(a, ast.Constant)]
        elif isinstance(node, ast.Attribute) and node.attr == "_writer":
            names.append(ast.unparse(node))
    ours = ("tactile", "tactile_protocol", "tactile_fw", "tactile_sim", "tactile_studies")
    return [
        n for n in names
        if isinstance(n, str) and n.split(".")[0] not in ours
        and any(part.startswith("_") and not part.startswith("__") for part in n.split(".")[1:])
    ]  # fmt: skip


def test_the_writers_use_public_apis_only():
    """No ``mcap_ros2._dynamic``, no ``writer._writer``: the MCAP file and the live server are
    written through foxglove-sdk's public API, the wrench encoded by ``wrench_cdr``."""
    from conftest import ROOT
    from import_graph import product_files

    bad = {
        str(p.relative_to(ROOT)): _private_modules(p.read_text(encoding="utf-8"))
        for p in product_files()
    }
    assert not {p: names for p, names in bad.items() if names}
    before = (  # what the export and the live server did
        "from mcap_ros2._dynamic import serialize_dynamic\n"
        "fox, dyn = need('foxglove', '--foxglove', 'foxglove', 'mcap_ros2._dynamic')\n"
        "raw = writer._writer\n"
    )
    assert len(_private_modules(before)) == 4  # module, name, need's string, attribute
