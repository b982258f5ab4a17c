#!/usr/bin/python3
"""The documents run as a test: every command block a reader is meant to type, in README.md, test/README.md and
doc/*.md, is run on the built tree, and a command that no longer works fails the suite.

A command block is a ```bash fence. The line before it must be one marker:
  <!-- doc-test: run -->                       run the block from the repository root with `bash -e`, in a fresh
                                               shell (no ROS master of the caller's: each block sources
                                               scripts/env.sh itself when it needs ROS)
  <!-- doc-test: run args="..." -->            the same, with these documented options appended to the block's
                                               first command, to keep its budget small
  <!-- doc-test: skip "REASON; covered by TEST" -->  not run here (several hosts, a display, a cluster...); TEST must
                                               be a test of the suite (ctest -N; NAME also stands for the
                                               parametrised NAME__ARGS)
Every relative link ([text](path)) must lead to a file or directory of the tree.
A run block passes when it exits 0 and every file its output says it wrote ("wrote PATH", "report in PATH",
"written to PATH", absolute paths) exists.
Fences of other kinds (```yaml, ```text, ```cpp...) are not commands; a fence without a language, or in ```sh or
```console, is refused, so that no command block escapes the test. Run blocks share one scratch environment:
XPERSIF_RUN_DIR (run.sh's documented variable) points under a temporary directory, so runs write nothing into the
tree unless a block names a directory itself. XPERSIF_DOC_SCRATCH is that temporary directory, the same for every
block of one run: a marker's args can redirect a block's output there (args="--out $XPERSIF_DOC_SCRATCH/first"),
so that what a developer left in the tree cannot decide whether the block passes.

usage: doc_commands.py [--list] [--only FILE[:LINE]] [--tests FILE | --ctest BUILD_DIR] REPO [MARKDOWN...]
       doc_commands.py --self-test REPO
  --list        print the blocks and their markers, run nothing
  --only        run only the blocks of FILE (or the block at FILE:LINE)
  --tests FILE  the suite's test names, one per line (ctest -N), to check the skip markers' TEST
  --ctest DIR   the same, asked of `ctest --test-dir DIR -N`
exit: 0 every run block passed and every marker is well formed; 1 a block failed or a marker is missing or wrong;
      2 usage
"""
import os
import re
import shlex
import subprocess
import sys
import tempfile
import time

MARKER = re.compile(r'^<!--\s*doc-test:\s*(run|skip)\b(.*?)-->\s*$')
ARGS = re.compile(r'^\s*args="([^"]*)"\s*$')
SKIP = re.compile(r'^\s*"([^"]+)"\s*$')
COVERED = re.compile(r'covered by ([A-Za-z0-9_.\-]+)')
FENCE = re.compile(r'^(\s*)```(.*)$')
REFUSED_LANGUAGES = {"", "sh", "shell", "console", "zsh"}
BLOCK_TIMEOUT = 900  # s; a main job with a small budget takes ~1 min on 2 cores


class Block:
    def __init__(self, path, line, marker, body):
        self.path, self.line, self.marker, self.body = path, line, marker, body  # marker: (kind, argument) or None

    def where(self):
        return "%s:%d" % (self.path, self.line)


def parse(path, text):
    """The ```bash blocks of a Markdown file with their markers, and the sentences for malformed fences."""
    blocks, problems = [], []
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, language = m.group(1), m.group(2).strip()
        start = i
        i += 1
        body = []
        while i < len(lines) and not re.match(r'^\s*```\s*$', lines[i]):
            body.append(lines[i][len(indent):] if lines[i].startswith(indent) else lines[i])
            i += 1
        if i >= len(lines):
            problems.append("%s:%d: a fence that is never closed" % (path, start + 1))
            break
        i += 1
        if language in REFUSED_LANGUAGES:
            problems.append("%s:%d: a fence in '%s': label command blocks ```bash (with a doc-test marker) and "
                            "anything else by its language (```text, ```yaml...)" % (path, start + 1, language or "no language"))
            continue
        if language != "bash":
            continue
        previous = start - 1
        while previous >= 0 and not lines[previous].strip():
            previous -= 1
        marker = None
        if previous >= 0:
            mm = MARKER.match(lines[previous].strip())
            if mm:
                marker = (mm.group(1), mm.group(2).strip())
        blocks.append(Block(path, start + 1, marker, "\n".join(body)))
    return blocks, problems


