#!/usr/bin/python3
"""The ROS-free core, checked on what the compiler actually read.

For every object file of the given core targets, the compiler's dependency file (.o.d, written by -MD) lists
every header the translation unit included, directly or not. A core translation unit may read the C++ library,
third-party libraries and the core's own headers (include/xpersif/core, src/core); it may not read a ROS
package's header (P/include/X/... where P/share/X/package.xml exists: how catkin installs a package, in /usr on
Debian as in /opt/ros), this package's generated messages (the devel space's include/), or a header of the
package's ROS layers (include/xpersif/<not core>). Exit 0 when clean, 1 naming each offending include.

usage: check_core_includes.py SOURCE_DIR DEVEL_PREFIX TARGET_DIR...
"""
import os
import sys


def dependencies(depfile):
    with open(depfile, encoding="utf-8", errors="replace") as f:
        text = f.read().replace("\\\n", " ")
    target, _, deps = text.partition(": ")
    # Paths with spaces are escaped as '\ '; none of ours has one, so a plain split is enough.
    return target.strip(), [d for d in deps.split() if d]


_ros_package_cache = {}


def ros_package_of(header):
    """The ROS package whose include directory holds header, or None."""
    parts = os.path.normpath(header).split(os.sep)
    for i in range(len(parts) - 2, 0, -1):
        if parts[i] != "include":
            continue
        prefix = os.sep.join(parts[:i]) or os.sep
        package = parts[i + 1]
        key = (prefix, package)
        if key not in _ros_package_cache:
            # include/ros/ is shared by roscpp, rostime and cpp_common; every other package has a folder of its own.
            owners = ("roscpp", "rostime", "cpp_common") if package == "ros" else (package,)
            _ros_package_cache[key] = any(os.path.isfile(os.path.join(prefix, "share", owner, "package.xml"))
                                          for owner in owners)
        if _ros_package_cache[key]:
            return package
    return None


def offence(header, source_dir, devel_prefix):
    header = os.path.normpath(header)
    own_include = os.path.join(source_dir, "include", "xpersif") + os.sep
    if header.startswith(os.path.join(devel_prefix, "include") + os.sep):
        return "a generated ROS message header"
    if header.startswith(own_include):
        rest = header[len(own_include):]
        if not rest.startswith("core" + os.sep):
            return "a header of the package's ROS layers (include/xpersif/%s)" % rest.split(os.sep)[0]
        return None
    if header.startswith(os.path.join(source_dir, "src") + os.sep):
        if not header.startswith(os.path.join(source_dir, "src", "core") + os.sep):
            return "a source of the package's ROS layers"
        return None
    package = ros_package_of(header)
    if package:
        return "a header of the ROS package '%s'" % package
    return None


def main(argv):
    if len(argv) < 4:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    source_dir, devel_prefix = os.path.realpath(argv[1]), os.path.realpath(argv[2])
    problems, seen = [], 0
    for target_dir in argv[3:]:
        for root, _, files in os.walk(target_dir):
            for name in files:
                if not name.endswith(".o.d"):
                    continue
                seen += 1
                _, deps = dependencies(os.path.join(root, name))
                source = os.path.relpath(os.path.realpath(deps[0]), source_dir) if deps else name
                offences = [(h, offence(os.path.realpath(h), source_dir, devel_prefix)) for h in deps[1:]]
                offences = [(h, why) for h, why in offences if why]
                if offences:
                    # Dependency files list headers in the order they were read: the first is the one to remove.
                    header, why = offences[0]
                    more = " (and %d more headers through it)" % (len(offences) - 1) if len(offences) > 1 else ""
                    problems.append("%s reads %s, %s%s" % (source, header, why, more))
    if seen == 0:
        print("check_core_includes: no dependency files under %s (was the core built with -MD?)"
              % " ".join(argv[3:]), file=sys.stderr)
        return 1
    for p in problems:
        print("the core must be ROS-free: " + p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
