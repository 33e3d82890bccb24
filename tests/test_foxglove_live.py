"""``--foxglove`` (issue 32): a WebSocket client on 127.0.0.1 offering the
``foxglove.websocket.v1`` subprotocol and its successor ``foxglove.sdk.v1`` (the same
protocol renamed; foxglove-sdk 0.30 accepts only the new name, which a test pins) sees
the channels advertised, subscribes and decodes
messages that equal what the recording holds for the same frames; the MCAP export of that
run carries the same topics and schemas; a client that never reads costs the recording
nothing.  ``foxglove-sdk`` and ``websockets`` are in the ``test`` extra."""

import json
import re
import socket
import struct
import sys
import threading
import time

import numpy as np
import pytest

import tactile
from tactile.board.stream_decoder import Contact, Sample
from tactile_protocol import constants as C

pytest.importorskip("foxglove")
websockets_sync = pytest.importorskip("websockets.sync.client")
SUBPROTOCOLS = ["foxglove.websocket.v1", "foxglove.sdk.v1"]


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Client:
    """A Foxglove WebSocket client: advertised channels by topic, subscriptions, and the
    binary message-data frames (opcode 1: u32 subscription, u64 log time ns, payload)."""

    def __init__(self, port, timeout_s=20.0, subprotocols=SUBPROTOCOLS, **options):
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                self.ws = websockets_sync.connect(
                    f"ws://127.0.0.1:{port}", subprotocols=subprotocols, **options
                ).__enter__()  # closed by the server's stop or ws.close()
                break
            except OSError:  # the command has not bound its port yet
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)
        assert self.ws.subprotocol in SUBPROTOCOLS
        self.channels, self.subs, self.received = {}, {}, []

    def wait_for(self, topics, timeout_s=20.0):
        deadline = time.monotonic() + timeout_s
        while not set(topics) <= set(self.channels):
            self._take(self.ws.recv(timeout=max(0.01, deadline - time.monotonic())))
        return {t: self.channels[t] for t in topics}

    def subscribe(self, topics):
        subs = [{"id": i, "channelId": self.channels[t]["id"]} for i, t in enumerate(topics)]
        self.subs.update({i: t for i, t in enumerate(topics)})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def _take(self, frame):
        if isinstance(frame, str):
            msg = json.loads(frame)
            if msg["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in msg["channels"]})
        elif frame[0] == 1:
            sub, log_ns = struct.unpack_from("<IQ", frame, 1)
            self.received.append((self.subs[sub], log_ns, bytes(frame[13:])))

    def drain(self):
        """Everything until the server closes (the command ended)."""
        try:
            while True:
                self._take(self.ws.recv(timeout=30))
        except Exception:  # ConnectionClosed: the command stopped its server
            pass


def _record(cli, out, port, *extra):
    return cli(
        "record", "--port", "sim://press?realtime=1", "-o", out, "--quiet", "--duration", "1.5",
        "--foxglove", "--foxglove-port", port, *extra,
    )  # fmt: skip


def _in_thread(fn, *args):
    result = {}
    thread = threading.Thread(target=lambda: result.setdefault("r", fn(*args)))
    thread.start()
    return thread, result


def test_a_client_sees_the_wrench_and_contact_state_the_recording_holds(cli, tmp_path):
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    port = free_port()
    thread, result = _in_thread(_record, cli, tmp_path / "run", port, "--foxglove-rate", "0")
    client = Client(port)
    topics = ["/tactile/sensor0/wrench", "/tactile/sensor0/contact"]
    wrench, contact = client.wait_for(topics).values()
    assert (wrench["encoding"], wrench["schemaName"], wrench["schemaEncoding"]) == (
        "cdr", "geometry_msgs/msg/WrenchStamped", "ros2msg",
    )  # fmt: skip
    assert (contact["encoding"], contact["schemaEncoding"]) == ("json", "jsonschema")
    client.subscribe(topics)
    client.drain()
    thread.join(30)
    code, out, err = result["r"]
    assert code == 0, err
    assert f"foxglove: serving ws://127.0.0.1:{port} (every frame)" in err
    assert "Traceback" not in err and " 0 dropped" in err

    advertised = Schema(
        id=0, data=wrench["schema"].encode(), encoding=wrench["schemaEncoding"],
        name=wrench["schemaName"],
    )  # fmt: skip
    decode = DecoderFactory().decoder_for(wrench["encoding"], advertised)  # ROS 2's, public
    # a frame's two messages go out in turn, and a client's queue keeps their order
    states = [(ns, json.loads(p)) for t, ns, p in client.received if t.endswith("/contact")]
    wrenches = [(ns, decode(p)) for t, ns, p in client.received if t.endswith("/wrench")]
    # (the two subscriptions take effect a few messages apart: a frame at either end of the
    # run may be half seen; frames are 1 ms apart, so their stamps tell them apart there)
    while states and wrenches and states[0][0] < wrenches[0][0]:
        states.pop(0)
    while states and wrenches and wrenches[0][0] < states[0][0]:
        wrenches.pop(0)
    n = min(len(states), len(wrenches))
    assert abs(len(states) - len(wrenches)) <= 1 and n > 200  # at the board's rate
    states, wrenches = states[:n], wrenches[:n]
    rec = tactile.load_recording(tmp_path / "run")
    row_of = {int(s): i for i, s in enumerate(rec.seq)}  # 1.5 s at 1 kHz: no seq wraps
    in_contact = 0
    for (ns, w), (state_ns, state) in zip(wrenches, states):
        i = row_of[state["seq"]]
        assert state_ns == ns == state["timestamp"]["sec"] * 10**9 + state["timestamp"]["nsec"]
        assert w.header.frame_id == "tactile_sensor0" and state["sensor"] == rec.sensor[i] == 0
        f, t = w.wrench.force, w.wrench.torque
        assert [f.x, f.y, f.z, t.x, t.y, t.z] == rec.wrench[i].tolist()  # N, N*m: exact
        assert w.header.stamp.sec * 10**9 + w.header.stamp.nanosec == ns
        if rec.host_utc_s is not None:  # (a loaded machine can leave no usable time base)
            assert abs(ns * 1e-9 - rec.host_utc_s[i]) < 0.25  # the fit then vs the final fit
        assert state["frame"] == ("contact" if rec.is_contact[i] else "sample")
        assert state["enter_threshold_N"] == rec.meta["device"]["enter_threshold_N"]
        in_contact += state["in_contact"]
    assert in_contact > 0  # press reaches 4 N within the 1.5 s

    code, out, _ = cli("export", tmp_path / "run", "-o", tmp_path / "run.mcap")
    assert code == 0 and "with their contact state" in out
    from mcap.reader import make_reader

    with open(tmp_path / "run.mcap", "rb") as fh:
        summary = make_reader(fh).get_summary()
    exported = {
        c.topic: (c.message_encoding, summary.schemas[c.schema_id])
        for c in summary.channels.values()
    }
    for topic, advertised in client.channels.items():
        encoding, schema = exported[topic]
        assert (encoding, schema.name, schema.encoding) == (
            advertised["encoding"], advertised["schemaName"], advertised["schemaEncoding"],
        )  # fmt: skip
        assert schema.data.decode() == advertised["schema"]


def test_a_client_that_never_reads_costs_the_recording_nothing(cli, tmp_path):
    """A fast emulator at every frame; the client's socket fills, the server drops for it."""
    base = ["record", "--port", "sim://press", "--quiet", "--contacts", "3"]
    code, _, err = cli(*base, "-o", tmp_path / "alone")
    assert code == 0, err
    port = free_port()
    args = (*base, "-o", tmp_path / "stalled", "--foxglove", "--foxglove-port", port,
            "--foxglove-rate", "0")  # fmt: skip
    thread, result = _in_thread(lambda: cli(*args))
    # reads nothing more once one frame is queued (nor the server's close frame: its own
    # close then waits close_timeout for an answer that cannot come, 10 s by default)
    client = Client(port, max_queue=1, close_timeout=0.1)
    client.subscribe(list(client.wait_for(["/tactile/sensor0/wrench"])))
    thread.join(60)
    code, _, err = result["r"]
    client.ws.close()
    assert code == 0, err
    alone = tactile.load_recording(tmp_path / "alone").meta
    stalled = tactile.load_recording(tmp_path / "stalled").meta
    assert stalled["samples"] == alone["samples"] > 5000
    assert stalled["decoder"]["lost_frames"] == alone["decoder"]["lost_frames"] == 0
    assert "foxglove: published" in err


def test_the_queue_drops_and_counts_what_the_publisher_cannot_take(monkeypatch):
    from tactile.foxglove import live as foxglove_live

    server = foxglove_live.LiveServer(port=0, rate_hz=0)
    gate = threading.Event()
    monkeypatch.setattr(server, "_log", lambda m, ns: gate.wait(10))  # a publisher stuck
    frames = [Sample(i & 0xFFFF, 1000 * i, 0, 0, 1, 2, 3, 4, 5, 6) for i in range(6000)]
    started = time.perf_counter()
    server.feed(frames, [(0.0, 1.7e9)] * len(frames))
    assert time.perf_counter() - started < 1.0  # never waits on the publisher
    gate.set()
    stats = server.close()
    queued = foxglove_live.QUEUE_FRAMES
    assert stats["frames"] == 6000 and queued <= 6000 - stats["dropped"] <= queued + 1
    assert stats["published"] == 6000 - stats["dropped"]


def test_the_rate_keeps_contact_edges_and_survives_the_clock_wrap():
    from tactile.foxglove.live import Decimator

    d = Decimator(100.0)  # 10 ms by the board's clock
    start = C.TIMESTAMP_MODULO - 25_000
    kept = [d.keep(Sample(i, (start + 1000 * i) % C.TIMESTAMP_MODULO, 0, 0, *[0] * 6))
            for i in range(100)]  # fmt: skip
    assert np.flatnonzero(kept).tolist() == list(range(0, 100, 10))
    edge = Contact(1, (start + 100_500) % C.TIMESTAMP_MODULO, 0, C.PHASE_BEGIN, 1, 0, *[0] * 6)
    assert d.keep(edge) and Decimator(0).keep(Sample(0, 0, 0, 0, *[0] * 6))


def test_without_the_extra_live_says_how_to_install_it(cli, monkeypatch):
    monkeypatch.setitem(sys.modules, "foxglove", None)  # import -> ImportError
    code, out, err = cli("live", "--port", "sim://press", "--foxglove", "--duration", "0.1")
    assert (code, out) == (2, "")
    assert err == (
        "tactile live: error: --foxglove needs the 'foxglove' extra:"
        " pip install 'tactile-shape[foxglove]'\n"
    )


def test_live_serves_on_the_asked_port_and_says_so(cli):
    port = free_port()
    thread, result = _in_thread(
        cli, "live", "--port", "sim://press?realtime=1", "--duration", "1",
        "--foxglove", "--foxglove-port", port, "--foxglove-rate", "50",
    )  # fmt: skip
    client = Client(port)
    client.subscribe(list(client.wait_for(["/tactile/sensor0/wrench"])))
    client.drain()
    thread.join(30)
    code, out, err = result["r"]
    assert code == 0 and "sensor 0  |F|" in out, err
    assert f"serving ws://127.0.0.1:{port} (50 Hz per sensor by the board's clock)" in err
    line = next(ln for ln in err.splitlines() if "foxglove: published" in ln)
    found = re.search(r"published (\d+) of (\d+) frames \((\d+) left out by the rate, 50 Hz per"
                      r" sensor by the board's clock; (\d+) status or reply frames?\); 0 dropped",
                      re.sub(r"(?<=\d),(?=\d)", "", line))  # fmt: skip
    assert found, line
    published, offered, left, other = map(int, found.groups())
    assert left > 0 and published + left + other == offered  # every frame the board sent
    counted = int(re.findall(r"frames (\d+)  lost 0", out)[-1])  # live's own count, which
    assert offered <= counted <= offered + 5  # has the handshake's frames too
    got = [ns for t, ns, _ in client.received]
    assert 5 <= len(got) <= 60  # 50 Hz by the board's clock over < 1 s subscribed


def test_bad_options_and_a_taken_port_are_one_line(cli, tmp_path):
    for option, value in (("--foxglove-port", "70000"), ("--foxglove-rate", "-1")):
        code, out, err = cli("live", "--port", "sim://press", "--foxglove", option, value)
        assert code == 2 and err.count("\n") == 1 and option in err, err
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        args = ("-o", tmp_path / "r", "--duration", "0.1", "--foxglove", "--foxglove-port", port)
        code, out, err = cli("record", "--port", "sim://press", *args)
    assert code == 2 and out == "" and "Traceback" not in err
    assert err.startswith(f"tactile record: error: --foxglove: cannot serve on 127.0.0.1:{port} (")
    assert err.count("\n") == 1 and not (tmp_path / "r").exists()  # refused before writing


def test_the_sdk_speaks_the_protocol_under_its_new_name_only():
    """foxglove-sdk 0.30 answers ``foxglove.sdk.v1`` (docs/foxglove.md: limits): a client
    that offers only ``foxglove.websocket.v1`` is refused (HTTP 400)."""
    from websockets.exceptions import InvalidStatus

    from tactile.foxglove.live import LiveServer

    server = LiveServer(port=0)
    try:
        with pytest.raises(InvalidStatus):
            Client(server.port, timeout_s=1, subprotocols=["foxglove.websocket.v1"])
        client = Client(server.port)
        assert client.ws.subprotocol == "foxglove.sdk.v1"
        client.ws.close()
    finally:
        server.close()


def test_the_sdk_drops_for_a_client_that_cannot_keep_up():
    """What the SDK does with a stalled client (it counts nothing we can read): it keeps
    ``BACKLOG`` messages for it and drops the oldest, and the publisher never waits."""
    from tactile.foxglove.live import LiveServer

    server = LiveServer(port=0, rate_hz=0)
    try:
        n = 25_000
        frames = [Sample(i & 0xFFFF, 1000 * i, 0, 0, 1, 2, 3, 4, 5, 6) for i in range(n)]
        server.feed(frames[:1], [(0.0, 1.7e9)])
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # before connect: the window
        sock.connect(("127.0.0.1", server.port))
        client = Client(server.port, sock=sock, max_queue=1)
        client.subscribe(list(client.wait_for(["/tactile/sensor0/contact"])))
        for k in range(1, n, 1000):  # paced so that our own queue takes everything
            server.feed(frames[k : k + 1000], [(0.0, 1.7e9)] * 1000)
            while server.worker.queue.qsize() > 100:
                time.sleep(0.01)
        deadline = time.monotonic() + 30
        while server.stats()["published"] < n and time.monotonic() < deadline:
            time.sleep(0.05)
        stats = server.stats()
        assert stats["published"] == n and stats["dropped"] == 0
        got = 0
        with pytest.raises(TimeoutError):
            while True:
                client.ws.recv(timeout=1)
                got += 1
        assert got < n - 1000  # the SDK dropped for this client, not for the publisher
        client.ws.close()
    finally:
        server.close()


def test_the_shipped_layout_reads_topics_we_publish():
    from conftest import ROOT

    from tactile.foxglove.topics import SCENE_TOPICS, contact_topic, wrench_topic

    ours = {wrench_topic(0), contact_topic(0), *SCENE_TOPICS}
    text = (ROOT / "docs" / "foxglove_layout.json").read_text()
    found = set()

    def walk(node):
        if isinstance(node, dict):
            for key, value in node.items():
                if key in ("value", "topicPath") and isinstance(value, str):
                    found.add(value.split(".")[0])
                if key == "topics":
                    found.update(value)
                walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    walk(json.loads(text))
    assert found == ours
    doc = (ROOT / "docs" / "foxglove.md").read_text()
    assert all(t.replace("0", "N") in doc for t in ours)


@pytest.mark.parametrize("device, sensors", [(None, [0]), ({"cal_ids": [3, 4]}, [0, 1])])
def test_a_client_that_connects_before_any_frame_is_told_every_sensors_topics(device, sensors):
    """Channels made after a client connects race the SDK's own filing of them, and a quick
    subscribe is refused (docs/foxglove.md: limits), so the server makes them first."""
    from tactile.foxglove.live import LiveServer

    server = LiveServer(port=0, rate_hz=0, device=device)
    try:
        client = Client(server.port)
        topics = [f"/tactile/sensor{i}/{kind}" for i in sensors for kind in ("wrench", "contact")]
        client.wait_for(topics, timeout_s=5)  # no frame fed: advertised at connection
        assert sorted(client.channels) == sorted(topics)
        client.ws.close()
    finally:
        server.close()


@pytest.mark.parametrize("simulated", [False, True])
def test_a_board_on_simulated_time_is_stamped_as_fed_not_by_a_clock_fit(monkeypatch, simulated):
    """Arrivals that pace board time like a clock, 1000 s ago: a real board's frames are
    stamped by the fit (then); a simulated board's (``sim://`` unpaced) as they are fed (now),
    as ``record`` claims no host time for it (docs/recording.md)."""
    from tactile.foxglove.live import LiveServer

    server = LiveServer(port=0, rate_hz=0, simulated=simulated)
    logged = []
    monkeypatch.setattr(server, "_log", lambda m, ns: logged.append(ns))
    ago = time.monotonic() - 1000.0
    frames = [Sample(i, 1000 * i, 0, 0, 1, 2, 3, 4, 5, 6) for i in range(4000)]
    for k in range(0, 4000, 1000):
        server.feed(frames[k : k + 1000], arrivals=[ago + 1e-3 * i for i in range(k, k + 1000)])
        server._fit_at = 0.0  # refit at every batch (one a second otherwise)
    server.close()
    now_ns = time.time_ns()
    assert len(logged) == 4000
    last_s = (now_ns - logged[-1]) * 1e-9  # how long before now the last frame is stamped
    assert (abs(last_s - 996.0) < 1.0) if not simulated else (0 <= last_s < 30)  # 4 s fed
