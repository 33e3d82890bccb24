"""A robot the host can command (issue 42): ``tactile.robot``'s client against raw lines, the
emulated arm's geometry and timing in-process, every bad input to the line protocol answered
in one line while the server serves on, and a touch seen in the board's decoded stream."""

import json
import math
import os
import socket
import subprocess
import sys
import threading
import tomllib

import numpy as np
import pytest
import serial

from tactile.board.stream_decoder import StreamDecoder
from tactile.errors import BoardTimeout, InputError
from tactile.logs.read import read_pose_log
from tactile.robot import Pose, RobotClient, RobotError, parse_address
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.orientation import matrix
from tactile_sim.emulator.robot_server import EmulatedArm, RobotServer, board_waiter
from tactile_sim.emulator.scene import SCENE_DIR, Scene, load_scene
from tactile_sim.emulator.servers import server_for

H = math.sqrt(0.5)
DOWN = (H, 0.0, H, 0.0)  # the home orientation: the pole (sensor +x) along world -z
POSE = b'{"op": "pose"}\n'


def _scene(name, tmp_path=None, **motion):
    """A shipped scene with [motion] keys replaced."""
    path = SCENE_DIR / f"{name}.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    data["motion"].update(motion)
    return Scene(path, data)


def _arm(name="explore_sphere", clock=lambda: 0, **motion):
    return EmulatedArm(_scene(name, **motion), clock=clock)


# --- the client, against a robot that sends raw lines ---------------------------------------


class FakeRobot:
    """A TCP peer that answers each request line with the next raw reply (None: never)."""

    def __init__(self, replies):
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.address = f"127.0.0.1:{self.sock.getsockname()[1]}"
        self.requests = []
        self.thread = threading.Thread(target=self._serve, args=(list(replies),), daemon=True)
        self.thread.start()

    def _serve(self, replies):
        try:
            conn, _ = self.sock.accept()
        except OSError:  # closed with no client: a test whose client never sent a line
            return
        with conn, conn.makefile("rb") as lines:
            for reply in replies:
                line = lines.readline()
                if not line:
                    return
                self.requests.append(json.loads(line))
                if reply is None:
                    lines.readline()  # until the client goes
                    return
                conn.sendall(reply)

    def close(self):
        self.sock.close()
        self.thread.join(5)


@pytest.fixture
def fake():
    made = []

    def make(*replies):
        made.append(FakeRobot(replies))
        return made[-1]

    yield make
    for robot in made:
        robot.close()


def test_the_client_sends_the_documented_lines_and_reads_the_answers(fake):
    pose = b'{"ok": true, "pose": {"position_m": [0.01, 0, 0.06], "quaternion": [1, 0, 0, 0]}}\n'
    touched = (b'{"ok": true, "touched": true, "pose": {"position_m": [0, 0, 0.04], '
               b'"quaternion": [0, 0, 1, 0]}, "travel_m": 0.02, "force_N": 5.0, '
               b'"t_us": [1000, 201000]}\n')  # fmt: skip
    robot = fake(pose, pose, touched)
    with RobotClient(robot.address, timeout_s=5) as client:
        assert client.pose() == Pose((0.01, 0.0, 0.06), (1.0, 0.0, 0.0, 0.0))
        assert client.move(Pose((0.01, 0.0, 0.06), DOWN)).position_m == (0.01, 0.0, 0.06)
        touch = client.touch((0, 0, 0.06), (0, 0, -2), 5, 0.05)
    assert touch.touched and touch.force_N == 5.0 and touch.travel_m == 0.02
    assert touch.t_us == (1000, 201000) and touch.pose.quaternion == (0.0, 0.0, 1.0, 0.0)
    assert robot.requests == [
        {"op": "pose"},
        {"op": "move", "pose": {"position_m": [0.01, 0.0, 0.06], "quaternion": list(DOWN)}},
        {"op": "touch", "from": [0.0, 0.0, 0.06], "direction": [0.0, 0.0, -1.0],
         "max_force_N": 5.0, "max_travel_m": 0.05},
    ]  # fmt: skip


