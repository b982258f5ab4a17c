#!/usr/bin/env python3
"""Bad bytes on topic connections (issue 19, item 2): a forged publisher for every topic the system subscribes to.

Against a running main system (test/service_battery.sh brings it up), for every topic that a node under the
namespace subscribes to, this script registers itself with the master as one more publisher of the topic, serves
the subscribers' requestTopic (XML-RPC) and accepts their TCPROS connections, answers their header as a real
publisher would (the type's md5sum and definition) and then sends, one case per registration:

  garbage    a length prefix and random bytes, one fewer than the type's smallest message, so they cannot
             deserialize; every array count roscpp reads on its way through them is tamed to under 1000 (tame()).
             Untamed, random counts made a nodelet manager allocate 12 GB and the kernel kill it. Random bytes at
             least as long as a fixed-size type (rosgraph_msgs/Clock) *are* a message to roscpp, which ignores
             what follows a complete message: a random simulated time. Both are ROS's risks, not cases this test
             can judge (doc/security.md).
  truncated  a length prefix that promises 64 KiB, 16 bytes, and the connection closed
  oversized  a length prefix of 2^31 bytes (over roscpp's 1 GB limit: it drops the connection)
  forged     a well-formed message of the right length whose first array (or string) declares 2^32-1 elements
             (roscpp resizes a vector before it checks the bytes are there: only element types of 8 bytes or more
             are forged, whose resize the kernel refuses at once on a 24 GiB machine with heuristic overcommit; see
             doc/security.md for the smaller ones)

After each topic's cases it checks that every component still answers get_state, and at the end that XPERSim's
world (ground truth) and the knowledge base are unchanged. Prints a table; exits 1 when a check failed.

  topic_garbage.py --kb FILE [--ns /xpersif] [--out FILE]
"""
import argparse
import io
import os
import random
import socket
import struct
import sys
import threading
import time
import xmlrpc.client
from xmlrpc.server import SimpleXMLRPCServer

import genpy
import rosgraph
import roslib.message
import rospy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from service_battery import Battery  # noqa: E402 - the same state hashes and liveness checks

CASES = ("garbage", "truncated", "oversized", "forged")
HUGE = 0xFFFFFFFF
NARROW_ELEMENTS = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "string"}


def header_bytes(fields):
    body = b""
    for key, value in fields.items():
        item = ("%s=%s" % (key, value)).encode()
        body += struct.pack("<I", len(item)) + item
    return struct.pack("<I", len(body)) + body


def read_header(conn):
    size = struct.unpack("<I", conn.recv(4, socket.MSG_WAITALL))[0]
    data = conn.recv(size, socket.MSG_WAITALL)
    fields, i = {}, 0
    while i < len(data):
        n = struct.unpack("<I", data[i:i + 4])[0]
        key, _, value = data[i + 4:i + 4 + n].decode(errors="replace").partition("=")
        fields[key] = value
        i += 4 + n
    return fields


PRIMITIVE_SIZES = {"bool": 1, "byte": 1, "char": 1, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2, "int32": 4,
                   "uint32": 4, "float32": 4, "int64": 8, "uint64": 8, "float64": 8, "time": 8, "duration": 8}
SAFE_COUNT = 100000  # elements roscpp may allocate for one array before it checks the bytes are there


class Overrun(Exception):
    """The bytes end before the message does: roscpp throws here, having allocated nothing big."""


def tame(buf, msg_class, rng):
    """Walk @p buf as roscpp deserializes @p msg_class (fields in order, a uint32 count before every string and
    variable array) and overwrite every array count over SAFE_COUNT with a small random one: roscpp resizes a vector
    to its count before it checks the bytes, so random bytes can make it allocate gigabytes (issue 19: a nodelet
    manager grew to 12 GB and was killed by the kernel). Returns how many counts were tamed; the walk must overrun."""
    tamed = [0]
    pos = [0]

    def take(n):
        if pos[0] + n > len(buf):
            raise Overrun()
        pos[0] += n

    def count(is_string):
        take(4)
        n = struct.unpack_from("<I", buf, pos[0] - 4)[0]
        if not is_string and n > SAFE_COUNT:
            n = rng.randrange(1, 1000)
            struct.pack_into("<I", buf, pos[0] - 4, n)
            tamed[0] += 1
        return n

    def field(typ):
        if typ.endswith("]"):
            element, size = typ[:typ.index("[")], typ[typ.index("[") + 1:-1]
            n = int(size) if size else count(False)
            if element in PRIMITIVE_SIZES:
                take(n * PRIMITIVE_SIZES[element])
            else:
                for _ in range(n):
                    field(element)
        elif typ in PRIMITIVE_SIZES:
            take(PRIMITIVE_SIZES[typ])
        elif typ == "string":
            take(count(True))  # roscpp checks a string's bytes before it copies them
        else:
            cls = roslib.message.get_message_class("std_msgs/Header" if typ == "Header" else typ)
            for t in cls._slot_types:
                field(t)

    try:
        for t in msg_class._slot_types:
            field(t)
    except Overrun:
        return tamed[0]
    raise AssertionError("garbage for %s deserializes" % msg_class._type)


