#!/usr/bin/env python3
"""Summarize a recorded main-job run (scripts/run.sh --record) for bench/run_loop_record.sh: what was recorded
per topic against what was published, where the published count is known, and bytes per simulated second.

   summarize_loop_record.py RUN_DIR  -> one JSON line

Published counts, by topic:
 - /xpersif/knowledge_base/experiments: the knowledge base's experiments table (one message per commit);
 - /xpersif/machine_learning/model: the knowledge base's models table (it stores every model it hears; a
   model the KB missed is not counted as published);
 - /tf: XPERSim's scene frames, by stamp (consecutive frames are exactly one physics step apart; a new
   XPERSim incarnation restarts the stamps, none here), as bench/summarize_traces.py;
 - FeatureVector and image topics: header.seq counts every image the camera rendered (one vector per image),
   so expected = last seq - first seq + 1 per publisher incarnation; dropped = expected - distinct seqs.
(rosbag's own Python API: Debian's python3-rosbag.)
"""
import glob
import json
import os
import sqlite3
import sys

import rosbag

run_dir = sys.argv[1]
bags = sorted(glob.glob(os.path.join(run_dir, 'xpersif_*.bag')))
counts = {}
tf_stamps = {}      # (callerid, transforms) -> set of stamps (us)
seqs = {}           # topic -> list of header.seq in order
models_with_run = 0
clock_first = clock_last = None
for path in bags:
    with rosbag.Bag(path) as bag:
        for topic, msg, t, header in bag.read_messages(return_connection_header=True):
            counts[topic] = counts.get(topic, 0) + 1
            if topic == '/tf' and msg.transforms:
                caller = header.get('callerid', b'')
                caller = caller.decode() if isinstance(caller, bytes) else caller
                tf_stamps.setdefault((caller, len(msg.transforms)), set()).add(
                    round(msg.transforms[0].header.stamp.to_sec() * 1e6))
            if topic == '/clock':
                c = msg.clock.to_sec()
                clock_first = c if clock_first is None else min(clock_first, c)
                clock_last = c if clock_last is None else max(clock_last, c)
            elif topic == '/xpersif/machine_learning/model' and msg.run_id != 0 and msg.data:
                models_with_run += 1  # what the KB stores (it skips run 0 and empty models)
            if topic.endswith('/features') or topic.endswith('image_raw'):
                seqs.setdefault(topic, []).append(msg.header.seq)


def seq_drops(values):
    """expected and recorded over runs of increasing seq (a restarted publisher starts again at 1)."""
    expected = recorded = 0
    run = []
    for v in values + [None]:
        if v is None or (run and v < run[-1]):
            if run:
                expected += run[-1] - run[0] + 1
                recorded += len(set(run))
            run = []
        if v is not None:
            run.append(v)
    return {'expected': expected, 'recorded': recorded, 'dropped': expected - recorded}


published = {}
db = os.path.join(run_dir, 'knowledge.db')
if os.path.exists(db):
    con = sqlite3.connect(db)
    published['/xpersif/knowledge_base/experiments'] = con.execute('select count(*) from experiments').fetchone()[0]
    published['/xpersif/machine_learning/model'] = con.execute('select count(*) from models').fetchone()[0]
    con.close()

tf = {}
if tf_stamps:
    key = max(tf_stamps, key=lambda k: len(tf_stamps[k]))
    ordered = sorted(tf_stamps[key])
    diffs = {}
    for a, b in zip(ordered, ordered[1:]):
        diffs[b - a] = diffs.get(b - a, 0) + 1
    period = max(diffs, key=diffs.get) if diffs else 1
    frames = sorted({round(s / period) for s in ordered})
    expected = frames[-1] - frames[0] + 1 if frames else 0
    tf = {'publisher': '%s (%d transforms)' % key, 'period_ms': period / 1000.0, 'expected': expected,
          'recorded': len(frames), 'dropped': expected - len(frames)}

size = sum(os.path.getsize(p) for p in bags)
sim_s = (clock_last - clock_first) if clock_first is not None else 0.0
surprise = sorted(glob.glob(os.path.join(run_dir, 'surprise_*.bag')))
print(json.dumps({
    'bags': len(bags), 'bytes': size, 'sim_s': round(sim_s, 3),
    'bytes_per_sim_s': round(size / sim_s) if sim_s > 0 else None,
    'messages': sum(counts.values()), 'topics': len(counts), 'per_topic': dict(sorted(counts.items())),
    'published': published, 'model_messages_with_run': models_with_run, 'tf': tf, 'seq': {t: seq_drops(v) for t, v in sorted(seqs.items())},
    'surprise_bags': len(surprise), 'surprise_bytes': sum(os.path.getsize(p) for p in surprise),
}))