def check_marker(block, tests):
    """"" when the block's marker is well formed, else the sentence."""
    if block.marker is None:
        return ("%s: a ```bash block without a marker on the line before it (<!-- doc-test: run -->, run args=\"...\" "
                "or skip \"REASON; covered by TEST\")" % block.where())
    kind, argument = block.marker
    if kind == "run":
        if argument and not ARGS.match(argument):
            return "%s: a run marker's only option is args=\"...\", not '%s'" % (block.where(), argument)
        if not [l for l in block.body.split("\n") if l.strip() and not l.strip().startswith("#")]:
            return "%s: a run block without a command" % block.where()
        return ""
    m = SKIP.match(argument)
    if not m:
        return "%s: a skip marker needs its reason in quotes: skip \"REASON; covered by TEST\"" % block.where()
    covered = COVERED.search(m.group(1))
    if not covered:
        return "%s: a skip marker must name the test that covers the block instead (\"...; covered by TEST\")" % block.where()
    name = covered.group(1)
    if tests is not None and name not in tests and not any(t.startswith(name + "__") for t in tests):
        return "%s: the skip marker names '%s', which is not a test of the suite" % (block.where(), name)
    return ""


def script_of(block):
    """The block as a script: the marker's args appended to its first command."""
    lines = block.body.split("\n")
    argument = block.marker[1]
    m = ARGS.match(argument) if argument else None
    if m and m.group(1):
        for n, line in enumerate(lines):
            stripped = line.strip()
            if stripped and not stripped.startswith("#"):
                # A command continued with '\' gets its arguments at the end of the continuation.
                while lines[n].rstrip().endswith("\\") and n + 1 < len(lines):
                    n += 1
                lines[n] = lines[n].rstrip() + " " + m.group(1)
                break
    return "\n".join(lines) + "\n"


def run_block(block, repo, scratch):
    """(passed, seconds, output tail)."""
    env = dict(os.environ)
    for name in ("ROS_MASTER_URI", "ROS_IP", "ROS_HOSTNAME", "XPERSIF_BIND_ADDRESS", "XPERSIF_BIND_ADDRESS_DERIVED",
                 "LD_PRELOAD"):
        env.pop(name, None)  # a reader's fresh shell
    env["XPERSIF_RUN_DIR"] = os.path.join(scratch, "run-%s-%d" % (os.path.basename(block.path), block.line))
    env["XPERSIF_DOC_SCRATCH"] = scratch
    env["ROS_HOME"] = os.path.join(scratch, "ros_home")
    script = os.path.join(scratch, "block.sh")
    with open(script, "w") as f:
        f.write(script_of(block))
    started = time.monotonic()
    try:
        done = subprocess.run(["bash", "-e", script], cwd=repo, env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, timeout=BLOCK_TIMEOUT, start_new_session=True)
        code, output = done.returncode, done.stdout.decode(errors="replace")
    except subprocess.TimeoutExpired as e:
        code, output = None, (e.stdout or b"").decode(errors="replace") + "\n(timed out after %d s)" % BLOCK_TIMEOUT
    seconds = time.monotonic() - started
    tail = "\n".join(output.rstrip().split("\n")[-15:])
    if code == 0:
        missing = missing_outputs(output)
        if missing:  # it said it wrote them: they must be there
            return False, seconds, "it said it wrote %s, which %s not there" % (
                ", ".join(missing), "is" if len(missing) == 1 else "are"), "0, but"
    return code == 0, seconds, tail if code != 0 else "", code


