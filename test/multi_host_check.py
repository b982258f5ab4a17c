#!/usr/bin/python3
"""The checks of test/multi_host.sh, run on the loop host (inside its network namespace) with /usr/bin/python3.

  multi_host_check.py --sim-netns NS --view-netns NS --view-dir DIR [--experiments N]

1. every component LOOPMODEL supervises becomes ACTIVE, each node runs on the host the launch put it on (its
   XML-RPC URI names that host's address, its process is in that namespace);
2. a short run (random design, N experiments) starts; after its first stored experiment every nodelet manager
   of the sim host is killed with SIGKILL; LOOPMODEL must report each of its components there `lost` within
   2 s, and `restarted` once roslaunch has respawned the managers on the sim host;
3. the run completes (SUCCEEDED, every experiment done or failed) and the knowledge base holds each of its
   experiments once;
4. the viewer on the view host (telesim_view) has rendered the scene from the tf it receives.
Exit status 0 when all hold; otherwise 1 with a sentence per failed check.
"""
import argparse
import glob
import os
import signal
import subprocess
import sys
import threading
import time

NS = "/xpersif"
SIM_MANAGERS = ["sim_manager", "embodiment_manager"]
NOTICE_LIMIT = 2.0  # seconds between the kill and LOOPMODEL's `lost`


def fail(sentence):
    print("multi_host_check: FAIL: " + sentence, flush=True)
    sys.exit(1)


def say(sentence):
    print("multi_host_check: " + sentence, flush=True)


def wait_for(predicate, timeout, period=0.1):
    deadline = time.time() + timeout
    while time.time() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(period)
    return predicate()


def netns_processes(netns):
    """{pid: command line} of the processes in a network namespace."""
    out = subprocess.run(["ip", "netns", "pids", netns], capture_output=True, text=True).stdout.split()
    processes = {}
    for pid in out:
        try:
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                processes[int(pid)] = f.read().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            pass
    return processes


def manager_pids(netns, manager):
    return [pid for pid, cmd in netns_processes(netns).items()
            if "__name:=%s " % manager in cmd + " " and "nodelet" in cmd and " manager" in cmd]


