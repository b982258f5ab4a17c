#!/usr/bin/python3
"""WEBBRIDGE without a browser (test/web_bridge.test): XPERSim in realtime and two bridges as stand-alone nodes,
`web_bridge` (read-only, the default) and `web_bridge_cmd` (commands with a token; no LOOPMODEL runs, so a command
reaches the bridge's command path and is answered "not offered"). WebSocket clients are python3-websocket's.

- the scene once, first, as XPERSim describes it; then frames with every dynamic node, where ground truth says;
- the page and three.js over HTTP from the same port, 404 for anything else, /stats;
- a client's rate (10 Hz) and "full" (every frame the bridge receives);
- a slow client (reads one message a second) and a client that never reads: the bridge's memory and their socket
  queues stay bounded, the one that never reads is disconnected, the other clients keep the full rate;
- malformed, oversized, binary, unexpected and flooding client messages: each closed with its code, the bridge goes on;
- a client that disconnects in the middle of a frame it sends, and one that vanishes while frames stream to it.
"""
import json
import os
import socket
import struct
import sys
import threading
import time
import unittest
import urllib.request
import xmlrpc.client

import rosgraph
import rospy
import websocket

from xpersif.msg import BodyPoses, Scene

PKG = "xpersif"
# The least share of the bridge's frames a client reading at full rate must get. A timing figure, so it is kept far
# from both what is measured here (95-100 % idle, 82 % once on a loaded CI machine) and what the failures it
# guards against give (~20 % or less).
FAST_CLIENT_SHARE = 0.6


def bridge_port(node):
    deadline = time.time() + 60
    while time.time() < deadline:
        if rospy.has_param(node + "/bound_port"):
            port = rospy.get_param(node + "/bound_port")
            if port:
                return port
        time.sleep(0.2)
    raise AssertionError(node + " never listened (no ~bound_port)")


def node_pid(node):
    master = rosgraph.Master("/test_web_bridge")
    uri = master.lookupNode(node)
    return xmlrpc.client.ServerProxy(uri).getPid("/test_web_bridge")[2]