# What the tools print about the files they write: "wrote PATH", "report in PATH", "written to PATH".
WROTE = re.compile(r'(?:\bwrote|\breport in|\bwritten to)\s+(/[^\s:,;()]+)')


def missing_outputs(output):
    """The absolute paths the block's output says were written that do not exist."""
    paths = []
    for path in WROTE.findall(output):
        path = path.rstrip(".")
        if path not in paths and not os.path.exists(path):
            paths.append(path)
    return paths


LINK = re.compile(r'\[[^\]]*\]\(([^)\s]+)\)')


def broken_links(path, shown, text):
    """Sentences for the relative links of a Markdown file whose file is not there (a web address is not checked)."""
    problems = []
    for number, line in enumerate(text.split("\n"), 1):
        for target in LINK.findall(line):
            if re.match(r'^[a-z]+:', target) or target.startswith("#"):
                continue
            where = os.path.normpath(os.path.join(os.path.dirname(path), target.split("#")[0]))
            if not os.path.exists(where):
                problems.append("%s:%d: the link %s leads to nothing (%s)" % (shown, number, target, where))
    return problems


def markdown_files(repo, given):
    if given:
        return given
    files = [os.path.join(repo, "README.md"), os.path.join(repo, "test", "README.md")]
    doc = os.path.join(repo, "doc")
    files += sorted(os.path.join(doc, f) for f in os.listdir(doc) if f.endswith(".md"))
    return files


def test_names(path):
    if not path:
        return None
    names = set()
    with open(path) as f:
        for line in f:
            m = re.match(r'^\s*Test\s+#\d+:\s+(\S+)', line)
            name = m.group(1) if m else line.strip()
            if name:
                names.add(name)
                # rostest entries are _ctest_xpersif_rostest_NAME.test and _ctest_xpersif_gtest_NAME
                short = re.sub(r'^_ctest_xpersif_(rostest|gtest)_', '', name)
                names.add(short)
                names.add(re.sub(r'\.test$', '', short))
    return names


def run_all(repo, files, only, tests, listing):
    problems, results = [], []
    blocks = []
    for path in files:
        with open(path, encoding="utf-8") as f:
            text = f.read()
        found, bad = parse(os.path.relpath(path, repo), text)
        blocks += found
        problems += bad + broken_links(path, os.path.relpath(path, repo), text)
    for block in blocks:
        why = check_marker(block, tests)
        if why:
            problems.append(why)
    if listing:
        for b in blocks:
            print("%s  %s %s" % (b.where(), b.marker[0] if b.marker else "UNMARKED", b.marker[1] if b.marker else ""))
        return problems, results
    selected = [b for b in blocks if b.marker and b.marker[0] == "run" and not check_marker(b, tests)]
    if only:
        selected = [b for b in selected if b.where() == only or b.path == only]
    with tempfile.TemporaryDirectory(prefix="xpersif_doc_commands.") as scratch:
        for block in selected:
            print("doc_commands: running %s ..." % block.where(), flush=True)
            passed, seconds, tail, code = run_block(block, repo, scratch)
            results.append((block, passed, seconds))
            print("doc_commands: %s %s in %.0f s" % (block.where(), "passed" if passed else "FAILED", seconds), flush=True)
            if not passed:
                problems.append("%s: the documented command failed (exit %s):\n%s\n--- its last lines:\n%s" %
                                (block.where(), code, script_of(block).rstrip(), tail))
    return problems, results


