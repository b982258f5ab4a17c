#!/usr/bin/python3
"""Group `perf report --sort comm,dso` lines into what the loop does (bench/run_loop_profile.sh)."""
import re
import sys

GROUPS = [
    ("physics (ODE)", r"libode"),
    ("rendering and vision (OpenCV, our renderer)", r"libopencv_(imgproc|core|imgcodecs)|libxpersif_render|libxpersif_perception"),
    ("learning (OpenCV ml, our learner)", r"libopencv_ml|libxpersif_learning"),
    ("knowledge base (SQLite)", r"libsqlite|libxpersif_kb"),
    ("messaging (roscpp, serialization, sockets, kernel)", r"libroscpp|librosconsole|libxmlrpc|libcpp_common|librostime|\[kernel|libboost|libbondcpp|libnodelet|libactionlib"),
    ("python (roslaunch, rosout, tools)", r"python"),
    ("idle (swapper)", r"^swapper$"),
    ("C/C++ runtime (malloc, memcpy, libstdc++)", r"libc\.so|libc-|libstdc\+\+|libm\.|ld-linux|libpthread|libgcc"),
    ("our other code", r"libxpersif|xpersif"),
]


def main():
    totals = {}
    for line in open(sys.argv[1]):
        m = re.match(r"\s*([\d.]+)%\s+(\S.*?)\s{2,}(\S.*)$", line)
        if not m:
            continue
        percent, comm, dso = float(m.group(1)), m.group(2).strip(), m.group(3)
        if comm == "swapper":
            group = "idle (swapper)"
        elif comm.startswith("python") or "ros" in comm and "xpersif" not in comm and comm.startswith("ros"):
            group = "python (roslaunch, rosout, tools)"
        else:
            group = next((name for name, pattern in GROUPS if re.search(pattern, dso)), "other")
        totals[group] = totals.get(group, 0.0) + percent
    print("--- by activity (% of both cores' time) ---")
    for name, percent in sorted(totals.items(), key=lambda kv: -kv[1]):
        print(f"{percent:6.1f} %  {name}")


if __name__ == "__main__":
    main()
