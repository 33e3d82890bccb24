"""``record --pose-log LOG --foxglove`` (issue 32): the 3D scene.  A client subscribed to
``/tactile/contacts``, ``/tactile/patch`` and ``/tactile/tf`` during the emulator's EP2
sweep gets arrows at the points contacts.csv holds, the sensor's poses of the log, and a
patch whose label is ``tactile ep2 analyze contacts.csv``'s; the MCAP export of the run
carries the same topics and schemas.  The messages are protobuf; ``pb`` below reads the
few fields checked (no protobuf package needed)."""

import base64
import json
import struct

import numpy as np
import pytest
from test_foxglove_live import Client, _in_thread, free_port
from test_record_pty import _scene_with, served_when_opened

import tactile

pytest.importorskip("foxglove")
pytestmark = pytest.mark.realtime  # a pty and a WebSocket on the wall clock

# field numbers of foxglove's .proto files
ENTITIES, E_ID, E_META, E_ARROWS, E_TRIANGLES, E_TEXTS = 2, 3, 6, 7, 12, 13
POSE, POSITION, ORIENTATION = 1, 1, 2
TEXT = 6


def pb(data):
    """{field number: [values]} of one protobuf message (varints as ints, 64-bit as
    doubles, length-delimited as bytes)."""
    out, i = {}, 0
    while i < len(data):
        key, i = _varint(data, i)
        field, wire = key >> 3, key & 7
        if wire == 0:
            value, i = _varint(data, i)
        elif wire == 1:
            (value,), i = struct.unpack_from("<d", data, i), i + 8
        elif wire == 2:
            n, i = _varint(data, i)
            value, i = bytes(data[i : i + n]), i + n
        elif wire == 5:
            (value,), i = struct.unpack_from("<f", data, i), i + 4
        else:
            raise ValueError(f"wire type {wire}")
        out.setdefault(field, []).append(value)
    return out


def _varint(data, i):
    value = shift = 0
    while True:
        b = data[i]
        i += 1
        value |= (b & 0x7F) << shift
        shift += 7
        if not b & 0x80:
            return value, i


def _xyz(vector_bytes):
    v = pb(vector_bytes)
    return [v.get(k, [0.0])[0] for k in (1, 2, 3)]


def arrows(update):
    """{entity id: [(point, x axis of the arrow)]} of a SceneUpdate's arrows."""
    found = {}
    for e in map(pb, pb(update).get(ENTITIES, [])):
        rows = []
        for a in map(pb, e.get(E_ARROWS, [])):
            pose = pb(a[POSE][0])
            x, y, z, w = [*_xyz(pose[ORIENTATION][0]), pb(pose[ORIENTATION][0]).get(4, [0.0])[0]]
            axis = [1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)]
            rows.append((_xyz(pose[POSITION][0]), axis))
        found[e[E_ID][0].decode()] = rows
    return found


def pose(transform):
    """(child frame, translation m, rotation x y z w) of a FrameTransform."""
    f = pb(transform)
    q = pb(f[5][0])
    return f[3][0].decode(), tuple(_xyz(f[4][0])), (*_xyz(f[5][0]), q.get(4, [0.0])[0])


def patch(update):
    """(metadata dict, text, has a mesh) of the patch SceneUpdate."""
    (e,) = map(pb, pb(update)[ENTITIES])
    meta = {pb(kv)[1][0].decode(): pb(kv)[2][0].decode() for kv in e.get(E_META, [])}
    text = pb(e[E_TEXTS][0])[TEXT][0].decode()
    return meta, text, bool(e.get(E_TRIANGLES))


