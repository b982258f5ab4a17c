#!/usr/bin/env bash
# Set-up shared by run.sh and test.sh: install the Debian packages that are missing, the web page's npm packages,
# then build ./build, saying which stage it is in and how far the build has come (the compiler's output goes to
# build.log).
#
#   bash scripts/setup.sh [--tests]
#     --tests   also build the tests (add_rostest_gtest targets are not built by default)
# Exit status (doc/exit-codes.md): 0 built, 1 a stage failed (the end of its log is printed), 2 usage.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
usage="usage: bash scripts/setup.sh [--tests]   (install what is missing, build ./build; --tests: the tests too)"
with_tests=0
while (($#)); do
  case "$1" in
    -h|--help) echo "$usage"; echo "exit: 0 built, 1 a stage failed, 2 usage"; exit 0 ;;
    --tests) with_tests=1; shift ;;
    *) echo "setup.sh: unknown argument '$1'" >&2; echo "$usage" >&2; exit 2 ;;
  esac
done
log="$repo/build.log"
sudo=""
[[ $(id -u) -eq 0 ]] || sudo=sudo

missing=()
while read -r package; do
  [[ -z "$package" || "$package" == \#* ]] && continue
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done < "$repo/scripts/debian-packages.txt"
if ((${#missing[@]})); then
  echo "setup: [1/3] installing ${#missing[@]} Debian packages (about a minute): ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
else
  echo "setup: [1/3] the Debian packages are installed"
fi

# The browser viewer's npm packages (web/package-lock.json: three.js for the page, playwright-core for its test),
# installed exactly as locked. Debian's nodejs may come without npm: then Debian's npm package.
if [[ ! -d "$repo/web/node_modules/three" || ! -d "$repo/web/node_modules/playwright-core" ||
      ! -d "$repo/web/node_modules/puppeteer-core" ]]; then
  if ! command -v npm >/dev/null; then
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq npm >/dev/null
  fi
  echo "setup: [2/3] npm ci in web/ (log: web/npm.log)"
  (cd "$repo/web" && npm ci --no-audit --no-fund >"$repo/web/npm.log" 2>&1) || { cat "$repo/web/npm.log"; exit 1; }
else
  echo "setup: [2/3] the web page's npm packages are installed"
fi

# One line per tenth of the build (make's "[ 37%]" markers), the compiler's output into build.log.
build() {
  local what=$1 last=-10 line percent
  shift
  cmake --build "$repo/build" -j"$(nproc)" "$@" 2>&1 | tee -a "$log" | while IFS= read -r line; do
    if [[ $line =~ ^\[\ *([0-9]+)%\] ]]; then
      percent=$((BASH_REMATCH[1] / 10 * 10))
      if ((percent > last)); then
        last=$percent
        echo "setup: [3/3] building $what: $percent %"
      fi
    fi
  done
}

echo "setup: [3/3] configuring and building into build/ (the first build takes about 10 minutes; log: build.log)"
# catkin snapshots the devel space's environment at configure time (build/catkin_generated/setup_cached.sh, which
# every ctest entry runs under) and leaves out directories that do not exist yet: on a fresh clone PYTHONPATH came
# out empty and web_bridge.test's Python could not import the package's messages. So they exist before it looks.
mkdir -p "$repo/build/devel/lib/python3/dist-packages" "$repo/build/devel/lib/pkgconfig"
# ROS's tools live in /usr/bin/python3; a python3 earlier on the PATH (pyenv) lacks catkin_pkg. A configured build
# is only built: cmake configures it again by itself when a CMakeLists.txt changed.
if [[ ! -f "$repo/build/CMakeCache.txt" || ! -f "$repo/build/Makefile" ]]; then
  cmake -S "$repo" -B "$repo/build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 >"$log" 2>&1 ||
    { tail -50 "$log"; echo "setup: configuring failed (log: build.log)" >&2; exit 1; }
else
  : >"$log"
fi
build "the package" || { tail -50 "$log"; echo "setup: the build failed (log: build.log)" >&2; exit 1; }
if ((with_tests)); then
  # add_rostest_gtest targets are EXCLUDE_FROM_ALL: they are built by the 'tests' target.
  build "the tests" --target tests || { tail -50 "$log"; echo "setup: building the tests failed (log: build.log)" >&2; exit 1; }
fi
echo "setup: built into $repo/build (log: build.log)"