GOOD_POSE = '"pose": {"position_m": [0, 0, 0.06], "quaternion": [1, 0, 0, 0]}'
BAD_ANSWERS = [
    (b"not json\n", "answer is not JSON"),
    (b'{"ok": true, "pose": {"position_m": [0, 0, NaN], "quaternion": [1, 0, 0, 0]}}\n',
     "answer is not JSON"),
    (b'{"ok": true, "pose": {"position_m": [0, 0, 1e999], "quaternion": [1, 0, 0, 0]}}\n',
     "pose.position_m[2]: must be finite"),
    (b'{"ok": true, "pose": {"position_m": [0, 0, 0], "quaternion": [1, 1, 0, 0]}}\n',
     "pose.quaternion: must have unit length"),
    (b'{"ok": true, "pose": {"position_m": [0, 0], "quaternion": [1, 0, 0, 0]}}\n',
     "must be a list of 3 numbers"),
    (b'{"ok": true, "pose": {"position_m": ["0", 0, 0], "quaternion": [1, 0, 0, 0]}}\n',
     "must be a number"),
    (b'{"ok": true}\n', "pose: must be an object"),
    (("{" + GOOD_POSE + "}\n").encode(), 'not an object with "ok"'),
    (b'[true]\n', 'not an object with "ok"'),
    (b'{"ok": false, "error": "unreachable pose: out\\nthere"}\n', ": unreachable pose: out there"),
    (b"{" + b" " * 70_000 + b"}\n", "line longer than 65536 bytes"),
]  # fmt: skip


@pytest.mark.parametrize(("reply", "why"), BAD_ANSWERS)
def test_a_bad_answer_is_one_line_exit_4(fake, reply, why):
    robot = fake(reply)
    with RobotClient(robot.address, timeout_s=5) as client, pytest.raises(RobotError) as err:
        client.pose()
    text = str(err.value)
    assert err.value.exit_code == 4 and "\n" not in text
    assert text.startswith(f"robot {robot.address}: ") and why in text, text


def test_a_robot_that_hangs_up_or_never_answers_is_exit_4(fake):
    robot = fake(b"")  # reads the request, answers nothing, hangs up
    with RobotClient(robot.address, timeout_s=5) as client, pytest.raises(RobotError) as err:
        client.pose()
    assert "closed the connection" in str(err.value)
    robot = fake(None)
    client = RobotClient(robot.address, timeout_s=0.2)
    with pytest.raises(BoardTimeout) as late:
        client.pose()
    assert late.value.exit_code == 4 and "no answer within 0.2 s" in str(late.value)
    with pytest.raises(RobotError, match="the connection is closed"):  # not a late answer
        client.pose()


def test_nobody_listening_is_exit_4_with_a_hint():
    with socket.create_server(("127.0.0.1", 0)) as s:
        port = s.getsockname()[1]
    with pytest.raises(RobotError) as err:
        RobotClient(f"127.0.0.1:{port}", timeout_s=2)
    assert err.value.exit_code == 4 and "cannot connect" in str(err.value)
    assert "tactile emulate SCENE --robot" in str(err.value)


@pytest.mark.parametrize("text", ["", "127.0.0.1", "127.0.0.1:", ":5001", "h:70000", "h:-1", "h:x"])
def test_a_bad_address_is_exit_2(text):
    with pytest.raises(InputError) as err:
        parse_address(text)
    assert err.value.exit_code == 2 and str(err.value).startswith("--robot: expected HOST:PORT")


def test_bad_touch_arguments_are_exit_2_and_never_sent(fake):
    robot = fake()
    with RobotClient(robot.address, timeout_s=5) as client:
        for args, why in [(((0, 0, 0), (0, 0, 0), 5, 0.1), "direction: must not be zero"),
                          (((0, 0, 0), (0, 0, 1), math.nan, 0.1), "max_force_N: must be finite"),
                          (((0, 0, 0), (0, 0, 1), 5, -1), "max_travel_m: must be > 0"),
                          (((0, 0), (0, 0, 1), 5, 1), "from: must be a list of 3")]:  # fmt: skip
            with pytest.raises(InputError, match=why):
                client.touch(*args)
    assert robot.requests == []