def rss_kb(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def decode_frame(data):
    assert data[:4] == b"XPF1", data[:4]
    generation, seq, sim_time, wall_time, n = struct.unpack_from("<IQddI", data, 4)
    assert len(data) == 36 + 28 * n, (len(data), n)
    poses = [struct.unpack_from("<7f", data, 36 + 28 * i) for i in range(n)]
    return generation, seq, sim_time, wall_time, poses


def close_code(ws, timeout=10):
    """Read until the server's close frame; its code (None if the connection just ended)."""
    ws.settimeout(timeout)
    deadline = time.time() + timeout
    while time.time() < deadline:
        try:
            frame = ws.recv_frame()  # raw frames: recv_data would answer the close and fail on a closed socket
        except (websocket.WebSocketConnectionClosedException, socket.timeout, websocket.WebSocketTimeoutException,
                ConnectionResetError, BrokenPipeError):
            return None
        if frame is None:
            return None
        if frame.opcode == websocket.ABNF.OPCODE_CLOSE:
            return struct.unpack("!H", frame.data[:2])[0] if len(frame.data) >= 2 else None
    return None


class Reader(threading.Thread):
    """A client that reads everything, as fast as it comes, and counts frames."""

    def __init__(self, url, rate="full", pause=0.0, rcvbuf=None):
        super().__init__(daemon=True)
        opts = ((socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf),) if rcvbuf else ()
        self.ws = websocket.create_connection(url, timeout=10, sockopt=opts)
        self.ws.send(json.dumps({"type": "config", "rate": rate}))
        self.pause = pause
        self.frames = 0
        self.closed_with = None
        self.stop = False

    def run(self):
        while not self.stop:
            try:
                opcode, data = self.ws.recv_data(control_frame=True)
            except Exception:
                return
            if opcode == websocket.ABNF.OPCODE_CLOSE:
                self.closed_with = struct.unpack("!H", data[:2])[0] if len(data) >= 2 else 0
                return
            if opcode == websocket.ABNF.OPCODE_BINARY:
                self.frames += 1
            if self.pause:
                time.sleep(self.pause)

    def close(self):
        self.stop = True
        try:
            self.ws.close(timeout=1)
        except Exception:
            pass


class TestWebBridge(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_web_bridge", anonymous=True)
        cls.port = bridge_port("/web_bridge")
        cls.cmd_port = bridge_port("/web_bridge_cmd")
        cls.url = "ws://127.0.0.1:%d/" % cls.port
        cls.http = "http://127.0.0.1:%d" % cls.port
        cls.scene = rospy.wait_for_message("/xpersif/xpersim/scene", Scene, timeout=60)
        cls.pid = node_pid("/web_bridge")

    def stats(self, port=None):
        with urllib.request.urlopen("http://127.0.0.1:%d/stats" % (port or self.port), timeout=5) as r:
            return json.loads(r.read())

    def first_messages(self, ws, count):
        out = []
        while len(out) < count:
            out.append(ws.recv())
        return out

    def assert_serving(self):
        ws = websocket.create_connection(self.url, timeout=10)
        scene = json.loads(ws.recv())
        self.assertEqual(scene["type"], "scene")
        ws.close()

    # ---- what a client gets ----------------------------------------------------------------------------
    def test_scene_first_then_frames_where_ground_truth_says(self):
        ws = websocket.create_connection(self.url, timeout=10)
        scene = json.loads(ws.recv())
        self.assertEqual(scene["type"], "scene")
        self.assertEqual([n["name"] for n in scene["nodes"]], [n.name for n in self.scene.nodes])
        self.assertEqual(scene["objects"], list(self.scene.objects))
        self.assertEqual(scene["frame_nodes"], [n.name for n in self.scene.nodes if n.dynamic])
        self.assertEqual([c["name"] for c in scene["cameras"]], [c.name for c in self.scene.cameras])
        for got, want in zip(scene["nodes"], self.scene.nodes):
            for v, w in zip(got["visuals"], want.visuals):
                self.assertAlmostEqual(v["color"][0], w.color.r, places=5)
        ws.send(json.dumps({"type": "config", "rate": "full"}))
        truth = rospy.wait_for_message("/xpersif/xpersim/ground_truth", BodyPoses, timeout=10)
        frame = None
        deadline = time.time() + 10
        while frame is None and time.time() < deadline:
            data = ws.recv()
            if isinstance(data, bytes):
                frame = decode_frame(data)
        self.assertIsNotNone(frame, "no frame within 10 s")
        generation, seq, sim_time, wall_time, poses = frame
        self.assertEqual(generation, scene["generation"])
        self.assertEqual(len(poses), len(scene["frame_nodes"]))
        self.assertLess(abs(time.time() - wall_time), 1.0)
        # Objects are top-level dynamic nodes: their frame pose is their world pose (the world stands still).
        index = {name: i for i, name in enumerate(scene["frame_nodes"])}
        for name, pose in zip(truth.names, truth.poses):
            if name not in index:
                continue
            p = poses[index[name]]
            self.assertAlmostEqual(p[0], pose.position.x, delta=1e-3, msg=name)
            self.assertAlmostEqual(p[1], pose.position.y, delta=1e-3, msg=name)
        ws.close()

    def test_page_and_three_over_http(self):
        with urllib.request.urlopen(self.http + "/", timeout=5) as r:
            page = r.read().decode()
            self.assertIn("importmap", page)
            self.assertTrue(r.headers["Content-Type"].startswith("text/html"))
        for path in ("/app.js", "/style.css", "/three/three.module.js", "/three/three.core.js",
                     "/three/addons/controls/OrbitControls.js"):
            with urllib.request.urlopen(self.http + path, timeout=5) as r:
                self.assertEqual(r.status, 200, path)
                self.assertGreater(len(r.read()), 100, path)
        for path in ("/../package.json", "/etc/passwd", "/three/../../CMakeLists.txt", "/node_modules/three/package.json"):
            with self.assertRaises(urllib.error.HTTPError) as e:
                urllib.request.urlopen(self.http + path, timeout=5)
            self.assertEqual(e.exception.code, 404, path)
        s = self.stats()
        self.assertGreater(s["frames_in"], 0)

    def test_rate_the_client_asks_for(self):
        slow = Reader(self.url, rate=10)
        full = Reader(self.url, rate="full")
        slow.start()
        full.start()
        time.sleep(1.0)
        f0, s0, n0 = full.frames, slow.frames, self.stats()["frames_in"]
        time.sleep(4.0)
        f1, s1, n1 = full.frames, slow.frames, self.stats()["frames_in"]
        slow.close()
        full.close()
        published = n1 - n0
        print("4 s: the bridge received %d frames; the full-rate client got %d, the 10 Hz client %d" % (
            published, f1 - f0, s1 - s0))
        self.assertGreater(published, 100)
        # Not 0.9: this test's Python readers share two loaded cores with the bridge and the simulator, and a CI run
        # saw a reader at 82 %. A bridge that paced every client at the slowest one's rate gives ~20 % here.
        self.assertGreaterEqual(f1 - f0, FAST_CLIENT_SHARE * published)
        self.assertTrue(32 <= s1 - s0 <= 48, s1 - s0)

    # ---- slow clients ------------------------------------------------------------------------------------
    def test_slow_and_stuck_clients_keep_memory_bounded_and_others_at_full_rate(self):
        window = rospy.get_param("/web_bridge/send_window")
        fast = [Reader(self.url) for _ in range(3)]
        slow = Reader(self.url, pause=1.0, rcvbuf=4096)  # reads one message a second
        stuck = websocket.create_connection(self.url, timeout=10,
                                            sockopt=((socket.SOL_SOCKET, socket.SO_RCVBUF, 4096),))
        stuck.send(json.dumps({"type": "config", "rate": "full"}))  # and never reads again
        for r in fast + [slow]:
            r.start()
        rss0 = rss_kb(self.pid)
        time.sleep(1.0)
        n0 = self.stats()["frames_in"]
        counts0 = [r.frames for r in fast]
        max_queued, max_rss = 0, rss0
        stuck_gone_after = None
        t0 = time.time()
        while time.time() - t0 < 12:
            s = self.stats()
            max_queued = max([max_queued] + [c["socket_queued_bytes"] + c["pending_bytes"] for c in s["clients"]])
            max_rss = max(max_rss, rss_kb(self.pid))
            if stuck_gone_after is None and s["disconnected_not_reading"] >= 1:
                stuck_gone_after = time.time() - t0
            time.sleep(0.25)
        n1 = self.stats()["frames_in"]
        counts1 = [r.frames for r in fast]
        for r in fast + [slow]:
            r.close()
        stuck.close()
        published = n1 - n0
        got = [b - a for a, b in zip(counts0, counts1)]
        print("12 s with a slow and a stuck client: bridge received %d frames, fast clients got %s; most bytes queued "
              "for one client %d (window %d); bridge RSS %d -> %d kB; the stuck client dropped after %s s; the slow "
              "one got %d frames" % (published, got, max_queued, window, rss0, max_rss, stuck_gone_after, slow.frames))
        # A bridge that let the slow (1 message/s) or the stuck client hold the others back would give them ~1 %.
        for g in got:
            self.assertGreaterEqual(g, FAST_CLIENT_SHARE * published)
        # A socket queue holds at most the window plus one message, and what waits in the bridge is one message
        # per kind: nothing grows with time.
        self.assertLessEqual(max_queued, window + 64 * 1024)
        self.assertLess(max_rss - rss0, 20 * 1024)
        self.assertIsNotNone(stuck_gone_after, "a client that never reads was never disconnected")
        self.assert_serving()

    # ---- bad client messages -----------------------------------------------------------------------------
    def test_bad_messages_get_a_close_code(self):
        limit = rospy.get_param("/web_bridge/max_client_message")
        cases = [
            ("binary", lambda ws: ws.send_binary(b'{"type":"config"}'), 1003),
            ("not JSON", lambda ws: ws.send("{type: config"), 1007),
            ("not an object", lambda ws: ws.send("[1, 2, 3]"), 1007),
            ("no type", lambda ws: ws.send("{}"), 1007),
            ("unknown type", lambda ws: ws.send('{"type":"shutdown"}'), 1008),
            ("unexpected key", lambda ws: ws.send('{"type":"config","rate":5,"debug":true}'), 1008),
            ("rate out of range", lambda ws: ws.send('{"type":"config","rate":-3}'), 1007),
            ("oversized", lambda ws: ws.send('{"type":"ping","id":"' + "x" * (2 * limit) + '"}'), 1009),
            ("a command to a read-only bridge", lambda ws: ws.send('{"type":"command","command":"pause","token":"x"}'),
             1008),
            ("a flood", lambda ws: [ws.send('{"type":"ping"}') for _ in range(200)], 1008),
        ]
        before = self.stats()["closed_bad_messages"]
        for what, act, code in cases:
            ws = websocket.create_connection(self.url, timeout=10)
            self.first_messages(ws, 1)
            try:
                act(ws)
            except (BrokenPipeError, ConnectionResetError, websocket.WebSocketConnectionClosedException):
                pass  # the flood may meet the close
            self.assertEqual(close_code(ws), code, what)
            ws.close()
        self.assertGreaterEqual(self.stats()["closed_bad_messages"] - before, len(cases))
        self.assertEqual(node_pid("/web_bridge"), self.pid)  # never a crash
        self.assert_serving()

    def test_commands_need_the_token(self):
        url = "ws://127.0.0.1:%d/" % self.cmd_port
        ws = websocket.create_connection(url, timeout=10)
        ws.send(json.dumps({"type": "command", "command": "pause", "token": "wrong-token", "id": "a"}))
        self.assertEqual(close_code(ws), 1008)
        ws = websocket.create_connection(url, timeout=10)
        token = rospy.get_param("/web_bridge_cmd/token")
        ws.send(json.dumps({"type": "command", "command": "pause", "token": token, "id": "b"}))
        answer = None
        deadline = time.time() + 10
        while answer is None and time.time() < deadline:
            data = ws.recv()
            if isinstance(data, str) and json.loads(data)["type"] == "command_result":
                answer = json.loads(data)
        ws.close()
        self.assertIsNotNone(answer)
        self.assertEqual(answer["id"], "b")
        self.assertFalse(answer["success"])  # no LOOPMODEL here: the bridge says so
        self.assertIn("loop_model/pause", answer["message"])

    # ---- clients that vanish -----------------------------------------------------------------------------
    def test_disconnect_mid_frame(self):
        watcher = Reader(self.url)
        watcher.start()
        # A raw client: the handshake, then half of a masked text frame that announces 100 bytes, then a reset.
        for _ in range(5):
            s = socket.create_connection(("127.0.0.1", self.port), timeout=5)
            s.sendall(("GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                       "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n").encode())
            reply = s.recv(4096)
            self.assertIn(b"101", reply.split(b"\r\n")[0])
            s.sendall(bytes([0x81, 0x80 | 100]) + b"\x01\x02\x03\x04" + b"x" * 10)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            s.close()
        # Clients that go away while frames stream to them at full rate.
        for _ in range(5):
            ws = websocket.create_connection(self.url, timeout=10)
            ws.send(json.dumps({"type": "config", "rate": "full"}))
            ws.recv()
            ws.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            ws.sock.close()
        n0, f0 = self.stats()["frames_in"], watcher.frames
        time.sleep(2.0)
        n1, f1 = self.stats()["frames_in"], watcher.frames
        watcher.close()
        self.assertEqual(node_pid("/web_bridge"), self.pid)
        self.assertGreaterEqual(f1 - f0, 0.9 * (n1 - n0))
        deadline = time.time() + 10
        while time.time() < deadline and len(self.stats()["clients"]) > 0:
            time.sleep(0.2)
        self.assertEqual(self.stats()["clients"], [], "clients that vanished are still held")


if __name__ == "__main__":
    import rostest
    rostest.rosrun(PKG, "test_web_bridge", TestWebBridge, sys.argv)