def self_test(repo):
    """The test must fail on a broken command, an unmarked block and a skip naming no test."""
    failures = []
    with tempfile.TemporaryDirectory(prefix="xpersif_doc_selftest.") as tmp:
        cases = {
            "broken.md": ('<!-- doc-test: run -->\n```bash\nsource scripts/env.sh\nxpersif_report --no-such-option\n```\n',
                          "the documented command failed"),
            "unmarked.md": ("```bash\ntrue\n```\n", "without a marker"),
            "unlabelled.md": ("```\ntrue\n```\n", "a fence in 'no language'"),
            "skip.md": ('<!-- doc-test: skip "needs a cluster; covered by no_such_test" -->\n```bash\ntrue\n```\n',
                        "not a test of the suite"),
            "link.md": ("See [the guide](doc/no-such-guide.md).\n", "leads to nothing"),
            "liar.md": ('<!-- doc-test: run -->\n```bash\necho "wrote /nonexistent/xpersif/report.md"\n```\n',
                        "which is not there"),
        }
        for name, (text, expected) in cases.items():
            path = os.path.join(tmp, name)
            with open(path, "w") as f:
                f.write(text)
            problems, _ = run_all(repo, [path], None, {"core_checks"}, False)
            if not any(expected in p for p in problems):
                failures.append("%s: expected a problem saying '%s', got %s" % (name, expected, problems or "none"))
        good = os.path.join(tmp, "good.md")
        with open(good, "w") as f:
            f.write('<!-- doc-test: run -->\n```bash\ntest -f package.xml\necho "wrote $PWD/package.xml"\n'
                    'touch "$XPERSIF_DOC_SCRATCH/shared"\n```\n\n'
                    '```yaml\nkey: value\n```\n\n'
                    '<!-- doc-test: run -->\n```bash\ntest -f "$XPERSIF_DOC_SCRATCH/shared"\n```\n')
        problems, results = run_all(repo, [good], None, set(), False)
        if problems or len(results) != 2:
            failures.append("good.md: expected two passing blocks sharing XPERSIF_DOC_SCRATCH and no problem, got %s"
                            % problems)
    for f in failures:
        print("doc_commands self-test: " + f, file=sys.stderr)
    if not failures:
        print("doc_commands self-test: a broken command, a command claiming a file it did not write, a link to "
              "nothing, an unmarked block, an unlabelled fence and a skip naming no test each fail the test; good "
              "blocks pass and share a scratch directory")
    return 1 if failures else 0


def main(argv):
    listing, only, tests_file, self = False, None, None, False
    rest = []
    i = 0
    while i < len(argv):
        a = argv[i]
        if a in ("-h", "--help"):
            print(__doc__.strip())
            return 0
        if a == "--list":
            listing = True
        elif a == "--self-test":
            self = True
        elif a in ("--only", "--tests", "--ctest"):
            if i + 1 >= len(argv):
                print("doc_commands: %s needs a value\n%s" % (a, __doc__.strip().split("\n\n")[-1]), file=sys.stderr)
                return 2
            i += 1
            if a == "--only":
                only = argv[i]
            elif a == "--tests":
                tests_file = argv[i]
            else:
                listing_file = os.path.join(tempfile.mkdtemp(prefix="xpersif_doc_tests."), "tests.txt")
                with open(listing_file, "w") as f:
                    subprocess.run(["ctest", "--test-dir", argv[i], "-N"], stdout=f, check=True)
                tests_file = listing_file
        elif a.startswith("-"):
            print("doc_commands: unknown option %s" % a, file=sys.stderr)
            return 2
        else:
            rest.append(a)
        i += 1
    if not rest:
        print("doc_commands: give the repository's root", file=sys.stderr)
        return 2
    repo = os.path.abspath(rest[0])
    if self:
        return self_test(repo)
    files = [os.path.abspath(f) for f in rest[1:]]
    problems, results = run_all(repo, markdown_files(repo, files), only, test_names(tests_file), listing)
    if results:
        print("doc_commands: %d blocks run, %d passed, %.0f s in all" %
              (len(results), sum(1 for r in results if r[1]), sum(r[2] for r in results)))
    for p in problems:
        print("doc_commands: " + p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
