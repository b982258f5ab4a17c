#!/usr/bin/env bash
# The build's structural rules, and proof that each check can fail:
#  1. the ROS-free core read no ROS header (cmake/check_core_includes.py on the core targets' dependency files;
#     the build runs it too), and the check refuses a probe that includes one;
#  2. the layers of src/ run one way (cmake/check_layers.py), and the check refuses a copy of the tree with one
#     include that runs back up;
#  3. every "@file NAME" comment names its own file.
# usage: core_checks.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$1 build=$2
devel=$build/devel
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "core_checks: $*" >&2; exit 1; }

core_dirs=()
for dir in "$build"/src/core/CMakeFiles/*.dir; do core_dirs+=("$dir"); done
((${#core_dirs[@]} >= 10)) || fail "expected the core's libraries under $build/src/core/CMakeFiles, found ${#core_dirs[@]}"
python3 "$src/cmake/check_core_includes.py" "$src" "$devel" "${core_dirs[@]}" || fail "the core read a ROS header"
echo "core_checks: ${#core_dirs[@]} core libraries read no ROS header"

# A probe translation unit that includes a ROS header, compiled the way the build compiles the core (-MD).
mkdir -p "$tmp/probe.dir"
printf '#include <ros/time.h>\nint probe() { return ros::Time(1.0).sec; }\n' >"$tmp/probe.cpp"
g++ -std=c++17 -I"$src/include" -MD -MF "$tmp/probe.dir/probe.cpp.o.d" -c "$tmp/probe.cpp" -o "$tmp/probe.dir/probe.o"
if out=$(python3 "$src/cmake/check_core_includes.py" "$src" "$devel" "$tmp/probe.dir" 2>&1); then
  fail "the check accepted a probe that includes <ros/time.h>"
fi
grep -q "a header of the ROS package" <<<"$out" || fail "the check's refusal did not name the ROS package: $out"
echo "core_checks: a probe that includes <ros/time.h> is refused: $out"

# A clean probe (a core header and the C++ library) passes.
rm -rf "$tmp/probe.dir" && mkdir -p "$tmp/probe.dir"
printf '#include "xpersif/core/common/validation.h"\n#include <vector>\nint probe() { return 1; }\n' >"$tmp/probe.cpp"
g++ -std=c++17 -I"$src/include" -MD -MF "$tmp/probe.dir/probe.cpp.o.d" -c "$tmp/probe.cpp" -o "$tmp/probe.dir/probe.o"
python3 "$src/cmake/check_core_includes.py" "$src" "$devel" "$tmp/probe.dir" || fail "the check refused a clean probe"

python3 "$src/cmake/check_layers.py" "$src" || fail "an include runs back up the layers"
echo "core_checks: every include in src/ runs down the layers"
mkdir -p "$tmp/tree"
cp -r "$src/src" "$src/include" "$tmp/tree/"
victim=$(ls "$tmp/tree/src/core/common/"*.cpp | head -n 1)
sed -i '1i #include "xpersif/loop/loop_model.h"' "$victim"
if out=$(python3 "$src/cmake/check_layers.py" "$tmp/tree" 2>&1); then
  fail "the layer check accepted a core file that includes LOOPMODEL's header"
fi
grep -q "a higher layer" <<<"$out" || fail "the layer check's refusal did not say why: $out"
echo "core_checks: a core file that includes LOOPMODEL's header is refused: $out"

# 3. A file's "@file NAME" is its own name (files were renamed and moved when the core got its folders).
misnamed() {  # misnamed DIR...: the files under DIR whose @file names another file
  local f named
  while IFS= read -r f; do
    named=$(grep -m1 -o '@file [^ ]*' "$f" | cut -d' ' -f2 || true)
    [[ -z "$named" || "$named" == "$(basename "$f")" ]] || echo "${f#"$src"/} (says $named)"
  done < <(find "$@" -name '*.h' -o -name '*.cpp')
}
wrong=$(misnamed "$src/src" "$src/include")
[[ -z "$wrong" ]] || fail "a file's @file names another file: $wrong"
printf '/**\n * @file other.h\n */\n' >"$tmp/tree/src/core/common/probe_name.h"
[[ -n "$(misnamed "$tmp/tree/src/core/common")" ]] || fail "the @file check accepted probe_name.h saying other.h"
echo "core_checks: every @file names its own file (a probe that names another is refused)"