def garbage(msg_class, rng):
    """Random bytes, one fewer than the type's smallest message (so they cannot deserialize), with every count
    roscpp would read on its way tamed (tame()). Returns (bytes, counts tamed)."""
    buf = bytearray(rng.randbytes(smallest_message(msg_class) - 1))
    tamed = tame(buf, msg_class, rng)
    return bytes(buf), tamed


def serialized(msg):
    buf = io.BytesIO()
    msg.serialize(buf)
    return bytearray(buf.getvalue())


def smallest_message(msg_class):
    """Bytes of the type's default message: empty strings and arrays, so no message of the type is shorter."""
    return len(serialized(msg_class()))


def forged_message(msg_class):
    """The type's default message with its first top-level array of wide elements declaring HUGE of them, as
    (bytes, field name), or None when it has no such array."""
    for name, typ in zip(msg_class.__slots__, msg_class._slot_types):
        if not typ.endswith("[]") or typ[:-2] in NARROW_ELEMENTS:
            continue  # not a variable array, or narrow elements whose resize the kernel would grant
        element = typ[:-2]
        if element == "time":
            sample = genpy.Time()
        elif element == "duration":
            sample = genpy.Duration()
        elif "/" in element or element == "Header":
            sample = roslib.message.get_message_class("std_msgs/Header" if element == "Header" else element)()
        else:
            sample = 0
        empty, one = msg_class(), msg_class()
        setattr(one, name, [sample])
        a, b = serialized(empty), serialized(one)
        offset = next(i for i in range(len(a)) if a[i] != b[i])  # the array's length: 0 in one, 1 in the other
        a[offset:offset + 4] = struct.pack("<I", HUGE)
        return bytes(a), name
    return None