# --- the emulated arm, in-process -----------------------------------------------------------


def _sphere_contact(c0, d, centre, reach):
    """The first s with |c0 + s d - centre| = reach (the fingertip's centre on the offset
    sphere), and the contact normal there."""
    rel = c0 - centre
    b, c = rel @ d, rel @ rel - reach * reach
    s = -b - math.sqrt(b * b - c)
    return s, (rel + s * d) / reach


def test_a_touch_meets_the_tilted_sphere_where_geometry_says():
    arm = _arm("explore_sphere")  # radius 5 cm, tilted 20 deg about x; r = 12 mm, 3 cm out
    m = arm.motion
    start = np.array([0.01, -0.005, 0.055])
    d = np.array([0.1, 0.2, -1.0]) / np.linalg.norm([0.1, 0.2, -1.0])
    touch = arm.touch(start, d, 5.0, 0.08)
    a = math.radians(20.0)
    centre = np.array([0.0, 0.05 * math.sin(a), -0.05 * math.cos(a)])  # Rx(20) (0, 0, -R)
    s, n = _sphere_contact(start + np.array([0, 0, -0.03]), d, centre, 0.05 + 0.012)
    depth = 5.0 / (20000.0 * -(d @ n))
    assert touch.touched and touch.force_N == pytest.approx(5.0, rel=1e-12)
    assert touch.travel_m == pytest.approx(s + depth, abs=1e-9)
    np.testing.assert_allclose(touch.pose.position_m, start + (s + depth) * d, atol=1e-9)
    np.testing.assert_allclose(touch.pose.quaternion, DOWN, atol=1e-12)
    t0, t1 = touch.t_us
    assert t1 - t0 == 200_000  # hold_s
    R = matrix(DOWN)
    F = R.T @ (5.0 * n)
    M = np.cross([0.03, 0.0, 0.0], F)  # the force's line goes through the fingertip's centre
    np.testing.assert_allclose(m.wrench_at((t0 + t1) / 2e6), np.r_[F, M], atol=1e-9)
    assert np.all(m.wrench_at(t0 * 1e-6 - 0.006) == 0.0)  # before the press: no load


