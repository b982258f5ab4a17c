#!/usr/bin/env bash
# One convention for every executable we ship (doc/exit-codes.md), checked on the list the build made, not on a
# list kept by hand: every xpersif and xpersif_* program in the devel space, every xpersif subcommand (from
# `xpersif --help`), every scripts/*.sh and scripts/xpersif_record:
#   --help and -h print a usage that lists the exit codes on stdout and exit 0;
#   a bad argument prints a sentence naming the tool, then the usage, on stderr, and exits 2.
# And sourcing scripts/env.sh with arguments never hands them to catkin's setup.
#   bash test/tools_help.sh BUILD_DIR
set -uo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$repo/build}
bin=$build/devel/lib/xpersif
export PATH="/usr/bin:$PATH" XPERSIF_SKIP_SETUP=1  # study.sh: no build for a usage
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=() checked=0

# expect NAME COMMAND...: the help and bad-argument conventions for one executable.
expect() {
  local name=$1
  shift
  local flag code
  for flag in --help -h; do
    "$@" "$flag" >"$tmp/out" 2>"$tmp/err"
    code=$?
    ((code == 0)) || failures+=("$name $flag: exit $code, not 0: $(head -2 "$tmp/err" | tr '\n' ' ')")
    grep -qi "usage" "$tmp/out" || failures+=("$name $flag: no usage on stdout")
    grep -qi "exit" "$tmp/out" || failures+=("$name $flag: the usage lists no exit codes")
  done
  "$@" --no-such-option-xyz >"$tmp/out" 2>"$tmp/err" </dev/null
  code=$?
  ((code == 2)) || failures+=("$name --no-such-option-xyz: exit $code, not 2")
  grep -q -- "no-such-option-xyz" "$tmp/err" || failures+=("$name --no-such-option-xyz: the sentence does not name the option: $(head -1 "$tmp/err")")
  grep -qi "usage" "$tmp/err" || failures+=("$name --no-such-option-xyz: no usage after the sentence")
  checked=$((checked + 1))
}

programs=$(find "$bin" -maxdepth 1 -type f -perm -u+x \( -name xpersif -o -name 'xpersif_*' \) | sort)
[[ -n "$programs" ]] || { echo "tools_help: no xpersif programs in $bin" >&2; exit 1; }
for program in $programs; do expect "$(basename "$program")" "$program"; done

subcommands=$("$bin/xpersif" --help | awk '/^Subcommands:/ { on = 1; next } on && /^  [a-z]/ { print $1 } on && /^$/ { exit }')
[[ $(wc -w <<<"$subcommands") -ge 10 ]] || failures+=("xpersif --help lists too few subcommands: $subcommands")
for sub in $subcommands; do expect "xpersif $sub" "$bin/xpersif" "$sub"; done

for script in "$repo"/scripts/*.sh "$repo/scripts/xpersif_record"; do
  case "$(basename "$script")" in
    env.sh) continue ;;  # sourced, takes no arguments: checked below
    test.sh)
      # Its arguments are ctest's (a bad one is ctest's to refuse, after the build): only the help here.
      bash "$script" --help >"$tmp/out" 2>&1 && grep -qi usage "$tmp/out" && grep -qi exit "$tmp/out" ||
        failures+=("test.sh --help: $(head -2 "$tmp/out" | tr '\n' ' ')")
      checked=$((checked + 1))
      continue ;;
  esac
  expect "scripts/$(basename "$script")" bash "$script"
done

# env.sh sourced by a script that was given arguments: catkin's _setup_util.py must not see them.
out=$(env -i HOME="$HOME" PATH=/usr/bin:/bin bash -c 'repo=$1; set -- --help --bogus; source "$repo/scripts/env.sh" && echo "sourced: $ROS_PACKAGE_PATH"' _ "$repo" 2>&1)
code=$?
{ ((code == 0)) && grep -q "^sourced: " <<<"$out" && ! grep -qi "usage" <<<"$out"; } ||
  failures+=("sourcing env.sh with arguments: exit $code: $(head -3 <<<"$out" | tr '\n' ' ')")

echo "tools_help: $checked executables and subcommands checked"
if ((${#failures[@]})); then
  printf 'FAIL: %s\n' "${failures[@]}" >&2
  exit 1
fi
