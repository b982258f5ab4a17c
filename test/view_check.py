#!/usr/bin/python3
"""Helpers of test/rviz_main_screenshot.sh (run with /usr/bin/python3, which has rospy).

  view_check.py topics RVIZ_CONFIG          every absolute topic of the rviz config is advertised, its
                                            robot description parameter is set
  view_check.py camera                      the first camera fixed to the world (for telesim_view)
  view_check.py scale                       px/m of a top-down view that shows the whole arena
  view_check.py shot OUT.json SHOT.png      once a run is experimenting, pause XPERSim, screenshot the display
                                            (SHOT.png "-": none), keep ground truth + scene + the loop's experiment
  view_check.py rviz OUT.json SHOT.png      each body's colour near its ground-truth pose in the top-down shot,
                                            and the loop's text over the arena true to the run (no placeholder,
                                            no surprise before the run's first experiment)
  view_check.py telesim OUT.json IMAGE.png CAMERA [LABEL]
                                            the same in an image rendered through that scene camera (telesim_view's,
                                            or the web page's view of it)

Nothing is hard-coded about the world: objects, colours, the robot and the arena come from XPERSim's scene.
"""
import json
import math
import os
import re
import subprocess
import sys
import time

NS = "/xpersif"


def scene_msg():
    import rospy
    from xpersif.msg import Scene
    rospy.init_node("view_check", anonymous=True, disable_signals=True)
    return rospy.wait_for_message(NS + "/xpersim/scene", Scene, timeout=30)


def quat_yaw(q):
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def read_png(path):
    size = subprocess.check_output(["/usr/bin/identify", "-format", "%w %h", path]).decode().split()
    w, h = int(size[0]), int(size[1])
    raw = subprocess.check_output(["/usr/bin/convert", path, "-depth", "8", "rgb:-"])
    return w, h, raw


def like(pixel, colour, lo=0.5, hi=1.5):
    """The pixel shows this colour under some lighting: the same direction in RGB, a brightness in lo..hi."""
    e = [255 * c for c in colour]
    ee = sum(c * c for c in e)
    if ee < 1:
        return sum(pixel) < 60
    k = sum(p * c for p, c in zip(pixel, e)) / ee
    if not lo <= k <= hi:
        return False
    err = math.sqrt(sum((p - k * c) ** 2 for p, c in zip(pixel, e)))
    return err < 0.12 * k * math.sqrt(ee)


def topics(config):
    import rospy
    import yaml
    rospy.init_node("view_check", anonymous=True, disable_signals=True)
    cfg = yaml.safe_load(open(config))
    names, params = [], []

    def walk(node):
        if isinstance(node, dict):
            for k, v in node.items():
                if k.endswith("Topic") and isinstance(v, str):
                    names.append(v)
                elif k == "Robot Description":
                    params.append(v)
                else:
                    walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)
    walk(cfg)
    deadline = time.time() + 30
    while True:
        published = {t for t, _ in rospy.get_published_topics()}
        missing = [t for t in names if t.startswith("/") and t not in published]
        missing += ["param " + p for p in params if not rospy.has_param(p)]
        if not missing or time.time() > deadline:
            break
        time.sleep(1)
    print("rviz config %s: topics %s, robot description %s" % (config, names, params))
    if missing:
        print("FAIL: not on the master: %s" % missing)
        sys.exit(1)


def camera():
    scene = scene_msg()
    parents = {n.name: n.parent for n in scene.nodes}
    for c in scene.cameras:
        if parents.get(c.frame) == scene.world_frame:
            print(c.name)
            return
    sys.exit("the scene has no camera fixed to the world")


def scale():
    """Pixels per metre for the top-down view that fits this world's arena into rviz's 3D view (~800 x 700)."""
    scene = scene_msg()
    floor = next(n for n in scene.nodes if n.name == "arena").visuals[0].box_size
    print(int(min(600, 700 / floor.x, 500 / floor.y)))


