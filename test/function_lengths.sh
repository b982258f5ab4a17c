#!/usr/bin/env bash
# No function in src/ longer than the limit (default 120 lines), measured by universal-ctags from each function's
# first line to its last: a long procedure is split into named steps that read as what they do (doc/development.md).
# usage: function_lengths.sh SOURCE_DIR [LIMIT]
set -euo pipefail
src=$1 limit=${2:-120}
command -v ctags >/dev/null || { echo "function_lengths: ctags (Debian's universal-ctags) is not installed" >&2; exit 1; }
long=$(ctags -R --languages=C++ --kinds-C++=f --fields=+ne -o - "$src/src" |
  awk -F'\t' -v limit="$limit" '{ l = ""; e = ""
      for (i = 4; i <= NF; i++) { if ($i ~ /^line:/) l = substr($i, 6); if ($i ~ /^end:/) e = substr($i, 5) }
      if (l != "" && e != "" && e - l + 1 > limit) print e - l + 1 " lines: " $2 ":" l " " $1 }' | sort -rn)
if [[ -n "$long" ]]; then
  echo "function_lengths: functions over $limit lines (split each into named steps):" >&2
  echo "$long" >&2
  exit 1
fi
count=$(ctags -R --languages=C++ --kinds-C++=f -o - "$src/src" | wc -l)
echo "function_lengths: all $count functions in src/ are at most $limit lines"
