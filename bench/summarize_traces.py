#!/usr/bin/env python3
"""Summarize one recorded run for bench/run_traces.sh: /tf frames recorded vs expected, simulated span, bytes.

   summarize_traces.py RUN_DIR TF_RATE|auto  -> one JSON line

XPERSim stamps /tf with simulated time advancing by exactly 1/tf_rate per frame (when every frame is
published: realtime, or fast with ~max_frame_rate above the frame rate), so over the frames recorded
expected = round((last - first) * tf_rate) + 1 and dropped = expected - distinct stamps recorded.
With `auto` the frame period is the most common difference between consecutive recorded stamps.
(rosbag's own Python API: Debian's python3-rosbag.)
"""
import glob
import json
import os
import sys

import rosbag

run_dir, rate_arg = sys.argv[1], sys.argv[2]
rate = 1e6  # stamps are collected in microseconds, then divided by the period
bags = sorted(glob.glob(os.path.join(run_dir, '*.bag')))
by_caller = {}  # (/tf publisher, transforms per message) -> stamps (us); XPERSim's scene frames are the most
clock_first = clock_last = None
counts = {}
for path in bags:
    with rosbag.Bag(path) as bag:
        for topic, msg, t, header in bag.read_messages(return_connection_header=True):
            counts[topic] = counts.get(topic, 0) + 1
            if topic == '/tf' and msg.transforms:
                caller = header.get('callerid', b'')
                caller = caller.decode() if isinstance(caller, bytes) else caller
                by_caller.setdefault((caller, len(msg.transforms)), set()).add(round(msg.transforms[0].header.stamp.to_sec() * rate))
            elif topic == '/clock':
                c = msg.clock.to_sec()
                clock_first = c if clock_first is None else min(clock_first, c)
                clock_last = c if clock_last is None else max(clock_last, c)
size = sum(os.path.getsize(p) for p in bags)
tf_publisher = max(by_caller, key=lambda c: len(by_caller[c])) if by_caller else ''
ordered = sorted(by_caller.get(tf_publisher, ()))
if rate_arg == 'auto':
    diffs = {}
    for a, b in zip(ordered, ordered[1:]):
        diffs[b - a] = diffs.get(b - a, 0) + 1
    period_us = max(diffs, key=diffs.get) if diffs else 1000
else:
    period_us = round(1e6 / float(rate_arg))
frames = sorted({round(s / period_us) for s in ordered})
stamps = frames
expected = (frames[-1] - frames[0] + 1) if frames else 0
sim_s = (clock_last - clock_first) if clock_first is not None else 0.0
print(json.dumps({
    'bags': len(bags), 'bytes': size, 'sim_s': round(sim_s, 3),
    'bytes_per_sim_s': round(size / sim_s) if sim_s > 0 else None,
    'tf_streams': len(by_caller), 'tf_publisher': '%s (%d transforms)' % tf_publisher if tf_publisher else '', 'tf_period_ms': period_us / 1000.0, 'tf_recorded': len(stamps), 'tf_expected': expected, 'tf_dropped': expected - len(stamps),
    'messages': sum(counts.values()), 'topics': len(counts),
    'image_msgs': sum(n for t, n in counts.items() if t.endswith('image_raw')),
}))
