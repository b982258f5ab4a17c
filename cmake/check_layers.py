#!/usr/bin/python3
"""The layers of src/ and include/xpersif/ run one way: a file may include its own folder's headers and those of
lower layers, never a higher layer's or a peer's. Every quoted #include is checked; exit 0 when every arrow runs
down, 1 naming each one that does not.

usage: check_layers.py SOURCE_DIR
"""
import os
import re
import sys

# The rank of each folder: the core's libraries first (as src/core/CMakeLists.txt links them), then the
# generated messages, the component model, the ROS glue, the components, their nodelet and plugin shells, and
# the executables. A folder not listed here is an error: add it where it belongs.
RANKS = {
    "core/common": 0,
    "core/render": 1, "core/sim": 1, "core/motion": 1, "core/planning": 1, "core/kb": 1, "core/learning": 1,
    "core/web": 1,
    "core/perception": 2, "core/experiment_spec": 2, "core/evaluation": 2,
    "messages": 5,
    "component": 10,
    "ros": 11,
    "xpersim": 20, "camera": 20, "embodiment": 20, "web": 20, "traces": 20, "examples": 20,
    "perception": 21,
    "cognition": 22,
    "decision": 23, "loop": 23,
    "nodelets": 30, "plugins": 30,
    "nodes": 40, "tools": 40,
}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def folder_of_file(rel):
    """The layer folder of a file under src/ or include/xpersif/."""
    parts = rel.split("/")
    parts = parts[2:] if parts[0] == "include" else parts[1:]
    if len(parts) < 2:
        return None
    return "core/" + parts[1] if parts[0] == "core" and len(parts) > 2 else parts[0]


def folder_of_include(name, own):
    parts = name.split("/")
    if parts[0] != "xpersif":
        return own  # a header beside the file (its own folder)
    if len(parts) == 2:
        return "messages"  # xpersif/Foo.h: generated from msg/, srv/, action/
    if parts[1] == "core" and len(parts) > 3:
        return "core/" + parts[2]
    return parts[1]


def main(argv):
    if len(argv) != 2:
        print("usage: check_layers.py SOURCE_DIR", file=sys.stderr)
        return 2
    root = argv[1]
    problems, files = [], 0
    for top in ("src", os.path.join("include", "xpersif")):
        for dirpath, _, names in os.walk(os.path.join(root, top)):
            for name in sorted(names):
                if not name.endswith((".h", ".hpp", ".cpp")):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, root)
                own = folder_of_file(rel)
                if own is None:
                    continue
                files += 1
                if own not in RANKS:
                    problems.append("%s: its folder '%s' has no layer in cmake/check_layers.py" % (rel, own))
                    continue
                with open(path, encoding="utf-8", errors="replace") as f:
                    for number, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        target = folder_of_include(m.group(1), own)
                        if target == own:
                            continue
                        if target not in RANKS:
                            problems.append("%s:%d includes %s, of a folder with no layer" % (rel, number, m.group(1)))
                        elif RANKS[target] >= RANKS[own]:
                            kind = "a peer" if RANKS[target] == RANKS[own] else "a higher layer"
                            problems.append("%s:%d includes %s: '%s' may not include '%s', %s" %
                                            (rel, number, m.group(1), own, target, kind))
    if files == 0:
        print("check_layers: no sources under %s" % root, file=sys.stderr)
        return 1
    for p in problems:
        print("layers: " + p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