def shot(out, png):
    import rospy
    from std_srvs.srv import Trigger
    from xpersif.msg import BodyPoses
    scene = scene_msg()
    latest = []
    sub = rospy.Subscriber(NS + "/xpersim/ground_truth", BodyPoses, lambda m: latest.append(m), queue_size=5)
    rospy.wait_for_service(NS + "/xpersim/pause", timeout=10)
    deadline = time.time() + 20
    while not latest and time.time() < deadline:
        time.sleep(0.1)
    # During a run: as soon as LOOPMODEL reports an experiment under way (the robot on its way to it).
    from xpersif.msg import RunLoopFeedback
    state, experiment = [], []

    def on_progress(m):
        state.append(m.state)
        experiment.append(m.experiment)
    rospy.Subscriber(NS + "/loop_model/progress", RunLoopFeedback, on_progress, queue_size=10)
    deadline = time.time() + 90
    # XPERSIF_SHOT_EXPERIMENT: wait for that experiment number too (a panel that shows it is then not a default).
    at_least = int(os.environ.get("XPERSIF_SHOT_EXPERIMENT", "0"))
    while (not state or state[-1] != "experimenting" or experiment[-1] < at_least) and time.time() < deadline:
        time.sleep(0.05)
    print("loop:", state[-1] if state else "no progress")
    print("pause:", rospy.ServiceProxy(NS + "/xpersim/pause", Trigger)().message)
    time.sleep(4)  # the last frame reaches every viewer; software GL renders it
    sub.unregister()
    truth = latest[-1]
    overlay = overlay_now(state[-1] if state else "")
    if png != "-":
        subprocess.check_call(["/usr/bin/import", "-window", "root", png])
    bodies = {}
    for name, pose in zip(truth.names, truth.poses):
        bodies[name] = [pose.position.x, pose.position.y, pose.position.z, quat_yaw(pose.orientation)]
    nodes = {n.name: n for n in scene.nodes}
    colours, radii = {}, {}
    for name in truth.names:
        node = nodes.get(name if name in scene.objects else scene.robot_root)
        v = node.visuals[0]
        colours[name] = [v.color.r, v.color.g, v.color.b]
        size = v.box_size  # a box's half diagonal, else the radius (both fields are always filled)
        radii[name] = math.hypot(size.x, size.y) / 2 if v.type == v.BOX else v.radius
    arena = nodes["arena"].visuals
    json.dump({"time": truth.header.stamp.to_sec(), "experiment": experiment[-1] if experiment else None,
               "overlay": overlay,
               "bodies": bodies, "colours": colours, "radii": radii,
               "robot": [n for n in truth.names if n not in scene.objects],
               "arena": [scene.arena_size_x, scene.arena_size_y],
               "floor": {"size": [arena[0].box_size.x, arena[0].box_size.y],
                         "colours": [[v.color.r, v.color.g, v.color.b] for v in arena]},
               "cameras": [{"name": c.name, "frame": c.frame, "fx": c.fx, "fy": c.fy, "cx": c.cx, "cy": c.cy}
                           for c in scene.cameras],
               "frames": {n.name: [n.parent, [n.transform.translation.x, n.transform.translation.y,
                                              n.transform.translation.z],
                                   [n.transform.rotation.x, n.transform.rotation.y, n.transform.rotation.z,
                                    n.transform.rotation.w]] for n in scene.nodes}}, open(out, "w"), indent=1)
    print("ground truth at t=%.3f: %s" % (truth.header.stamp.to_sec(),
                                          {k: [round(c, 3) for c in v[:2]] for k, v in bodies.items()}))


def overlay_now(loop_state):
    """The text a viewer's rviz shows over the arena (progress_markers' latched markers), with LOOPMODEL's state
    (as shot() last heard it) and how many experiments of the run MOTIVATION had heard of when it was drawn."""
    import rospy
    from visualization_msgs.msg import MarkerArray
    from xpersif.msg import Motivation
    topics = [t for t, _ in rospy.get_published_topics() if t.endswith("/progress_markers/markers")]
    if not topics:
        return None
    markers = rospy.wait_for_message(topics[0], MarkerArray, timeout=10)
    motivation = rospy.wait_for_message(NS + "/motivation/motivation", Motivation, timeout=10)
    return {"lines": [m.text for m in sorted(markers.markers, key=lambda m: m.id) if m.action == m.ADD],
            "experiments_heard": motivation.experiments, "loop_state": loop_state}