def _brute_gap(obj, c, half=0.015, step=1e-4):
    """Distance from c to the object's surface, from a dense grid around below c."""
    x = np.arange(c[0] - half, c[0] + half, step)
    y = np.arange(c[1] - half, c[1] + half, step)
    X, Y = np.meshgrid(x, y)
    Z = obj.height(X, Y)
    return float(np.sqrt((X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2).min())


def test_a_touch_on_the_turned_saddle_stops_at_first_contact():
    arm = _arm("explore_saddle")  # saddle, R = 5 cm, turned 30 deg
    start = np.array([0.012, 0.008, 0.06])
    d = np.array([-0.2, 0.0, -1.0]) / np.linalg.norm([-0.2, 0.0, -1.0])
    touch = arm.touch(start, d, 3.0, 0.08)
    assert touch.touched and touch.force_N == pytest.approx(3.0)
    obj, c0 = arm.motion.obj, start + np.array([0.0, 0.0, -0.03])
    n = _load_normal(arm)
    s = touch.travel_m - 3.0 / (20000.0 * -(d @ n))  # where the fingertip met the saddle
    assert _brute_gap(obj, c0 + s * d) == pytest.approx(0.012, abs=2e-6)  # touching there
    assert _brute_gap(obj, c0 + (s - 2e-4) * d) > 0.012 + 1e-5  # and clear just before
    q = c0 + s * d - 0.012 * n  # the contact: on the surface, the force along its normal
    assert q[2] == pytest.approx(float(obj.height(q[0], q[1])), abs=1e-12)
    np.testing.assert_allclose(obj.normals(q[:1], q[1:2])[0], n, atol=1e-9)


def _load_normal(arm):
    """The world direction of the arm's current contact force."""
    m = arm.motion
    F = m.R @ m.wrench_at(m.end_s)[:3]
    return F / np.linalg.norm(F)


def test_a_miss_travels_its_limit_or_to_the_workspace_edge_with_no_force():
    arm = _arm("explore_sphere")
    home = np.array(arm.pose().position_m)
    miss = arm.touch(home, (1.0, 0.0, 0.0), 5.0, 0.01)
    assert not miss.touched and miss.force_N == 0.0 and miss.t_us is None
    assert miss.travel_m == pytest.approx(0.01)
    np.testing.assert_allclose(miss.pose.position_m, home + [0.01, 0.0, 0.0], atol=1e-12)
    edge = arm.touch(home, (0.0, 1.0, 0.0), 5.0, 1.0)  # the box ends 3 cm out
    assert not edge.touched and edge.travel_m == pytest.approx(0.03)
    assert np.all(arm.motion.wrench_at(arm.motion.end_s + 1.0) == 0.0)


def test_an_unreachable_pose_is_refused_and_the_arm_stays():
    arm = _arm("explore_sphere")
    before = arm.pose()
    for pose, why in [(Pose((0.0, 0.0, 0.5), DOWN), "outside the workspace"),
                      (Pose((0.0, 0.0, 0.03), DOWN), "inside the object")]:  # fmt: skip
        with pytest.raises(RobotError, match=f"unreachable pose: .*{why}") as err:
            arm.move(pose)
        assert err.value.exit_code == 4
    with pytest.raises(RobotError, match="unreachable start"):
        arm.touch((0.0, 0.0, 0.02), (0, 0, -1), 5.0, 0.05)
    assert arm.pose() == before and arm.motion.end_s == 0.0


def test_the_press_holds_until_the_next_command_and_a_move_lets_go():
    now = [0]
    arm = _arm("explore_cylinder", clock=lambda: now[0])
    m = arm.motion
    touch = arm.touch(arm.pose().position_m, (0, 0, -1), 4.0, 0.05)
    held = m.wrench_at(touch.t_us[1] * 1e-6)
    assert np.linalg.norm(held[:3]) == pytest.approx(4.0)
    np.testing.assert_allclose(m.wrench_at(touch.t_us[1] * 1e-6 + 10.0), held)
    now[0] = touch.t_us[1] + 10_000_000  # the board's clock 10 s on: the next command
    turned = (math.cos(0.3), 0.0, math.sin(0.3), 0.0)  # 0.6 rad about y
    target = Pose((0.0, 0.01, 0.09), turned)
    arm.move(Pose((0.0, 0.01, 0.05), DOWN))  # backs out first, so the path is clear
    np.testing.assert_allclose(m.wrench_at(now[0] * 1e-6), held)  # still pressed at its start
    assert np.all(m.wrench_at(m.end_s) == 0.0)
    with pytest.raises(RobotError, match="outside the workspace"):
        arm.move(target)  # the turned fingertip would leave the box
    ok = Pose((0.0, 0.01, 0.05), (math.cos(0.1), 0.0, math.sin(0.1), 0.0))
    got = arm.move(ok)
    np.testing.assert_allclose(got.position_m, ok.position_m, atol=1e-15)
    np.testing.assert_allclose(got.quaternion, ok.quaternion, atol=1e-12)
    np.testing.assert_allclose(m.orientation_at(m.end_s), matrix(ok.quaternion), atol=1e-12)


def test_a_command_starts_at_the_boards_clock_not_before():
    arm = _arm("explore_pit", clock=lambda: 2_000_000)
    touch = arm.touch(arm.pose().position_m, (0, 0, -1), 5.0, 0.05)
    assert touch.t_us[0] > 2_000_000
    assert (
        np.all(arm.motion.wrench_at(2.0) == 0.0) and round(arm.motion.end_s * 1e6) == touch.t_us[1]
    )


def test_a_scene_of_another_kind_has_no_arm():
    with pytest.raises(InputError, match='kind = "commanded"'):
        EmulatedArm(_scene("ep2_sweep_sphere"))


# --- the line protocol's bad inputs ---------------------------------------------------------

MOVE = '{{"op": "move", "pose": {{"position_m": {}, "quaternion": [{}, 0, {}, 0]}}}}'
TOUCH = '{{"op": "touch", "from": {}, "direction": [0, 0, -1], "max_force_N": {}, "max_travel_m": 0.05}}'  # noqa: E501
BAD_LINES = [
    (b'{"op": "fly"}', 'unknown op "fly" (ops: move, touch, pose)'),
    (b'{"pose": {}}', "unknown op null"),
    (
        MOVE.format("[0.5, 0, 0.06]", H, H).encode(),
        "unreachable pose: fingertip centre (0.5, 0, 0.03) m outside the workspace",
    ),  # noqa: E501
    (MOVE.format("[0, 0, 0.03]", H, H).encode(), "unreachable pose: the fingertip would be"),
    (TOUCH.format("[0, 0, 0.02]", 5).encode(), "unreachable start"),
    (MOVE.format("[0, 0, 0.06]", 1, 1).encode(), "move: pose.quaternion: must have unit length"),
    (b'{"op": "move", "pose": ', "malformed JSON"),
    (b"not json", "malformed JSON"),
    (b"\xff\xfe", "malformed JSON"),
    (b"", "malformed JSON: an empty line"),
    (b"[1, 2]", "malformed request: must be a JSON object"),
    (TOUCH.format("[0, 0, 0.06]", "NaN").encode(), "non-finite number NaN"),
    (TOUCH.format("[0, 0, 0.06]", "-Infinity").encode(), "non-finite number -Infinity"),
    (TOUCH.format("[0, 0, 1e999]", 5).encode(), "touch: from[2]: must be finite, got inf"),
    (TOUCH.format("[0, 0, 0.06]", 0).encode(), "touch: max_force_N: must be > 0"),
    (b'{"op": "touch"}', "touch: from: must be a list of 3 numbers"),
    (b"{" + b" " * 70_000 + b"}", "line longer than 65536 bytes"),
]


@pytest.fixture
def served():
    arm = _arm("explore_sphere")
    with RobotServer(arm) as server:
        host, port = parse_address(server.address)
        yield arm, host, port


def _talk(host, port):
    sock = socket.create_connection((host, port), timeout=10)
    return sock, sock.makefile("rb")


@pytest.mark.parametrize(("line", "why"), BAD_LINES)
def test_a_bad_line_gets_one_error_line_and_the_server_serves_on(served, line, why):
    arm, host, port = served
    sock, answers = _talk(host, port)
    with sock, answers:
        sock.sendall(line + b"\n" + POSE)
        first, second = answers.readline(), answers.readline()
    reply = json.loads(first)
    assert first.endswith(b"\n") and first.count(b"\n") == 1
    assert reply["ok"] is False and why in reply["error"], reply
    assert json.loads(second) == {"ok": True, "pose": {"position_m": [0.0, 0.0, 0.06],
                                                       "quaternion": list(DOWN)}}  # fmt: skip
    assert arm.motion.end_s == 0.0  # nothing moved


def test_a_client_that_vanishes_is_let_go_and_the_next_is_served():
    done = threading.Event()  # the arm has done a touch (it waits for the board at the end)
    arm = EmulatedArm(_scene("explore_sphere"), wait=lambda t_us: done.set())
    with RobotServer(arm) as server:
        host, port = parse_address(server.address)
        for partial in (b'{"op": "to', b'{"op": "touch", "from": [0, 0, 0.06], "direction": [0'):
            sock, _ = _talk(host, port)
            sock.sendall(partial)
            sock.close()  # gone mid-line: nothing done
        sock, answers = _talk(host, port)
        sock.sendall(TOUCH.format("[0, 0, 0.06]", 5).encode() + b"\n")
        sock.close()  # gone before its answer
        answers.close()
        assert done.wait(10)
        with RobotClient(server.address, timeout_s=10) as client:
            pose = client.pose()
    assert len(arm.motion.holds) == 1  # the whole line's touch, once; the partial ones never
    assert pose.position_m == tuple(arm.motion.p) and pose.position_m[2] < 0.06


# --- the arm beside the board: the touch in the board's stream --------------------------------


def _samples(msgs):
    s = [m for m in msgs if m.type_name == "SAMPLE" and m.sensor == 0]
    t = np.array([m.timestamp_us for m in s])
    w = np.array([[m.fx, m.fy, m.fz, m.tx, m.ty, m.tz] for m in s], float) * 1e-6
    return t, w


def test_a_touch_reaches_the_boards_stream_and_the_pose_log(tmp_path):
    scene = _scene("explore_sphere")
    board = EmulatedBoard(scene, core="python", boot_id=7, board_id=b"ROBOTARM")
    log = tmp_path / "poses.csv"
    arm = EmulatedArm(board.motion, lambda: board.t_us, board.run_until, log)
    board.host_opened()
    decoder, msgs = StreamDecoder(), []
    board.run_until(300_000)
    msgs += decoder.feed(board.read_host())
    start = np.array([0.004, 0.0, 0.055])
    touch = arm.touch(start, (0.0, 0.0, -1.0), 5.0, 0.05)
    msgs += decoder.feed(board.read_host())
    t0, t1 = touch.t_us
    assert board.t_us >= t1  # answered once the board had passed the hold
    t, w = _samples(msgs)
    rest = w[(t > 50_000) & (t < 300_000)].mean(axis=0)  # unloaded: the tool's weight only
    press = w[(t >= t0) & (t <= t1)]
    assert len(press) >= 90  # 0.2 s at 500 Hz
    sphere = np.array([0.0, 0.05 * math.sin(math.radians(20)), -0.05 * math.cos(math.radians(20))])
    centre = np.array(touch.pose.position_m) + [0.0, 0.0, -0.03]
    n = (centre - sphere) / np.linalg.norm(centre - sphere)  # the surface's normal there
    F = matrix(DOWN).T @ (5.0 * n)
    got = press.mean(axis=0) - rest
    np.testing.assert_allclose(got[:3], F, atol=0.05)  # noise 0.06-0.11 N, ~100 samples
    np.testing.assert_allclose(got[3:], np.cross([0.03, 0, 0], F), atol=0.003)
    rows = read_pose_log(log)
    assert len(rows) == 1 and rows.t_start[0] == t0 and rows.t_end[0] == t1
    np.testing.assert_allclose(rows.position[0], touch.pose.position_m, atol=1e-15)
    np.testing.assert_allclose(rows.quaternion[0], DOWN, atol=1e-12)
    assert rows.probe["radius"] == 0.012


def test_the_served_arm_moves_the_served_board(tmp_path):
    """The emulator on a pty as fast as possible, the arm on TCP: a touch over the wire
    shows in what the host reads from the port."""
    scene = _scene("explore_saddle")
    board = EmulatedBoard(scene, core="python")
    clock = lambda: board.t_us  # noqa: E731
    arm = EmulatedArm(board.motion, clock, board_waiter(clock))
    result = {}
    with RobotServer(arm) as robot, server_for(board, realtime=False) as server:
        port = serial.Serial(server.path, timeout=0.02)

        def command():
            with RobotClient(robot.address, timeout_s=30) as client:
                result["touch"] = client.touch((0.0, 0.0, 0.06), (0, 0, -1), 4.0, 0.05)

        worker = threading.Thread(target=command)
        worker.start()
        decoder, msgs = StreamDecoder(), []
        while worker.is_alive():  # (fast: the board's time runs as the host reads)
            msgs += decoder.feed(port.read(4096))
        touch = result["touch"]
        while _samples(msgs)[0].max(initial=0) < touch.t_us[1]:  # what the port still holds
            msgs += decoder.feed(port.read(4096))
        port.close()
    t, w = _samples(msgs)
    rest = w[t < touch.t_us[0] - 300_000].mean(axis=0)
    press = w[(t >= touch.t_us[0]) & (t <= touch.t_us[1])].mean(axis=0) - rest
    assert touch.touched and np.linalg.norm(press[:3]) == pytest.approx(4.0, abs=0.1)
    np.testing.assert_allclose(press[:3], [-4.0, 0.0, 0.0], atol=0.1)  # the saddle's apex


def test_emulate_serves_the_arm_only_for_a_commanded_scene(cli):
    code, out, err = cli("emulate", "press", "--robot", "127.0.0.1:0", "--duration", "0.05")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert 'only with a scene of [motion] kind = "commanded"' in err
    code, out, err = cli("emulate", "explore_sphere", "--duration", "0.05")
    assert code == 2 and "moves only when told: add --robot 127.0.0.1:PORT" in err
    code, out, err = cli("emulate", "explore_sphere", "--robot", "localhost", "--duration", "1")
    assert code == 2 and "--robot: expected HOST:PORT" in err
    code, out, err = cli(
        "emulate", "explore_sphere", "--robot", "127.0.0.1:0", "--duration", "0.05"
    )
    path, address = out.splitlines()
    assert code == 0 and path.startswith("/dev/pts/")
    host, port = parse_address(address)
    assert host == "127.0.0.1" and port > 0


@pytest.mark.parametrize(
    ("motion", "why"),
    [
        ("home_m = [0.0, 0.0, 0.0]", "[motion] home_m: unreachable home_m: the fingertip would be"),
        ("home_m = [0.0, 0.0, 0.2]", "[motion] home_m: unreachable home_m: fingertip centre"),
        ("workspace_max_m = [0.03, -0.04, 0.06]", "[motion] workspace_max_m: y must be >"),
        ('object = "plane"\nfinger_radius_m = 0.0', "[motion] finger_radius_m: must be finite, >"),
    ],
)
def test_a_commanded_scene_that_cannot_be_is_one_line_exit_2(tmp_path, motion, why):
    path = tmp_path / "arm.toml"
    path.write_text(f'[motion]\nkind = "commanded"\n{motion}\n', encoding="utf-8")
    with pytest.raises(InputError) as err:
        EmulatedArm(load_scene(path))
    assert err.value.exit_code == 2 and "\n" not in str(err.value)
    assert str(err.value).startswith(f"{path}: {why}"), str(err.value)


def test_a_bad_pose_is_bad_input_and_a_taken_address_is_refused():
    with pytest.raises(InputError, match="quaternion: must have unit length") as err:
        Pose((0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.1))
    assert err.value.exit_code == 2
    with pytest.raises(InputError, match=r"position_m\[1\]: must be finite"):
        Pose((0.0, math.inf, 0.0))
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        with pytest.raises(InputError, match=f"--robot 127.0.0.1:{port}: cannot listen there"):
            RobotServer(_arm(), "127.0.0.1", port)


def test_tactile_emulate_robot_end_to_end(tmp_path):
    """``tactile emulate SCENE --robot 127.0.0.1:0 --pose-log``, a process: a touch over TCP
    while a host reads the board's port, and the pose log's row for its hold."""
    log = tmp_path / "poses.csv"
    cmd = [sys.executable, "-m", "tactile.cli.main", "emulate", "explore_cylinder", "--fast",
           "--robot", "127.0.0.1:0", "--pose-log", str(log)]  # fmt: skip
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))  # this checkout's sources
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    try:
        path = proc.stdout.readline().decode().strip()
        address = proc.stdout.readline().decode().strip()
        port = serial.Serial(path, timeout=0.02)
        result = {}

        def command():
            with RobotClient(address, timeout_s=30) as client:
                result["touch"] = client.touch((0.0, 0.0, 0.06), (0, 0, -1), 5.0, 0.05)

        worker = threading.Thread(target=command)
        worker.start()
        while worker.is_alive():  # a host reading, so the fast board's time runs
            port.read(4096)
        port.close()
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=30)
    touch = result["touch"]
    assert touch.touched and touch.force_N == pytest.approx(5.0)
    rows = read_pose_log(log)
    assert (rows.t_start[0], rows.t_end[0]) == touch.t_us and len(rows) == 1
    np.testing.assert_allclose(rows.position[0], touch.pose.position_m, atol=1e-15)
    assert b"Traceback" not in err