class ForgedPublisher:
    """One registration as a publisher of @p topic that answers every subscriber with @p case."""

    def __init__(self, topic, topic_type, case):
        self.master = xmlrpc.client.ServerProxy(rosgraph.get_master_uri())  # the master's API, as this caller
        self.topic, self.type, self.case = topic, topic_type, case
        self.msg_class = roslib.message.get_message_class(topic_type)
        self.caller_id = "/xpersif_topic_garbage_%d" % os.getpid()
        self.sent = 0
        self.tamed = 0
        self.listener = socket.socket()
        self.listener.bind(("127.0.0.1", 0))
        self.listener.listen(16)
        self.rpc = SimpleXMLRPCServer(("127.0.0.1", 0), logRequests=False, allow_none=True)
        for name, fn in (("requestTopic", self.request_topic), ("getPid", lambda c: [1, "", os.getpid()]),
                         ("getBusInfo", lambda c: [1, "", []]), ("shutdown", lambda c, m="": [1, "", 0]),
                         ("publisherUpdate", lambda c, t, p: [1, "", 0]),
                         ("paramUpdate", lambda c, k, v: [1, "", 0])):
            self.rpc.register_function(fn, name)
        self.uri = "http://127.0.0.1:%d/" % self.rpc.server_address[1]
        self.stop = False
        threading.Thread(target=self.rpc.serve_forever, daemon=True).start()
        threading.Thread(target=self.accept, daemon=True).start()

    def request_topic(self, caller_id, topic, protocols):
        return [1, "", ["TCPROS", "127.0.0.1", self.listener.getsockname()[1]]]

    def accept(self):
        self.listener.settimeout(0.2)
        while not self.stop:
            try:
                conn, _ = self.listener.accept()
            except socket.timeout:
                continue
            except OSError:
                return
            threading.Thread(target=self.serve, args=(conn,), daemon=True).start()

    def serve(self, conn):
        try:
            conn.settimeout(5)
            read_header(conn)
            conn.sendall(header_bytes({"callerid": self.caller_id, "topic": self.topic, "type": self.type,
                                       "md5sum": self.msg_class._md5sum, "latching": "0",
                                       "message_definition": self.msg_class._full_text}))
            # Seeded by topic and case: the same bytes every run.
            rng = random.Random("%s %s" % (self.topic, self.case))
            if self.case == "garbage":
                payload, self.tamed = garbage(self.msg_class, rng)
                conn.sendall(struct.pack("<I", len(payload)) + payload)
            elif self.case == "truncated":
                conn.sendall(struct.pack("<I", 65536) + rng.randbytes(16))
            elif self.case == "oversized":
                conn.sendall(struct.pack("<I", 1 << 31) + rng.randbytes(64))
            elif self.case == "forged":
                body, _ = forged_message(self.msg_class)
                conn.sendall(struct.pack("<I", len(body)) + body)
            self.sent += 1
            time.sleep(0.5)  # let the subscriber read it before the connection closes
        except OSError:
            pass
        finally:
            conn.close()

    def run(self, subscribers, timeout=10.0):
        code, msg, _ = self.master.registerPublisher(self.caller_id, self.topic, self.type, self.uri)
        if code != 1:
            return "the master refused the registration: %s" % msg
        deadline = time.time() + timeout
        while self.sent < subscribers and time.time() < deadline:
            time.sleep(0.05)
        time.sleep(0.7)
        self.master.unregisterPublisher(self.caller_id, self.topic, self.uri)
        self.stop = True
        self.rpc.shutdown()
        self.listener.close()
        return ""


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--kb", required=True)
    parser.add_argument("--ns", default="/xpersif")
    parser.add_argument("--out", default="/tmp/xpersif_topic_garbage.md")
    args = parser.parse_args()
    rospy.init_node("xpersif_topic_garbage", anonymous=True, disable_signals=True)
    battery = Battery(args.ns, args.kb, args.out, None)
    master = rosgraph.Master(rospy.get_name())
    components = battery.components()
    before = battery.state()

    _, subscribed, _ = master.getSystemState()
    types = dict(master.getTopicTypes())
    ns = args.ns.rstrip("/") + "/"
    targets = []
    for topic, nodes in sorted(subscribed):
        ours = [n for n in nodes if n.startswith(ns)]
        if not ours or topic not in types or types[topic] == "*" or topic == "/rosout":
            continue
        try:
            loadable = roslib.message.get_message_class(types[topic]) is not None
        except Exception:  # noqa: BLE001 - a type this python cannot load is skipped, and said so
            loadable = False
        if not loadable:
            print("skipped %s: its type %s cannot be loaded here" % (topic, types[topic]))
            continue
        targets.append((topic, types[topic], len(ours)))

    # One round per case: a forged publisher for every topic at once, then every component asked if it lives.
    rows, failures = [], []
    forged = {topic: forged_message(roslib.message.get_message_class(t)) for topic, t, _ in targets}
    for case in CASES:
        def applies(target):
            msg_class = roslib.message.get_message_class(target[1])
            if case == "forged":
                return forged[target[0]] is not None
            return case != "garbage" or smallest_message(msg_class) > 0
        round_targets = [t for t in targets if applies(t)]
        for target in targets:
            if target not in round_targets:
                rows.append((target[0], target[1], case, "-",
                             "no array of 8-byte or wider elements: not sent" if case == "forged"
                             else "its messages are empty: any bytes are one"))
        publishers = [(t, ForgedPublisher(t[0], t[1], case)) for t in round_targets]
        outcomes = {}
        threads = [threading.Thread(target=lambda t=t, p=p: outcomes.__setitem__(t[0], p.run(t[2])))
                   for t, p in publishers]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        for (topic, topic_type, subscribers), publisher in publishers:
            why = outcomes.get(topic, "no outcome")
            if why:
                failures.append("%s %s: %s" % (topic, case, why))
            what = {"forged": "field %s declares %d elements" % (forged[topic][1], HUGE) if forged[topic] else "",
                    "garbage": "%d random bytes, %d counts tamed" %
                               (smallest_message(roslib.message.get_message_class(topic_type)) - 1, publisher.tamed)
                    }.get(case, "sent")
            rows.append((topic, topic_type, case, "%d (%d nodes)" % (publisher.sent, subscribers), why or what))
        dead = [c for c in components if battery.alive(c) is None]
        world = battery.world_hash()  # after each round: which case changed the world, if one did
        print("%s: %d forged publishers, %d connections served; %s; world %s" %
              (case, len(publishers), sum(p.sent for _, p in publishers),
               "every component answers" if not dead else "DEAD: " + ", ".join(dead), world))
        if world != before[0]:
            failures.append("after the %s round the world is %s, not %s" % (case, world, before[0]))
        if dead:
            failures.append("after the %s round: %s no longer answer get_state" % (case, ", ".join(dead)))
    rows.sort()
    after = battery.state()
    if before != after:
        failures.append("the world or the knowledge base changed: %s -> %s" % (before, after))
    sent = sum(1 for r in rows if r[3] != "-")
    connected = sum(int(r[3].split()[0]) for r in rows if r[3] != "-")

    with open(args.out, "w") as out:
        out.write("| topic | type | case | connections served (subscribing nodes) | what was sent |\n|---|---|---|---|---|\n")
        for row in rows:
            out.write("| %s |\n" % " | ".join(str(c) for c in row))
    summary = ("%d topics, %d forged publishers, %d subscriber connections served bad bytes; every component "
               "answers; world and knowledge base %s; %d failures" %
               (len(targets), sent, connected, "unchanged" if before == after else "CHANGED", len(failures)))
    print(summary)
    with open(args.out, "a") as out:
        out.write("\n" + summary + "\n")
    for f in failures:
        print("FAIL: " + f, file=sys.stderr)
    if connected == 0:
        print("FAIL: no subscriber connected to a forged publisher", file=sys.stderr)
        return 1
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