def check_overlay(data):
    """The overlay says what it knows and nothing it does not: LOOPMODEL's state, no placeholder, no surprise
    before the run's first experiment."""
    overlay = data.get("overlay")
    if not overlay or not overlay["lines"]:
        print("overlay: no progress text in the view")
        return ["overlay"]
    for line in overlay["lines"]:
        print("overlay: %s" % line)
    failures = []
    if not overlay["lines"][0].startswith("loop: %s " % overlay["loop_state"]):
        failures.append("overlay's loop state (LOOPMODEL's is %s)" % overlay["loop_state"])
    if "?" in " ".join(overlay["lines"]):
        failures.append("overlay's placeholder")
    claims_surprise = any(re.search(r"surprise [0-9]", line) for line in overlay["lines"])
    if claims_surprise != (overlay["experiments_heard"] > 0):
        failures.append("overlay's surprise after %d experiments" % overlay["experiments_heard"])
    return failures


def check_bodies(data, w, h, raw, project, px_per_m, where):
    failures = []
    for name, (x, y, z, _) in data["bodies"].items():
        u0, v0 = project(x, y, z)
        colour = data["colours"][name]
        r = int(data["radii"][name] * px_per_m) + 4
        xs = ys = n = 0
        for v in range(max(0, int(v0) - r), min(h, int(v0) + r + 1)):
            for u in range(max(0, int(u0) - r), min(w, int(u0) + r + 1)):
                i = 3 * (v * w + u)
                if like(raw[i:i + 3], colour):
                    xs += u
                    ys += v
                    n += 1
        area = math.pi * (data["radii"][name] * px_per_m) ** 2 / 2  # a box's footprint is ~2/pi of its circle
        found = "nothing"
        ok = n >= 0.25 * area
        if n:
            du, dv = xs / n - u0, ys / n - v0
            found = "%d px, centroid off by (%.1f, %.1f) px" % (n, du, dv)
            ok = ok and math.hypot(du, dv) <= 0.3 * data["radii"][name] * px_per_m + 2
        print("%s: %-12s colour %s at (%.3f, %.3f) -> pixel (%.0f, %.0f): %s %s" % (
            where, name, [round(c, 2) for c in colour], x, y, u0, v0, found, "ok" if ok else "MISSING"))
        if not ok:
            failures.append(name)
    return failures


