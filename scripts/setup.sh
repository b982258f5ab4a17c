#!/usr/bin/env bash
# Set-up shared by run.sh and test.sh: install the Debian packages that are missing, then build ./build.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

missing=()
while read -r package; do
  [[ -z "$package" || "$package" == \#* ]] && continue
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done < "$repo/scripts/debian-packages.txt"
if ((${#missing[@]})); then
  echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  sudo=""
  [[ $(id -u) -eq 0 ]] || sudo=sudo
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# The browser viewer's npm packages (web/package-lock.json: three.js for the page, playwright-core for its test),
# installed exactly as locked. Debian's nodejs may come without npm: then Debian's npm package.
if [[ ! -d "$repo/web/node_modules/three" || ! -d "$repo/web/node_modules/playwright-core" ||
      ! -d "$repo/web/node_modules/puppeteer-core" ]]; then
  if ! command -v npm >/dev/null; then
    sudo=""
    [[ $(id -u) -eq 0 ]] || sudo=sudo
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq npm >/dev/null
  fi
  echo "setup: npm ci in web/"
  (cd "$repo/web" && npm ci --no-audit --no-fund >"$repo/web/npm.log" 2>&1) || { cat "$repo/web/npm.log"; exit 1; }
fi

# catkin snapshots the devel space's environment at configure time (build/catkin_generated/setup_cached.sh, which
# every ctest entry runs under) and leaves out directories that do not exist yet: on a fresh clone PYTHONPATH came
# out empty and web_bridge.test's Python could not import the package's messages. So they exist before it looks.
mkdir -p "$repo/build/devel/lib/python3/dist-packages" "$repo/build/devel/lib/pkgconfig"
# ROS's tools live in /usr/bin/python3; a python3 earlier on the PATH (pyenv) lacks catkin_pkg.
cmake -S "$repo" -B "$repo/build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 >"$repo/build.log" 2>&1 ||
  { cat "$repo/build.log"; exit 1; }
cmake --build "$repo/build" -j"$(nproc)" >>"$repo/build.log" 2>&1 || { tail -50 "$repo/build.log"; exit 1; }
echo "setup: built into $repo/build (log: build.log)"