def node_host(master, node):
    import urllib.parse
    try:
        uri = master.lookupNode(node)
    except Exception:
        return None
    return urllib.parse.urlparse(uri).hostname


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--sim-netns", required=True)
    parser.add_argument("--view-netns", required=True)
    parser.add_argument("--view-dir", required=True)
    parser.add_argument("--experiments", type=int, default=4)
    args = parser.parse_args()

    import actionlib
    import rosgraph
    import rospy
    from xpersif.msg import ComponentEvent, ComponentStatus, ExperimentRecord, RunLoopAction, RunLoopGoal
    from xpersif.srv import GetExperiments

    rospy.init_node("multi_host_check", disable_signals=True)
    master = rosgraph.Master("/multi_host_check")
    loop_ip = os.environ["ROS_IP"]

    # --- 1. up, and where it should be --------------------------------------------------------------------
    status = {}
    rospy.Subscriber(NS + "/loop_model/status", ComponentStatus, lambda m: status.update(last=m))

    def all_active():
        s = status.get("last")
        return s is not None and s.state == ComponentStatus.ACTIVE and s.parts and all(
            p.state == ComponentStatus.ACTIVE and p.state_name != "LOST" for p in s.parts)

    t0 = time.time()
    if not wait_for(all_active, 150.0):
        s = status.get("last")
        fail("LOOPMODEL and its components did not all become ACTIVE within 150 s: %s" % (
            "no status from LOOPMODEL" if s is None else
            ", ".join("%s %s" % (p.name, p.state_name) for p in s.parts if p.state != ComponentStatus.ACTIVE)
            or "LOOPMODEL is %s" % s.state_name))
    say("all %d components ACTIVE after %.0f s: %s" % (len(status["last"].parts), time.time() - t0,
                                                       ", ".join(p.name for p in status["last"].parts)))

    sim_ip = None
    for manager in SIM_MANAGERS:
        pids = manager_pids(args.sim_netns, manager)
        if len(pids) != 1:
            fail("%s should run once on the sim host (namespace %s); found %d processes" % (manager, args.sim_netns, len(pids)))
        sim_ip = node_host(master, NS + "/" + manager)
    for manager in ["kb_manager", "loop_manager"]:
        host = node_host(master, NS + "/" + manager)
        if host != loop_ip:
            fail("%s should run on the loop host %s; its URI names %s" % (manager, loop_ip, host))
    if sim_ip in (None, loop_ip):
        fail("the sim host's managers advertise %s, not an address of their own" % sim_ip)
    def tf_readers():
        _, subscribers, _ = master.getSystemState()
        return [n for topic, nodes in subscribers if topic == "/tf" for n in nodes if "telesim_view" in n]

    if not wait_for(tf_readers, 60.0, 0.5):
        fail("no telesim_view subscribes to /tf within 60 s")
    view_ip = node_host(master, tf_readers()[0])
    if view_ip in (None, loop_ip, sim_ip):
        fail("telesim_view runs at %s, not on a host of its own" % view_ip)
    if not any("telesim_view" in cmd for cmd in netns_processes(args.view_netns).values()):
        fail("telesim_view is not a process of the view host's namespace %s" % args.view_netns)
    say("placement: sim_manager and embodiment_manager at %s, kb_manager and loop_manager at %s, "
        "telesim_view at %s" % (sim_ip, loop_ip, view_ip))

    # --- 2. a run, and the sim host's managers killed mid-run ---------------------------------------------
    events = []
    lock = threading.Lock()

    def on_event(e):
        with lock:
            events.append((time.time(), e))

    records = []
    rospy.Subscriber(NS + "/loop_model/events", ComponentEvent, on_event, queue_size=200)
    rospy.Subscriber(NS + "/knowledge_base/experiments", ExperimentRecord, records.append, queue_size=100)
    client = actionlib.SimpleActionClient(NS + "/loop_model/run", RunLoopAction)
    if not client.wait_for_server(rospy.Duration(30.0)):
        fail("LOOPMODEL's run command is not offered")
    goal = RunLoopGoal(name="across_hosts", experiments=args.experiments, goals=0, design="random", seed=3)
    t_run = time.time()
    client.send_goal(goal)
    if not wait_for(lambda: records, 120.0):
        fail("no experiment was stored within 120 s of the run's start")
    say("first experiment stored %.1f s after the run started" % (time.time() - t_run))

    # The components LOOPMODEL runs in the sim host's managers (config/loop.yaml).
    supervised = {p.name.rsplit("/", 1)[-1] for p in status["last"].parts}
    on_sim = [c for c in ("xpersim", "robot_model") if c in supervised]
    if len(on_sim) != 2:
        fail("LOOPMODEL does not supervise xpersim and robot_model (it supervises %s)" % sorted(supervised))
    killed = []
    for manager in SIM_MANAGERS:
        for pid in manager_pids(args.sim_netns, manager):
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
    t_kill = time.time()
    say("killed the sim host's managers (pids %s)" % ", ".join(map(str, killed)))

    def first_event(component, outcome, after):
        with lock:
            for t, e in events:
                if (t >= after and e.kind == ComponentEvent.SUPERVISION and e.name.rsplit("/", 1)[-1] == component
                        and e.outcome == outcome):
                    return t, e
        return None

    for component in on_sim:
        lost = wait_for(lambda: first_event(component, "lost", t_kill), 10.0, 0.02)
        if not lost:
            fail("LOOPMODEL did not report %s lost within 10 s of the kill" % component)
        delay = lost[0] - t_kill
        say("LOOPMODEL noticed %s lost after %.2f s: %s" % (component, delay, lost[1].reason))
        if delay > NOTICE_LIMIT:
            fail("LOOPMODEL noticed %s lost after %.2f s; it must within %.1f s" % (component, delay, NOTICE_LIMIT))
    for component in on_sim:
        back = wait_for(lambda: first_event(component, "restarted", t_kill), 90.0, 0.1)
        if not back:
            fail("LOOPMODEL did not restart %s within 90 s of the kill" % component)
        say("%s restarted %.1f s after the kill" % (component, back[0] - t_kill))
    for manager in SIM_MANAGERS:
        if not wait_for(lambda: len(manager_pids(args.sim_netns, manager)) == 1, 30.0, 0.2):
            fail("%s was not respawned on the sim host" % manager)

    # --- 3. the run completes, every experiment stored once ------------------------------------------------
    if not client.wait_for_result(rospy.Duration(150.0)):
        fail("the run did not end within 150 s of the kill")
    state, result = client.get_state(), client.get_result()
    if state != actionlib.GoalStatus.SUCCEEDED:
        fail("the run ended in state %d: %s" % (state, client.get_goal_status_text()))
    say("run %d: %d done, %d failed, %.0f s" % (result.run_id, result.experiments_done, result.experiments_failed,
                                                 time.time() - t_run))
    if result.experiments_done + result.experiments_failed != args.experiments:
        fail("the run did %d + %d experiments, not %d" % (result.experiments_done, result.experiments_failed,
                                                         args.experiments))
    if result.experiments_done < 2:
        fail("only %d experiments succeeded: %s" % (result.experiments_done, result.message))
    get = rospy.ServiceProxy(NS + "/knowledge_base/get_experiments", GetExperiments)
    stored = get(run_id=result.run_id, status="")
    if not stored.success:
        fail("get_experiments refused: " + stored.message)
    seqs = [r.seq for r in stored.experiments]
    if sorted(seqs) != list(range(1, args.experiments + 1)):
        fail("the knowledge base holds experiments %s of run %d; expected 1..%d once each" % (
            seqs, result.run_id, args.experiments))
    done = [r for r in stored.experiments if r.status == "done"]
    if any(not r.before.objects or not r.after.objects for r in done):
        fail("a stored experiment lacks the world before or after")
    say("the knowledge base holds experiments %s of run %d" % (sorted(seqs), result.run_id))

    # --- 4. the viewer on view renders from tf -------------------------------------------------------------
    if not wait_for(lambda: glob.glob(os.path.join(args.view_dir, "*_000001.png")), 10.0):
        fail("telesim_view on the view host wrote no image into %s" % args.view_dir)
    say("telesim_view on the view host rendered the scene from tf")
    rospy.signal_shutdown("done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