def check_rviz(data_path, png):
    data = json.load(open(data_path))
    w, h, raw = read_png(png)
    # The 3D view: the box around rviz's background colour (the test config's 48; 48; 48), not the panels.
    back_rows, back_cols = [0] * h, [0] * w
    for v in range(0, h, 2):
        for u in range(0, w, 2):
            if all(abs(c - 48) <= 8 for c in raw[3 * (v * w + u):3 * (v * w + u) + 3]):
                back_rows[v] += 1
                back_cols[u] += 1
    if not max(back_rows):
        print("FAIL: no rviz 3D view in the screenshot")
        return 1
    # Rows and columns that are mostly background: text in the panels does not count.
    rows = [v for v in range(h) if back_rows[v] >= 0.3 * max(back_rows)]
    cols = [u for u in range(w) if back_cols[u] >= 0.3 * max(back_cols)]
    u_lo, u_hi, v_lo, v_hi = cols[0], cols[-1], rows[0], rows[-1]
    # Calibrate the top-down view on the arena: rows and columns that are mostly floor or wall colour.
    arena_colours = data["floor"]["colours"]
    mask_rows, mask_cols = [0] * h, [0] * w
    for v in range(v_lo, v_hi, 2):
        for u in range(u_lo, u_hi, 2):
            i = 3 * (v * w + u)
            if any(like(raw[i:i + 3], c, 0.8, 1.25) for c in arena_colours):  # not the grid's faint lines
                for dv in (0, 1):
                    mask_rows[min(h - 1, v + dv)] += 1
                for du in (0, 1):
                    mask_cols[min(w - 1, u + du)] += 1
    rows = [v for v in range(h) if mask_rows[v] >= 0.5 * max(mask_rows)]
    cols = [u for u in range(w) if mask_cols[u] >= 0.5 * max(mask_cols)]
    if not rows or not cols:
        print("FAIL: no arena in the screenshot")
        return 1
    fx, fy = data["floor"]["size"]
    sx = (cols[-1] - cols[0] + 1) / fx
    sy = (rows[-1] - rows[0] + 1) / fy
    cu, cv = (cols[0] + cols[-1]) / 2, (rows[0] + rows[-1]) / 2
    print("rviz %dx%d: 3D view %d..%d x %d..%d px, arena %d..%d x %d..%d px, %.0f x %.0f px/m, centre (%.0f, %.0f)" % (
        w, h, u_lo, u_hi, v_lo, v_hi, cols[0], cols[-1], rows[0], rows[-1], sx, sy, cu, cv))
    if abs(sx - sy) > 0.05 * sx:
        print("FAIL: the arena is not where a top-down view puts it (%.0f vs %.0f px/m)" % (sx, sy))
        return 1
    failures = check_bodies(data, w, h, raw, lambda x, y, z: (cu + sx * x, cv - sy * y), sx, "rviz")
    overlay = check_overlay(data)
    if overlay:
        print("FAIL: the loop's text over the arena: %s" % ", ".join(overlay))
    return max(report(failures), 1 if overlay else 0)


def transform_point(data, frame, p):
    """world_from_frame applied to p, following the scene's parents."""
    while frame in data["frames"]:
        parent, t, (x, y, z, w) = data["frames"][frame]
        r = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
             [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
             [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
        p = [sum(r[i][j] * p[j] for j in range(3)) + t[i] for i in range(3)]
        frame = parent
    return p


def check_telesim(data_path, png, camera_name, where="telesim"):
    data = json.load(open(data_path))
    w, h, raw = read_png(png)
    cam = next(c for c in data["cameras"] if c["name"] == camera_name)
    origin = transform_point(data, cam["frame"], [0, 0, 0])
    ex = [a - b for a, b in zip(transform_point(data, cam["frame"], [1, 0, 0]), origin)]
    ey = [a - b for a, b in zip(transform_point(data, cam["frame"], [0, 1, 0]), origin)]
    ez = [a - b for a, b in zip(transform_point(data, cam["frame"], [0, 0, 1]), origin)]

    def project(x, y, z):
        d = [x - origin[0], y - origin[1], z - origin[2]]
        cx, cy, cz = (sum(a * b for a, b in zip(d, e)) for e in (ex, ey, ez))
        return cam["fx"] * cx / cz + cam["cx"], cam["fy"] * cy / cz + cam["cy"]
    print("%s %s %dx%d, camera at (%.2f, %.2f, %.2f)" % (where, camera_name, w, h, *origin))
    scale = cam["fx"] / max(0.1, origin[2])
    return report(check_bodies(data, w, h, raw, project, scale, where))


def report(failures):
    if failures:
        print("FAIL: not where ground truth says: %s" % ", ".join(failures))
        return 1
    return 0


if __name__ == "__main__":
    command = sys.argv[1]
    if command == "topics":
        topics(sys.argv[2])
    elif command == "camera":
        camera()
    elif command == "scale":
        scale()
    elif command == "shot":
        shot(sys.argv[2], sys.argv[3])
    elif command == "rviz":
        sys.exit(check_rviz(sys.argv[2], sys.argv[3]))
    elif command == "telesim":
        sys.exit(check_telesim(*sys.argv[2:6]))
    else:
        sys.exit(__doc__)
