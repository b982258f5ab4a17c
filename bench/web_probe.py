#!/usr/bin/python3
"""bench/run_web.sh's probe: over one window, the simulator's real-time factor (from /clock) and the CPU and memory
of the bridge and of the simulator (from /proc).   web_probe.py BRIDGE_PID SIM_PID WARMUP SECONDS"""
import json
import os
import sys
import time

import rospy
from rosgraph_msgs.msg import Clock

TICK = os.sysconf("SC_CLK_TCK")


def cpu(pid):
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK  # utime + stime


def rss_mb(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return 0.0


def main():
    bridge, sim, warmup, seconds = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
    rospy.init_node("web_probe", anonymous=True, disable_signals=True)
    time.sleep(warmup)
    c0 = rospy.wait_for_message("/clock", Clock, timeout=10).clock.to_sec()
    w0, b0, s0 = time.time(), cpu(bridge), cpu(sim)
    time.sleep(seconds)
    c1 = rospy.wait_for_message("/clock", Clock, timeout=10).clock.to_sec()
    w1, b1, s1 = time.time(), cpu(bridge), cpu(sim)
    print(json.dumps({"rtf": (c1 - c0) / (w1 - w0), "bridge_cpu_pct": 100 * (b1 - b0) / (w1 - w0),
                      "sim_cpu_pct": 100 * (s1 - s0) / (w1 - w0), "bridge_rss_mb": rss_mb(bridge)}))


if __name__ == "__main__":
    main()