@pytest.mark.slow
def test_the_scene_shows_the_contacts_and_the_patch_the_files_hold(cli, tmp_path):
    served = served_when_opened(_scene_with(tmp_path, "ep2_sweep_sphere", "rest_s = 0.3"), False)
    log = tmp_path / "poses.csv"
    served.board.motion.write_pose_log(log)
    out, port = tmp_path / "run", free_port()
    with served:
        args = ("record", "--port", served.path, "--no-tare", "--contacts", "3", "--pose-log",
                log, "-o", out, "--quiet", "--foxglove", "--foxglove-port", port)  # fmt: skip
        thread, result = _in_thread(lambda: cli(*args))
        client = Client(port)
        topics = ["/tactile/contacts", "/tactile/patch", "/tactile/tf"]
        advertised = client.wait_for(topics)
        client.subscribe(topics)
        client.drain()
        thread.join(60)
    code, stdout, err = result["r"]
    assert code == 0, err
    assert "Traceback" not in err and "foxglove: scene:" in err and "failed" not in err, err
    for c in advertised.values():
        assert (c["encoding"], c["schemaEncoding"]) == ("protobuf", "protobuf")
    assert advertised["/tactile/contacts"]["schemaName"] == "foxglove.SceneUpdate"
    assert advertised["/tactile/tf"]["schemaName"] == "foxglove.FrameTransform"

    latest = {}
    for topic, _, payload in client.received:
        if topic == "/tactile/contacts":
            latest.update(arrows(payload))  # an entity is replaced as its contact grows
    got = [row for rows in latest.values() for row in rows]
    c = tactile.load_recording(out).contacts  # contacts.csv, in m
    csv = np.column_stack([c.points_m, c.normals])
    assert len(got) == len(csv) > 20
    points = np.array([p for p, _ in got])
    normals = np.array([n for _, n in got])
    order = np.lexsort(points.T[::-1])
    want = csv[np.lexsort(csv[:, :3].T[::-1])]
    assert np.allclose(points[order], want[:, :3], atol=1e-6)  # m, as contacts.csv rounds
    assert np.allclose(normals[order], want[:, 3:], atol=1e-5)
    assert any(t == "/tactile/tf" for t, _, _ in client.received)

    patches = [patch(p) for t, _, p in client.received if t == "/tactile/patch"]
    assert patches, err
    meta, text, mesh = patches[-1]
    code, analysed, err = cli("ep2", "analyze", out / "contacts.csv", "--json")
    assert code == 0, err
    expected = json.loads(analysed.splitlines()[0])
    assert meta["shape"] == expected["shape"] == "sphere" and mesh
    assert abs(float(meta["S"]) - expected["S"]) < 0.05 and f"EP2: {expected['shape']}" in text

    code, line, err = cli("export", out, "-o", tmp_path / "run.mcap", "--pose-log", log)
    assert code == 0, err
    assert "EP2 patch (sphere)" in line and "sensor poses (m) on /tactile/tf" in line
    from mcap.reader import make_reader

    with open(tmp_path / "run.mcap", "rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        exported = {
            c.topic: (c.message_encoding, summary.schemas[c.schema_id])
            for c in summary.channels.values()
        }
        messages = {}
        for _, channel, message in reader.iter_messages(topics=topics):
            messages.setdefault(channel.topic, []).append(message.data)
    for topic, c in advertised.items():
        encoding, schema = exported[topic]
        assert (encoding, schema.name, schema.encoding) == (
            c["encoding"], c["schemaName"], c["schemaEncoding"],
        )  # fmt: skip
        assert schema.data == base64.b64decode(c["schema"])
    rows = [r for m in messages["/tactile/contacts"] for rs in arrows(m).values() for r in rs]
    assert len(rows) == len(csv)
    meta, _, mesh = patch(messages["/tactile/patch"][-1])
    assert meta["shape"] == expected["shape"] and mesh
    live_tf = {pose(p) for t, _, p in client.received if t == "/tactile/tf"}
    exported_tf = [pose(m) for m in messages["/tactile/tf"]]
    assert live_tf <= set(exported_tf) and len(exported_tf) > 3  # stamps: each sink's clock


def _sphere_cap(n=60, radius=0.05, seed=1):
    """Contacts on a sphere's cap (m) with outward normals, no noise."""
    rng = np.random.default_rng(seed)
    theta, phi = rng.uniform(0, 0.5, n), rng.uniform(0, 2 * np.pi, n)
    nrm = np.column_stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    return radius * nrm, nrm


def test_a_patch_is_drawn_only_where_ep2_determines_it():
    from tactile.foxglove import scene

    pts, nrm = _sphere_cap()
    record, mesh = scene.fit_patch(pts, nrm, None)
    meta, text, drawn = patch(scene.patch_update(record, mesh, pts.mean(0), len(pts), 0).encode())
    assert meta["shape"] == "sphere" and drawn and mesh.shape[1] == 3
    assert text.startswith("EP2: sphere (60 contacts): S 1.00 (95% [")
    assert text.endswith(f"radius {record['radius'] * 1e3:.1f} mm")  # the record's m, in mm
    refused, none = scene.fit_patch(pts[:2], nrm[:2], None)
    meta, text, drawn = patch(scene.patch_update(refused, none, pts[0], 2, 0).encode())
    assert none is None and not drawn and meta["S"] == "null"
    assert text.startswith("EP2: refused (2 contacts): ")
    unsure = {"shape": "uncertain", "S": 0.4, "S_interval": (-0.9, 1.0)}
    meta, text, drawn = patch(scene.patch_update(unsure, mesh, pts[0], 60, 0).encode())
    assert not drawn and "S not determined" in text and "0.40" not in text
    assert scene.s_colour(-1) == (0.0, 0.0, 1.0) and scene.s_colour(1) == (1.0, 0.0, 0.0)
    assert scene.s_colour(0) == (1.0, 1.0, 1.0)


def test_transforms_carry_the_log_pose():
    from scipy.spatial.transform import Rotation

    from tactile.foxglove import scene

    for q in Rotation.random(50, random_state=3).as_quat():  # x, y, z, w
        R = Rotation.from_quat(q).as_matrix()
        got = pose(scene.sensor_transform(2, R, (0.1, -0.2, 0.3), 5).encode())
        assert got[0] == "tactile_sensor2" and np.allclose(got[1], (0.1, -0.2, 0.3))
        assert np.allclose(got[2], q * np.sign(q[3]), atol=1e-12)


def test_the_ep2_worker_fits_the_latest_contacts_and_skips_stale_ones(monkeypatch):
    import threading

    import foxglove

    from tactile.foxglove import live_scene, scene
    from tactile.foxglove.topics import Topics

    gate, fitted = threading.Event(), []

    def slow_fit(points, normals, finger):
        fitted.append(len(points))
        gate.wait(10)
        return {"shape": None, "error": "test"}, None

    monkeypatch.setattr(scene, "fit_patch", slow_fit)
    pub = live_scene.ScenePublisher(Topics(foxglove, foxglove.Context()), log=None)
    pts, nrm = _sphere_cap()
    for n in (10, 20, 30, 40):  # the first starts, the next two are replaced by the last
        pub.request(pts[:n], nrm[:n], None, 0)
        while n == 10 and not fitted:
            threading.Event().wait(0.01)
    gate.set()
    pub.close()
    assert fitted == [10, 40] and pub.stale == 2 and pub.patches == 2
