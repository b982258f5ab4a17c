#!/usr/bin/python3
"""A study: N seeds x designs x budget on the lockstep loop, headless, with a report (issue 16).

    bash scripts/study.sh [--seeds N | --seed-list 1,2,5] [--designs random,random_null,learning_progress,oracle]
                          [--budget B] [--goals G] [--world FILE] [--out DIR] [--jobs J] [--evaluation-size M]
                          [--evaluation-objects a,b] [--evaluation-seed S] [--every K]
                          [--param component.name=value]... [--timeout SECONDS] [--report-only]
                          [--backend local|slurm] [--partition P] [--time T] [--mem M] [--cells-per-task K]
                          [--sbatch-arg ARG]...

Every cell (design, seed) is one experiment file (OUT/experiments/) run by `roslaunch xpersif experiment.launch`
on a master of its own, into its own run directory (OUT/cells/DESIGN-seedNNN/), as many at once as --jobs
(default: the number of cores). First, once per study, the held-out evaluation set: M uniform random pushes on the
learnable objects, each in turn (OUT/evaluation/, exported to OUT/evaluation_set.csv), the same for every design and
seed.
Two arms besides the designs: random_null (random design on other seeds: what chance alone gives) and oracle (random
design on the learnable objects that move, known from the evaluation set; it starts when that set is done). The
report's primary measure is study_measures.py's.
A study that was interrupted resumes when run again with the same OUT: finished cells (status 0 and their curve)
are skipped, unfinished ones are run again from scratch. Run again with more seeds or designs (and otherwise the same
arguments), it is extended: the finished cells are kept and only the new ones run. The report (OUT/report/) comes
from the knowledge bases and run directories alone: `--report-only` writes it again.
`--backend slurm` runs the cells as Slurm job arrays instead (scripts/study_slurm.py, doc/slurm.md): OUT must be on a
filesystem the nodes share.
"""

import argparse
import csv
import datetime
import json
import math
import os
import random
import re
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import time

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study_measures  # noqa: E402  (scripts/, beside this file)
import xpersif_plots  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Object keys a world file may give an object whose behaviour is fixed (doc/worlds.md). An object with
# any other key (e.g. a property the simulator redraws before each push) is taken as unlearnable.
# The null arm runs random design on these seeds plus this offset, so that it shares no seed with random.
NULL_SEED_OFFSET = 1000003
# The evaluation set pushes each evaluation object in turn (a uniform random push each time), so that every object the
# measure weighs equally has as many pushes; 32 each, so that a push MANIPULATION refuses leaves at least 30.
EVALUATION_DESIGN = "round_robin"
EVALUATION_PUSHES_PER_OBJECT = 32
STATIC_OBJECT_KEYS = {"name", "shape", "size", "radius", "length", "mass", "friction", "color", "pose"}


def fail(sentence, code=2):
    print("study: " + sentence, file=sys.stderr)
    sys.exit(code)


# ---- the study's definition --------------------------------------------------------------------------------

def parse_args(argv):
    p = argparse.ArgumentParser(prog="study.sh", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, default=None, help="seeds 1..N (default 3)")
    p.add_argument("--seed-list", default=None, help="these seeds, comma-separated (instead of --seeds)")
    p.add_argument("--designs", default="random,random_null,learning_progress,error_max,oracle",
                   help="comma-separated designs; random_null is random design on other seeds (the null), oracle is "
                        "random design told which objects are unlearnable or trivial")
    p.add_argument("--budget", type=int, default=40, help="experiments per cell")
    p.add_argument("--goals", type=int, default=0,
                   help="goals per cell after its experiments, reached with the model it learned (default 0)")
    p.add_argument("--world", default=os.path.join(REPO, "worlds", "structured.yaml"),
                   help="the world file (default: the default experiment's, worlds/structured.yaml)")
    p.add_argument("--out", default=None, help="the study's directory (default studies/<time>)")
    p.add_argument("--jobs", type=int, default=None,
                   help="cells at once (default: the cores; slurm: at most this many tasks of an array at once, "
                        "default no limit)")
    p.add_argument("--evaluation-size", type=int, default=None,
                   help="pushes of the held-out evaluation set, each evaluation object in turn (default %d per "
                        "evaluation object)" % EVALUATION_PUSHES_PER_OBJECT)
    p.add_argument("--evaluation-objects", default=None,
                   help="objects of the evaluation set (default: the world's objects but the unlearnable ones)")
    p.add_argument("--evaluation-seed", type=int, default=999, help="seed of the evaluation set")
    p.add_argument("--every", type=int, default=None, help="learning-curve checkpoint spacing (default budget/40, >= 1)")
    p.add_argument("--param", action="append", default=[], help="component.name=value for every run")
    p.add_argument("--timeout", type=float, default=None, help="seconds per cell (default 240 + 10 per experiment)")
    p.add_argument("--report-only", action="store_true", help="only write the report from what is there")
    p.add_argument("--backend", choices=("local", "slurm"), default="local",
                   help="where the cells run: local (--jobs at once on this machine, the default) or slurm (job "
                        "arrays; doc/slurm.md)")
    p.add_argument("--partition", help="slurm: the partition (sbatch --partition)")
    p.add_argument("--time", help="slurm: each array task's time limit (sbatch --time, e.g. 0:30:00)")
    p.add_argument("--mem", help="slurm: each array task's memory (sbatch --mem, e.g. 1G)")
    p.add_argument("--cells-per-task", type=int, default=1, help="slurm: cells one array task runs in turn (default 1)")
    p.add_argument("--sbatch-arg", action="append", default=[],
                   help="slurm: one more sbatch option, e.g. --sbatch-arg=--account=lab (repeatable)")
    a = p.parse_args(argv)
    check_backend(a)
    if a.seed_list:
        try:
            a.seed_list = [int(s) for s in a.seed_list.split(",") if s.strip()]
        except ValueError:
            fail("--seed-list is '%s'; it must be integers separated by commas" % a.seed_list)
    else:
        a.seed_list = list(range(1, (a.seeds or 3) + 1))
    if not a.seed_list or any(s < 0 or s > 2**31 - 1000 for s in a.seed_list):
        fail("the seeds must be at least one integer in 0..2147482647")
    a.designs = [d for d in a.designs.split(",") if d]
    if not a.designs:
        fail("--designs is empty; name at least one design (e.g. random,learning_progress)")
    for d in a.designs:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", d):
            fail("--designs: '%s' is not a design name" % d)
    if a.budget < 1 or a.budget > 100000:
        fail("--budget is %d; it must be in 1..100000" % a.budget)
    if a.goals < 0 or a.goals > 10000:
        fail("--goals is %d; it must be in 0..10000" % a.goals)
    a.array_limit = a.jobs  # slurm: sbatch --array=...%J when --jobs is given
    if a.jobs is None:
        a.jobs = os.cpu_count() or 1
    if a.jobs < 1:
        fail("--jobs is %d; it must be at least 1" % a.jobs)
    if a.evaluation_size is not None and a.evaluation_size < 1:
        fail("--evaluation-size is %d; it must be at least 1" % a.evaluation_size)
    if study_measures.NULL in a.designs and max(a.seed_list) > 2**31 - 1000 - NULL_SEED_OFFSET:
        fail("the seeds of %s are the seeds + %d; seeds must then be at most %d" % (
            study_measures.NULL, NULL_SEED_OFFSET, 2**31 - 1000 - NULL_SEED_OFFSET))
    if a.every is None:
        a.every = max(1, a.budget // 40)
    if a.every < 1:
        fail("--every is %d; it must be at least 1" % a.every)
    a.world = os.path.abspath(a.world)
    if not os.path.isfile(a.world):
        fail("--world %s: no such file" % a.world)
    if a.out is None:
        a.out = os.path.join(REPO, "studies", datetime.datetime.now().strftime("%Y%m%d-%H%M%S"))
    a.out = os.path.abspath(a.out)
    if a.timeout is None:
        default_evaluation = EVALUATION_PUSHES_PER_OBJECT * len(world_objects(a.world))
        a.timeout = 240 + 10 * max(a.budget, a.evaluation_size or 0, default_evaluation)
    params = {}
    for item in a.param:
        m = re.fullmatch(r"([A-Za-z_][A-Za-z0-9_]*)\.([A-Za-z_][A-Za-z0-9_]*)=(.*)", item)
        if not m:
            fail("--param '%s' is not component.name=value" % item)
        params.setdefault(m.group(1), {})[m.group(2)] = yaml.safe_load(m.group(3))
    a.params = params
    return a


def check_backend(a):
    if a.cells_per_task < 1:
        fail("--cells-per-task is %d; it must be at least 1" % a.cells_per_task)
    if a.backend == "slurm" and not shutil.which("sbatch"):
        fail("--backend slurm: sbatch is not on the PATH; run the study where Slurm's client commands are (a login "
             "node; Debian: slurm-client)")
    if a.backend == "local":
        given = [o for o, v in (("--partition", a.partition), ("--time", a.time), ("--mem", a.mem),
                                ("--cells-per-task", a.cells_per_task != 1), ("--sbatch-arg", a.sbatch_arg)) if v]
        if given:
            fail("%s %s only for --backend slurm" % (", ".join(given), "is" if len(given) == 1 else "are"))


def world_objects(world_file):
    """The world's objects (name -> its keys), in file order."""
    try:
        with open(world_file) as f:
            world = yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as e:
        fail("cannot read the world %s: %s" % (world_file, e))
    objects = world.get("objects") if isinstance(world, dict) else None
    if not isinstance(objects, list) or not objects:
        fail("the world %s lists no objects" % world_file)
    return [(o.get("name"), o) for o in objects if isinstance(o, dict)]


def evaluation_objects(args):
    objects = world_objects(args.world)
    names = [n for n, _ in objects]
    if args.evaluation_objects:
        chosen = [o for o in args.evaluation_objects.split(",") if o]
        for o in chosen:
            if o not in names:
                fail("--evaluation-objects: '%s' is not an object of %s; its objects are %s" % (o, args.world, ", ".join(names)))
        return chosen, "given by --evaluation-objects"
    chosen = [n for n, o in objects if set(o) <= STATIC_OBJECT_KEYS]
    left = [n for n in names if n not in chosen]
    if not chosen:
        fail("every object of %s has keys beyond %s, so none counts as learnable; name them with --evaluation-objects"
             % (args.world, ", ".join(sorted(STATIC_OBJECT_KEYS))))
    why = "the world's objects" + (" but %s (keys beyond the fixed ones: unlearnable)" % ", ".join(left) if left else "")
    return chosen, why


def definition(args, eval_objects):
    defn = {"designs": args.designs, "seeds": args.seed_list, "budget": args.budget, "world": args.world,
            "evaluation": {"size": args.evaluation_size, "objects": eval_objects, "seed": args.evaluation_seed,
                           "design": EVALUATION_DESIGN},
            "parameters": args.params}
    if args.goals:  # only when asked, so that a study from before --goals existed still resumes
        defn["goals"] = args.goals
    return defn


def experiment_file(path, name, seed, world, phase, parameters):
    doc = {"name": name, "world": world, "seed": seed, "clock": "lockstep", "phases": [phase],
           "parameters": parameters}
    with open(path, "w") as f:
        f.write("# Written by scripts/study.py: one cell of the study in %s.\n" % os.path.dirname(os.path.dirname(path)))
        yaml.safe_dump(doc, f, default_flow_style=None, sort_keys=False)


class Cell:
    def __init__(self, name, design, seed, experiments, file, run_dir):
        self.name, self.design, self.seed, self.experiments = name, design, seed, experiments
        self.file, self.run_dir = file, run_dir
        self.process = None
        self.started = None
        self.attempts = 0
        self.done_units = 0
        self.outcome = None  # (code, sentence)
        self.waits_for_evaluation = False

    def status(self):
        try:
            with open(os.path.join(self.run_dir, "status")) as f:
                code, _, sentence = f.read().strip().partition(" ")
                return int(code), sentence
        except (OSError, ValueError):
            return None

    def finished(self):
        s = self.status()
        return s is not None and s[0] == 0 and os.path.exists(os.path.join(self.run_dir, "knowledge.db"))


def extension(old, new):
    """What @p new adds to the stored study @p old when it only adds seeds or designs (the same world, budget,
    evaluation set and parameters, so the finished cells stay valid), as a phrase; None when it is another study."""
    def rest(d):
        return {k: v for k, v in d.items() if k not in ("seeds", "designs")}
    added, dropped = [], False
    for key in ("seeds", "designs"):
        before, after = old.get(key, []), new[key]
        dropped = dropped or any(v not in after for v in before)
        more = [str(v) for v in after if v not in before]
        if more:
            added.append("%s %s" % (key, ",".join(more)))
    return " and ".join(added) if rest(old) == rest(new) and not dropped and added else None


def plan(args, eval_objects):
    os.makedirs(os.path.join(args.out, "experiments"), exist_ok=True)
    defn = definition(args, eval_objects)
    stored = os.path.join(args.out, "study.json")
    if os.path.exists(stored):
        with open(stored) as f:
            old = json.load(f)
        if old != defn:
            added = extension(old, defn)
            if added is None:
                diff = [k for k in defn if old.get(k) != defn[k]]
                fail("%s holds another study (its %s differ from these arguments); resume it with the same arguments, "
                     "add seeds or designs to it, or use another --out" % (args.out, ", ".join(diff)))
            print("study: extending %s with %s; its finished cells are kept" % (args.out, added), file=sys.stderr)
            with open(stored, "w") as f:
                json.dump(defn, f, indent=2)
    else:
        with open(stored, "w") as f:
            json.dump(defn, f, indent=2)
    params = args.params
    ev_params = json.loads(json.dumps(params))
    ev_params.setdefault("design_of_experiments", {})["objects"] = eval_objects
    ev_file = os.path.join(args.out, "experiments", "evaluation.yaml")
    experiment_file(ev_file, "evaluation", args.evaluation_seed, args.world,
                    {"kind": "experimentation", "name": "evaluation", "design": EVALUATION_DESIGN,
                     "experiments": args.evaluation_size, "goals": 0}, ev_params)
    cells = [Cell("evaluation", "evaluation", args.evaluation_seed, args.evaluation_size, ev_file,
                  os.path.join(args.out, "evaluation"))]
    for seed in args.seed_list:
        for design in args.designs:
            name = "%s-seed%03d" % (design, seed)
            f = os.path.join(args.out, "experiments", name + ".yaml")
            cell = Cell(name, design, seed, args.budget, f, os.path.join(args.out, "cells", name))
            if design == study_measures.ORACLE:
                cell.waits_for_evaluation = True  # its objects come from the evaluation set (arm_file)
            else:
                arm_file(args, cell, None)
            cells.append(cell)
    return cells


def arm_file(args, cell, moving):
    """The cell's experiment file. The run is named after the arm; random_null runs random design on seeds shifted
    by NULL_SEED_OFFSET; oracle runs random design on `moving` alone (the learnable objects that move)."""
    design, seed, params = cell.design, cell.seed, args.params
    if design == study_measures.NULL:
        design, seed = "random", cell.seed + NULL_SEED_OFFSET
    elif design == study_measures.ORACLE:
        design = "random"
        params = json.loads(json.dumps(params))
        params.setdefault("design_of_experiments", {})["objects"] = moving
    experiment_file(cell.file, cell.name.replace("-", "_"), seed, args.world,
                    {"kind": "experimentation", "name": cell.design, "design": design, "experiments": args.budget,
                     "goals": args.goals}, params)


def evaluation_rows(evaluation):
    """The evaluation set's successful pushes: (seq, object, side, offset, distance, dx, dy, dyaw) tuples."""
    ev_db = os.path.join(evaluation.run_dir, "knowledge.db")
    if not os.path.exists(ev_db):
        return []
    con = sqlite3.connect("file:%s?mode=ro" % ev_db, uri=True)
    try:
        run = con.execute("SELECT id FROM runs WHERE name = 'evaluation' ORDER BY id DESC LIMIT 1").fetchone()
        if not run:
            return []
        return con.execute("SELECT seq, object, side, push_offset, distance, dx, dy, dyaw FROM experiments "
                           "WHERE run_id = ? AND status = 'done' ORDER BY seq", run).fetchall()
    finally:
        con.close()


def moving_from(ev_rows, eval_objects):
    """The learnable objects that move, and their travel shares, from the evaluation set's rows (evaluation_rows)."""
    rows = [dict(zip(("seq", "object", "side", "offset", "distance", "dx", "dy", "dyaw"), r)) for r in ev_rows]
    return study_measures.moving_objects(rows, eval_objects)


# ---- running the cells -------------------------------------------------------------------------------------

def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def start(cell):
    if os.path.exists(cell.run_dir):
        shutil.rmtree(cell.run_dir)  # an unfinished cell runs again from scratch
    os.makedirs(cell.run_dir)
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_IP="127.0.0.1",
               ROS_LOG_DIR=os.path.join(cell.run_dir, "ros_log_launch"))
    env.pop("ROS_HOSTNAME", None)
    log = open(os.path.join(cell.run_dir, "console.log"), "w")
    cell.process = subprocess.Popen(
        ["roslaunch", "-p", str(port), "xpersif", "experiment.launch", "experiment:=" + cell.file,
         "run_dir:=" + cell.run_dir], stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True,
        cwd=cell.run_dir)
    log.close()
    cell.started = time.time()
    cell.attempts += 1
    cell.done_units = 0


def stop(cell):
    """SIGINT to the cell's process group (roslaunch stops its nodes), harder if it does not go."""
    if not cell.process or cell.process.poll() is not None:
        return
    for sig, wait in ((signal.SIGINT, 20), (signal.SIGTERM, 10), (signal.SIGKILL, 5)):
        try:
            os.killpg(cell.process.pid, sig)
        except ProcessLookupError:
            return
        try:
            cell.process.wait(wait)
            return
        except subprocess.TimeoutExpired:
            pass


class LocalCells:
    """The cells on this machine, --jobs at once (the default backend; study_slurm.SlurmCells is the other): start
    a cell, submit (nothing to do here), poll its exit code, stop the running ones."""

    def __init__(self, args):
        self.slots, self.timeout = args.jobs, args.timeout

    def adopt(self, cells):
        return []  # a cell of an earlier runner ended with it

    def start(self, cell):
        start(cell)

    def submit(self):
        pass

    def poll(self, cell):
        code = cell.process.poll()
        if code is None and time.time() - cell.started > self.timeout:
            stop(cell)
            cell.outcome = (1, "timed out after %d s" % self.timeout)
            code = 1
        return code

    def stop(self, cells):
        for cell in cells:
            stop(cell)


def backend_for(args):
    if args.backend == "slurm":
        import study_slurm  # scripts/, beside this file
        return study_slurm.SlurmCells(args)
    return LocalCells(args)


PROGRESS = re.compile(r": experiment (\d+) of (\d+)")


def units_of(cell):
    """Experiments the running cell has done, from its console (the runner's progress lines)."""
    try:
        with open(os.path.join(cell.run_dir, "console.log"), "rb") as f:
            f.seek(0, 2)
            f.seek(max(0, f.tell() - 8192))
            tail = f.read().decode("utf-8", "replace")
    except OSError:
        return cell.done_units
    found = PROGRESS.findall(tail)
    if found:
        cell.done_units = max(cell.done_units, min(int(found[-1][0]), cell.experiments))
    return cell.done_units


def clock(seconds):
    seconds = int(max(0, seconds))
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return ("%dh%02dm" % (h, m)) if h else ("%dm%02ds" % (m, s)) if m else ("%ds" % s)


class Progress:
    def __init__(self, total, skipped):
        self.total, self.skipped = total, skipped
        self.started = time.time()
        self.tty = sys.stderr.isatty()
        self.last_line, self.last_print = "", 0

    def show(self, done, cells_done, cells_total, running, final=False):
        elapsed = time.time() - self.started
        fraction = done / self.total if self.total else 1.0
        bar = "#" * int(30 * fraction) + "-" * (30 - int(30 * fraction))
        worked = done - self.skipped
        left = "unknown"
        if worked > 0 and done < self.total:
            left = "about " + clock(elapsed / worked * (self.total - done))
        elif done >= self.total:
            left = "none"
        line = "study [%s] %3d%% %d/%d experiments, %d/%d cells done, %d running, %s elapsed, %s left" % (
            bar, int(100 * fraction), done, self.total, cells_done, cells_total, running, clock(elapsed), left)
        if self.tty:
            sys.stderr.write("\r" + line + ("\n" if final else ""))
            sys.stderr.flush()
        elif final or (line != self.last_line and time.time() - self.last_print >= 10):
            print(line, file=sys.stderr, flush=True)
            self.last_print = time.time()
        self.last_line = line


def curve(cell, args, evaluation):
    """The cell's learning curve on the study's evaluation set (xpersif_study_curve), into its run directory, with
    the learner the cells learned with: one forest per object when --param machine_learning.learner_type=
    per_object_forest, MACHINELEARNING's shared forest otherwise."""
    learner_type = args.params.get("machine_learning", {}).get("learner_type", "random_forest")
    out = subprocess.run(
        ["xpersif_study_curve", "--evaluation-database", os.path.join(evaluation.run_dir, "knowledge.db"),
         "--database", os.path.join(cell.run_dir, "knowledge.db"), "--run", cell.design, "--out", cell.run_dir,
         "--every", str(args.every), "--learner", "per_object" if learner_type == "per_object_forest" else "shared"],
        capture_output=True, text=True)
    if out.returncode != 0:
        return out.stderr.strip() or "xpersif_study_curve failed"
    return ""


TOOL_SENTENCE = re.compile(r"^(xpersif[\w-]*: .*)$")
ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]|\x1b\][^\x07]*\x07")


def console_cause(run_dir):
    """The first sentence one of our tools wrote to the cell's console (e.g. xpersif_experiment refusing the world
    before the launch began), or ''."""
    try:
        with open(os.path.join(run_dir, "console.log"), errors="replace") as f:
            for line in f:
                m = TOOL_SENTENCE.match(ANSI.sub("", line).strip())
                if m:
                    return m.group(1)
    except OSError:
        pass
    return ""


def failure_of(args, cell, status):
    """Why a cell failed: its own status; under Slurm, what the backend found (it holds the status and Slurm's word);
    else what its console says."""
    first = (cell.outcome, status) if args.backend == "slurm" else (status, cell.outcome)
    known = first[0] or first[1]
    if known:
        return known
    cause = console_cause(cell.run_dir)
    return (1, "ended without an outcome: %s (%s/console.log)" % (cause, cell.run_dir) if cause else
            "ended without an outcome; see %s/console.log" % cell.run_dir)


def run_cells(args, cells):
    evaluation = cells[0]
    todo = [c for c in cells if not (c.finished() and (c is evaluation or os.path.exists(os.path.join(c.run_dir, "curve.csv"))))]
    finished_cells = [c for c in cells if c not in todo]
    total = sum(c.experiments for c in cells)
    skipped = sum(c.experiments for c in finished_cells)
    if finished_cells:
        print("study: resuming %s: %d of %d cells already finished" % (args.out, len(finished_cells), len(cells)),
              file=sys.stderr)
    progress = Progress(total, skipped)
    failed = []
    moving_cache = None  # the oracle's objects (moving_from), once the evaluation set is done
    need_curve = [c for c in todo if c is not evaluation]
    queue = list(todo)
    # Cells whose run finished before the evaluation set: their curves wait for it.
    waiting_curve = [c for c in need_curve if c.finished()]
    queue = [c for c in queue if c not in waiting_curve]
    backend = backend_for(args)
    running = backend.adopt(queue)  # cells an earlier runner submitted that still run (Slurm)
    queue = [c for c in queue if c not in running]

    def interrupted(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, interrupted)
    try:
        # Cells that ran but have no curve yet (a study stopped between a run's end and its curve) are curved too.
        while queue or running or (waiting_curve and evaluation in finished_cells):
            while len(running) < backend.slots:
                ready = [c for c in queue if not c.waits_for_evaluation or evaluation in finished_cells]
                if not ready and evaluation in failed:  # the oracle's objects come from the evaluation set
                    ready = [c for c in queue if c.waits_for_evaluation]
                if not ready:
                    break
                cell = ready[0]
                queue.remove(cell)
                if cell.waits_for_evaluation:
                    if evaluation in finished_cells and moving_cache is None:  # read once, when the set is done
                        moving_cache = moving_from(evaluation_rows(evaluation), args.eval_objects)[0]
                    moving = moving_cache if evaluation in finished_cells else []
                    if not moving:
                        cell.outcome = (1, "the oracle has nothing to push: %s" % (
                            "no evaluation object moved in the evaluation set" if evaluation in finished_cells else
                            "the evaluation set failed"))
                        failed.append(cell)
                        continue
                    arm_file(args, cell, moving)
                backend.start(cell)
                running.append(cell)
            backend.submit()
            time.sleep(1.0)
            for cell in list(running):
                code = backend.poll(cell)
                if code is None:
                    continue
                running.remove(cell)
                status = cell.status()
                if cell.finished():
                    cell.outcome = status
                    if cell is evaluation:
                        finished_cells.append(cell)
                    else:
                        waiting_curve.append(cell)
                elif cell.attempts < 2:
                    print("\nstudy: %s failed (%s); once more" % (cell.name, failure_of(args, cell, status)[1]),
                          file=sys.stderr)
                    queue.append(cell)
                else:
                    cell.outcome = failure_of(args, cell, status)
                    failed.append(cell)
            if evaluation in finished_cells:
                for cell in list(waiting_curve):
                    why = curve(cell, args, evaluation)
                    waiting_curve.remove(cell)
                    if why:
                        cell.outcome = (1, why)
                        failed.append(cell)
                    else:
                        finished_cells.append(cell)
            done = sum(c.experiments for c in finished_cells) + sum(c.experiments for c in waiting_curve) + \
                sum(units_of(c) for c in running)
            progress.show(done, len(finished_cells), len(cells), len(running))
    except KeyboardInterrupt:
        print("\nstudy: interrupted; stopping %d running cells (run the same command again to resume)" % len(running),
              file=sys.stderr)
        backend.stop(running)
        sys.exit(130)
    if evaluation not in finished_cells:
        for cell in waiting_curve:
            cell.outcome = (1, "ran, but has no learning curve: the evaluation set failed (%s)" % (
                evaluation.outcome[1] if evaluation.outcome else "unknown"))
            failed.append(cell)
    progress.show(sum(c.experiments for c in finished_cells), len(finished_cells), len(cells), 0, final=True)
    for cell in failed:
        print("study: cell %s failed: %s" % (cell.name, cell.outcome[1] if cell.outcome else "unknown"), file=sys.stderr)
    return failed


# ---- the report --------------------------------------------------------------------------------------------

T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262, 10: 2.228,
       12: 2.179, 15: 2.131, 20: 2.086, 25: 2.060, 30: 2.042, 40: 2.021, 60: 2.000, 120: 1.980}


def t95(df):
    try:
        from scipy import stats
        return float(stats.t.ppf(0.975, df))
    except ImportError:
        keys = sorted(k for k in T95 if k <= df)
        return T95[keys[-1]] if keys else T95[1]


def mean_ci(values):
    n = len(values)
    m = sum(values) / n
    if n < 2:
        return m, m, m
    sd = math.sqrt(sum((v - m) ** 2 for v in values) / (n - 1))
    h = t95(n - 1) * sd / math.sqrt(n)
    return m, m - h, m + h


def median(values):
    v = sorted(values)
    n = len(v)
    if n == 0:
        return float("nan")
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])


def bootstrap_median_ci(values, rng, rounds=2000):
    if len(values) < 2:
        return (values[0], values[0]) if values else (float("nan"), float("nan"))
    medians = sorted(median([rng.choice(values) for _ in values]) for _ in range(rounds))
    return medians[int(0.025 * rounds)], medians[int(0.975 * rounds) - 1]


def sign_flip_test(diffs):
    """Two-sided exact (n <= 16) or Monte Carlo paired permutation test of mean difference 0."""
    n = len(diffs)
    if n == 0:
        return float("nan")
    observed = abs(sum(diffs))
    if n <= 16:
        count = 0
        for mask in range(1 << n):
            s = sum(d if (mask >> i) & 1 else -d for i, d in enumerate(diffs))
            count += abs(s) >= observed - 1e-15
        return count / float(1 << n)
    rng = random.Random(1)
    rounds = 100000
    count = sum(abs(sum(d if rng.random() < 0.5 else -d for d in diffs)) >= observed - 1e-15 for _ in range(rounds))
    return (count + 1) / (rounds + 1)


def wilcoxon(diffs):
    try:
        from scipy import stats
    except ImportError:
        return None
    if not any(abs(d) > 0 for d in diffs):
        return 1.0
    try:
        return float(stats.wilcoxon(diffs).pvalue)
    except ValueError:
        return None


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def fmt(x, digits=4):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    if isinstance(x, float) and math.isinf(x):
        return "never"
    return ("%." + str(digits) + "f") % x


def pct(x):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    return "never" if math.isinf(x) else "%.0f %%" % (100 * x)


def object_curve(cell):
    """{object: {k: error}} from the cell's curve_objects.csv ({} for a cell curved before it existed)."""
    path = os.path.join(cell.run_dir, "curve_objects.csv")
    out = {}
    if os.path.exists(path):
        for r in read_csv(path):
            out.setdefault(r["object"], {})[int(r["experiments"])] = float(r["error"])
    return out


def goal_curve(cell):
    """({object: {k: one-push goal error}}, {object: (random choice, best choice)}) from the cell's curve_goals.csv
    (empty for a cell curved before it existed)."""
    path = os.path.join(cell.run_dir, "curve_goals.csv")
    curves, references = {}, {}
    if os.path.exists(path):
        for r in read_csv(path):
            curves.setdefault(r["object"], {})[int(r["experiments"])] = float(r["goal_error"])
            references[r["object"]] = (float(r["random_choice"]), float(r["best_choice"]))
    return curves, references


def cell_goals(cell):
    """The cell's goals from its knowledge base: (object, reached, final error, pushes), and the tolerance."""
    con = sqlite3.connect("file:%s?mode=ro" % os.path.join(cell.run_dir, "knowledge.db"), uri=True)
    try:
        run = con.execute("SELECT id, parameters FROM runs WHERE name = ? ORDER BY id DESC LIMIT 1",
                          (cell.design,)).fetchone()
        if not run:
            return [], None
        try:
            tolerance = json.loads(run[1] or "{}").get("goal_tolerance")
        except ValueError:
            tolerance = None
        rows = con.execute("SELECT object, reached, final_error, pushes_used FROM goals WHERE run_id = ? ORDER BY id",
                           (run[0],)).fetchall()
        return rows, tolerance
    finally:
        con.close()


def measures_files(out, data, moving, budget):
    """The primary measures (study_measures) from the cells' per-object curves, into measures.csv and
    object_curves.csv."""
    object_curves = {key: d["objects"] for key, d in data.items() if d["objects"]}
    measured = study_measures.measures(object_curves, moving, budget)
    with open(os.path.join(out, "cell_measures.csv"), "w", newline="") as f:
        names = [n for n, _ in measured["fractions"]]
        w = csv.writer(f)
        w.writerow(["design", "seed", "log_area"] + ["error_" + n for n in names])
        for (design, seed), v in sorted(measured["cells"].items()):
            w.writerow([design, seed, v["area"]] + [v["error_" + n] for n in names])
    with open(os.path.join(out, "measures.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["design", "measure", "seeds", "ratio_to_random", "ci_low", "ci_high"])
        for row in measured["rows"]:
            for name in ["area"] + ["error_" + n for n, _ in measured["fractions"]]:
                w.writerow([row["design"], name, row["seeds"], *row[name]])
            if row.get("paired"):
                w.writerow([row["design"], "area_paired", row["seeds"], *row["paired"]])
            if row.get("oracle_fraction"):
                w.writerow([row["design"], "oracle_fraction", row["seeds"], *row["oracle_fraction"]])
    references = {}
    for d in data.values():
        references.update(d["goal_curve"][1])  # the same in every cell: a property of the evaluation set
    measured["competence"] = study_measures.competence(
        {key: d["goal_curve"][0] for key, d in data.items() if d["goal_curve"][0]}, references, moving, budget)
    with open(os.path.join(out, "competence.csv"), "w", newline="") as f:
        comp = measured["competence"]
        w = csv.writer(f)
        w.writerow(["design", "seed"] + ["goal_error_" + n for n, _ in comp["fractions"]])
        for (design, seed), v in sorted(comp["cells"].items()):
            w.writerow([design, seed] + [v[n] for n, _ in comp["fractions"]])
    with open(os.path.join(out, "object_curves.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["design", "object", "experiments", "seeds", "mean", "ci_low", "ci_high"])
        for design in sorted({d for d, _ in object_curves}):
            for o in sorted({o for (d, _), c in object_curves.items() if d == design for o in c}):
                ks = sorted({k for (d, _), c in object_curves.items() if d == design and o in c for k in c[o]})
                for k in ks:
                    values = [c[o][k] for (d, _), c in object_curves.items() if d == design and k in c.get(o, {})]
                    w.writerow([design, o, k, len(values), *mean_ci(values)])
    return measured


def measures_section(measured, moving, move_shares, ev_rows, eval_objects):
    md = ["## Designs against random: the area under the log-error curve (primary)", ""]
    counts = {o: sum(1 for r in ev_rows if r[1] == o) for o in eval_objects}
    unpushed = [o for o in eval_objects if not counts[o]]
    still = [o for o in eval_objects if o not in moving and counts[o]]
    md.append("Per cell, the mean over its budget of log E(k), where E(k) is the prediction error after k experiments "
              "averaged with equal weight over the learnable objects that move: %s (evaluation pushes %s)%s. A ratio is "
              "exp(difference of the mean areas): the ratio of the geometric-mean errors over the budget; below 1 "
              "is better than random. 95 %% intervals by bootstrap over seeds. An object moves when its median "
              "travel in the evaluation set is at least %d %% of its median push distance (scripts/study_measures.py)."
              % (", ".join("%s (%.0f %%)" % (o, 100 * move_shares.get(o, 0)) for o in moving) or "none",
                 ", ".join("%s %d" % (o, counts[o]) for o in eval_objects),
                 ("; not counted: %s (they do not move, so any model predicts them)" % ", ".join(
                     "%s (%.0f %%)" % (o, 100 * move_shares.get(o, 0)) for o in still) if still else "") +
                 ("; not judged: %s (no successful evaluation push)" % ", ".join(unpushed) if unpushed else ""),
                 int(100 * study_measures.MOVES_SHARE)))
    md.append("")
    few = [o for o in moving if counts.get(o, 0) < 30]
    if few:
        md.append("Fewer than 30 evaluation pushes of %s: the curves are noisy (raise --evaluation-size)." % ", ".join(few))
        md.append("")
    if not measured["rows"]:
        md.append("No design to compare with random (the study needs a random arm and another).")
        md.append("")
        return md
    names = [n for n, _ in measured["fractions"]]
    ks = dict(measured["fractions"])

    def cell(t):
        return "%.3f (%.3f–%.3f)" % t if t else "–"
    md.append("| design | seeds | area ratio (unpaired) | area ratio (paired; r) | error at %s |" % " | ".join(
        "%s (k=%d)" % (n, ks[n]) for n in names) + " fraction of the oracle's gain |")
    md.append("|---|---|---|---|" + "---|" * len(names) + "---|")
    for row in measured["rows"]:
        paired = cell(row.get("paired")) + ("; r=%.2f" % row["pairing_r"] if not math.isnan(row.get("pairing_r", float("nan"))) else "")
        frac = row.get("oracle_fraction")
        md.append("| %s | %d | %s | %s | %s | %s |" % (
            row["design"], row["seeds"], cell(row["area"]), paired, " | ".join(cell(row["error_" + n]) for n in names),
            "%.0f %% (%.0f–%.0f %%)" % tuple(100 * x for x in frac) if frac else "–"))
    md.append("")
    if measured.get("oracle_gains") is False:
        md.append("The oracle gains nothing over random that this study can tell (its area ratio's interval reaches 1), "
                  "so no design's fraction of its gain is given.")
        md.append("")
    null_row = next((r for r in measured["rows"] if r["design"] == study_measures.NULL), None)
    if null_row:
        r, lo, hi = null_row["area"]
        if measured["null_seeds"] < study_measures.MIN_SEEDS:
            judged = "%d seeds are too few for an interval, so nothing here can be judged." % measured["null_seeds"]
        elif measured.get("null_ok"):
            judged = "1.00 lies within its interval, as it must."
        else:
            judged = ("1.00 lies OUTSIDE its interval: chance alone made a difference this large, so no ratio above "
                      "can be trusted (more seeds, or a biased measure).")
        md.append("**The null** (random_null, random design on other seeds, against random): area ratio %.3f "
                  "(%.3f–%.3f): %s" % (r, lo, hi, judged))
    else:
        md.append("**No null arm** (add random_null to --designs): nothing shows what chance alone gives here.")
    base_seeds = sum(1 for d, _ in measured["cells"] if d == study_measures.BASE)
    if base_seeds >= study_measures.MIN_SEEDS and not math.isnan(measured.get("detectable", float("nan"))):
        md.append("")
        md.append("With these seeds the study detects (80 %% power, 5 %% two-sided) an area ratio of %.2f or lower: "
                  "an effect smaller than %.0f %% goes unseen." % (1 - measured["detectable"], 100 * measured["detectable"]))
    md.append("")
    for sentence in measured["verdicts"]:
        md.append("- " + sentence + ".")
    md.append("")
    md.append("Files: `measures.csv` (every ratio with its interval), `cell_measures.csv` (per cell), "
              "`object_curves.csv` (per object and design).")
    md.append("")
    md.extend(competence_section(measured.get("competence")))
    return md


def competence_section(comp):
    """Competence at one-push goals (issue 38): what the model can do with what it predicts."""
    if not comp or not comp["cells"]:
        return []
    names = [n for n, _ in comp["fractions"]]
    ks = dict(comp["fractions"])
    md = ["## Competence: one-push goals", "",
          "With the model learned after k experiments, one push to bring an object to a target: the targets are the "
          "evaluation set's measured outcomes, each object's own; for a target the model picks, among the object's "
          "other evaluation pushes, the one it predicts lands closest; the error is where that push really went "
          "(m, a turn counted at 2 cm per radian), averaged with equal weight over the learnable objects that move. "
          "The pushes' outcomes are the simulator's, measured once in the evaluation set, so no design is judged on "
          "other pushes than another (core::oneShotGoalErrors). A model that knows nothing does what picking at "
          "random does: %.4f m; the best choice the pushes allow: %.4f m." % (comp["random_choice"], comp["best_choice"]),
          "",
          "| design | seeds | " + " | ".join("goal error at %s (k=%d)" % (n, ks[n]) for n in names) + " |",
          "|---|---|" + "---|" * len(names)]
    rows = {r["design"]: r for r in comp["rows"]}
    for design, means in comp["means"].items():
        seeds = sum(1 for d, _ in comp["cells"] if d == design)
        cells = []
        for n in names:
            r = rows.get(design, {}).get(n)
            cells.append("%.4f" % means[n] + (" (ratio %.3f, %.3f–%.3f)" % r if r else ""))
        md.append("| %s | %d | %s |" % (design, seeds, " | ".join(cells)))
    md += ["", "Ratios are to random's mean goal error (geometric, bootstrap over seeds); below 1 is better. "
           "File: `competence.csv` (per cell).", ""]
    return md


def report(args, cells, eval_objects, eval_why):
    out = os.path.join(args.out, "report")
    os.makedirs(out, exist_ok=True)
    evaluation = cells[0]
    data = {}  # (design, seed) -> {"curve": [(k, e)], "experiments": rows, "notions": rows}
    for cell in cells[1:]:
        if not (cell.finished() and os.path.exists(os.path.join(cell.run_dir, "curve.csv"))):
            continue
        curve_rows = [(int(r["experiments"]), float(r["error"])) for r in read_csv(os.path.join(cell.run_dir, "curve.csv"))]
        data[(cell.design, cell.seed)] = {
            "goals": cell_goals(cell),
            "curve": curve_rows,
            "experiments": read_csv(os.path.join(cell.run_dir, "experiments.csv")),
            "notions": read_csv(os.path.join(cell.run_dir, "notions.csv")),
            "objects": object_curve(cell),
            "goal_curve": goal_curve(cell),
        }
    designs = [d for d in args.designs if any(k[0] == d for k in data)]
    seeds = sorted({k[1] for k in data})
    objects = [n for n, _ in world_objects(args.world)]

    # The evaluation set, stored with the study.
    ev_rows = evaluation_rows(evaluation)
    with open(os.path.join(args.out, "evaluation_set.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["seq", "object", "side", "offset", "distance", "dx", "dy", "dyaw"])
        w.writerows(ev_rows)

    # Per cell.
    cell_rows = []
    for (design, seed), d in sorted(data.items()):
        counts = {o: 0 for o in objects}
        for r in d["experiments"]:
            counts[r["object"]] = counts.get(r["object"], 0) + 1
        cell_rows.append({"design": design, "seed": seed, "designed": len(d["experiments"]),
                          "failed": sum(r["status"] != "done" for r in d["experiments"]),
                          "learned": d["curve"][-1][0], "final_error": d["curve"][-1][1],
                          "mean_error": sum(e for _, e in d["curve"]) / len(d["curve"]),
                          **{"n_" + o: c for o, c in counts.items()}})
    with open(os.path.join(out, "cells.csv"), "w", newline="") as f:
        if cell_rows:
            w = csv.DictWriter(f, fieldnames=list(cell_rows[0].keys()))
            w.writeheader()
            w.writerows(cell_rows)

    # Learning curves: mean and 95 % interval over seeds at every checkpoint.
    curve_rows = []
    for design in designs:
        ks = sorted({k for (dd, _), d in data.items() if dd == design for k, _ in d["curve"]})
        for k in ks:
            values = [dict(d["curve"])[k] for (dd, _), d in data.items() if dd == design and k in dict(d["curve"])]
            m, lo, hi = mean_ci(values)
            curve_rows.append({"design": design, "experiments": k, "seeds": len(values), "mean": m, "ci_low": lo,
                               "ci_high": hi})
    with open(os.path.join(out, "learning_curves.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["design", "experiments", "seeds", "mean", "ci_low", "ci_high"])
        w.writeheader()
        w.writerows(curve_rows)

    # Experiments needed to reach random's final error, per seed.
    reach_rows = []
    for seed in seeds:
        base = data.get(("random", seed))
        if not base:
            continue
        target, k_random = base["curve"][-1][1], base["curve"][-1][0]
        for design in designs:
            d = data.get((design, seed))
            if design == "random" or not d:
                continue
            k = next((kk for kk, e in d["curve"] if e <= target), None)
            reach_rows.append({"design": design, "seed": seed, "random_final_error": target,
                               "random_experiments": k_random, "experiments_to_reach": "" if k is None else k,
                               "share_of_random": (k / k_random if k is not None and k_random > 0 else
                                                   (float("inf") if k is None else 0.0))})
    with open(os.path.join(out, "reach.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["design", "seed", "random_final_error", "random_experiments",
                                          "experiments_to_reach", "share_of_random"])
        w.writeheader()
        w.writerows(reach_rows)

    # Share of experiments per object over time.
    width = max(1, int(math.ceil(args.budget / 10.0)))
    share_rows = []
    for design in designs:
        for start_seq in range(1, args.budget + 1, width):
            end_seq = min(args.budget, start_seq + width - 1)
            per_seed = []
            for (dd, _), d in data.items():
                if dd != design:
                    continue
                rows = [r for r in d["experiments"] if start_seq <= int(r["seq"]) <= end_seq]
                if rows:
                    per_seed.append({o: sum(r["object"] == o for r in rows) / len(rows) for o in objects})
            for o in objects:
                if per_seed:
                    share_rows.append({"design": design, "from": start_seq, "to": end_seq, "object": o,
                                       "share": sum(p[o] for p in per_seed) / len(per_seed), "seeds": len(per_seed)})
    with open(os.path.join(out, "object_share.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["design", "from", "to", "object", "share", "seeds"])
        w.writeheader()
        w.writerows(share_rows)

    # Tests: each design against random, paired by seed.
    test_rows = []
    for design in designs:
        if design == "random":
            continue
        for measure, key in (("final error", "final_error"), ("mean error over the curve", "mean_error")):
            pairs = []
            for seed in seeds:
                a = next((r for r in cell_rows if r["design"] == design and r["seed"] == seed), None)
                b = next((r for r in cell_rows if r["design"] == "random" and r["seed"] == seed), None)
                if a and b:
                    pairs.append(a[key] - b[key])
            if pairs:
                test_rows.append({"design": design, "measure": measure, "seeds": len(pairs),
                                  "median_difference": median(pairs), "wilcoxon_p": wilcoxon(pairs),
                                  "permutation_p": sign_flip_test(pairs)})
    with open(os.path.join(out, "tests.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["design", "measure", "seeds", "median_difference", "wilcoxon_p", "permutation_p"])
        w.writeheader()
        w.writerows(test_rows)

    plots(out, designs, curve_rows, share_rows, objects)
    moving, move_shares = moving_from(ev_rows, eval_objects)
    measured = measures_files(out, data, moving, args.budget)

    # report.md
    md = ["# Study: %s" % os.path.basename(args.out), ""]
    md.append("Command: `bash scripts/study.sh %s`" % " ".join(a for a in sys.argv[1:] if a != "--report-only"))
    md.append("")
    md.append("World `%s`; designs %s; seeds %s; budget %d experiments per cell; %d of %d cells finished." % (
        args.world, ", ".join(args.designs), ",".join(map(str, args.seed_list)), args.budget, len(data),
        len(args.designs) * len(args.seed_list)))
    md.append("")
    md.append("**Evaluation set** (held out, the same for every design and seed): %d successful random pushes of "
              "%s (%s), seed %d, stored in `evaluation/knowledge.db` and `evaluation_set.csv`. A cell's error after k "
              "experiments is the RMS prediction error on it of MACHINELEARNING's learner (%s) trained on the cell's "
              "first k successful experiments (m; a turn counts as the travel of a point 2 cm from the centre); "
              "checkpoints every %d experiments." % (
                  len(ev_rows), ", ".join(eval_objects), eval_why, args.evaluation_seed,
                  args.params.get("machine_learning", {}).get("learner_type", "random_forest"), args.every))
    md.append("")
    md.extend(measures_section(measured, moving, move_shares, ev_rows, eval_objects))
    md.append("## Learning curves on the whole evaluation set (mean over seeds, 95 % t-interval)")
    md.append("")
    md.append("![learning curves](learning_curves.png)")
    md.append("")
    md.append("| design | seeds | error at 0 | final error (mean, 95 % CI) | experiments learned (mean) | failed (mean) |")
    md.append("|---|---|---|---|---|---|")
    for design in designs:
        rows = [r for r in cell_rows if r["design"] == design]
        first = [d["curve"][0][1] for (dd, _), d in data.items() if dd == design]
        m, lo, hi = mean_ci([r["final_error"] for r in rows])
        md.append("| %s | %d | %s | %s (%s–%s) | %.1f | %.1f |" % (
            design, len(rows), fmt(sum(first) / len(first)), fmt(m), fmt(lo), fmt(hi),
            sum(r["learned"] for r in rows) / len(rows), sum(r["failed"] for r in rows) / len(rows)))
    md.append("")
    md.append("## Secondary: experiments needed to reach random design's final error (per seed)")
    md.append("")
    md.append("The first crossing of one noisy curve with the other's noisy end point: random_null's row is what "
              "chance alone gives.")
    md.append("")
    rng = random.Random(0)
    for design in designs:
        rows = [r for r in reach_rows if r["design"] == design]
        if not rows:
            continue
        shares = [r["share_of_random"] for r in rows]
        lo, hi = bootstrap_median_ci(shares, rng)
        never = sum(math.isinf(s) for s in shares)
        md.append("- **%s**: median %s of random's experiments (95 %% bootstrap interval of the median %s–%s; per "
                  "seed %s)%s." % (design, pct(median(shares)).replace("never", "never, i.e. more than all"), pct(lo), pct(hi),
                                   ", ".join(pct(s) for s in shares),
                                   "; never within its budget in %d of %d seeds" % (never, len(rows)) if never else ""))
    md.append("")
    md.append("## Against random design, paired by seed")
    md.append("")
    md.append("| design | measure | seeds | median difference (m) | Wilcoxon signed-rank p | sign-flip permutation p |")
    md.append("|---|---|---|---|---|---|")
    for r in test_rows:
        md.append("| %s | %s | %d | %s | %s | %s |" % (r["design"], r["measure"], r["seeds"], fmt(r["median_difference"]),
                                                    fmt(r["wilcoxon_p"], 3), fmt(r["permutation_p"], 3)))
    md.append("")
    md.append("Negative differences: the design's error is lower than random's. With few seeds no test can be "
              "significant (with n seeds the smallest two-sided sign-flip p is 2/2^n).")
    md.append("")
    md.append("## Share of experiments per object")
    md.append("")
    md.append("![share per object](object_share.png)")
    md.append("")
    warm = min(50, args.budget // 2)
    md.append("After the first %d experiments (mean over seeds):" % warm)
    md.append("")
    md.append("| design | " + " | ".join(objects) + " |")
    md.append("|---|" + "---|" * len(objects))
    for design in designs:
        per_seed = []
        for (dd, _), d in data.items():
            rows = [r for r in d["experiments"] if dd == design and int(r["seq"]) > warm]
            if rows:
                per_seed.append([sum(r["object"] == o for r in rows) / len(rows) for o in objects])
        if per_seed:
            md.append("| %s | %s |" % (design, " | ".join(pct(sum(p[i] for p in per_seed) / len(per_seed))
                                                         for i in range(len(objects)))))
    md.append("")
    md.append("## Notions (in how many seeds each was learned)")
    md.append("")
    for design in designs:
        found = {}
        for (dd, _), d in data.items():
            if dd != design:
                continue
            for n in d["notions"]:
                found.setdefault((n["subject"], n["predicate"]), []).append(n["text"])
        runs = sum(1 for (dd, _) in data if dd == design)
        md.append("- **%s** (%d runs): %s" % (design, runs, "; ".join(
            "%s (%d of %d)" % (texts[0], len(texts), runs) for _, texts in sorted(found.items())) or "none"))
    md.append("")
    goal_rows = [{"design": design, "seed": seed, "object": g[0], "reached": int(g[1]), "final_error": g[2],
                  "pushes": g[3]}
                 for (design, seed), d in sorted(data.items()) for g in d["goals"][0]]
    with open(os.path.join(out, "goals.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["design", "seed", "object", "reached", "final_error", "pushes"])
        w.writeheader()
        w.writerows(goal_rows)
    if goal_rows:
        tolerances = sorted({d["goals"][1] for d in data.values() if d["goals"][1] is not None})
        md.append("## Goals reached with the learned model")
        md.append("")
        md.append("After its experiments each cell set %d goals (targets one to several pushes away) and reached each "
                  "with up to a few pushes chosen by the model it had learned; a goal counts as reached within %s. "
                  "Goal pushes are learned from but are not part of the learning curves." % (
                      args.goals, " or ".join("%.1f cm" % (100 * t) for t in tolerances) or "the run's tolerance"))
        md.append("")
        md.append("| design | goals | reached | median final error (m) | mean pushes | reached per object |")
        md.append("|---|---|---|---|---|---|")
        for design in designs:
            rows = [r for r in goal_rows if r["design"] == design]
            if not rows:
                continue
            per_object = []
            for o in objects:
                ro = [r for r in rows if r["object"] == o]
                if ro:
                    per_object.append("%s %d/%d" % (o, sum(r["reached"] for r in ro), len(ro)))
            reached = sum(r["reached"] for r in rows)
            md.append("| %s | %d | %d (%s) | %s | %.1f | %s |" % (
                design, len(rows), reached, pct(reached / len(rows)), fmt(median([r["final_error"] for r in rows])),
                sum(r["pushes"] for r in rows) / len(rows), ", ".join(per_object)))
        md.append("")
    md.append("Files: `cells.csv` (per cell), `learning_curves.csv`/`.png`, `reach.csv`, `tests.csv`, "
              "`object_share.csv`/`.png`, `goals.csv`; each cell's run directory `cells/DESIGN-seedNNN/` holds its knowledge base, "
              "`curve.csv`, `experiments.csv`, `notions.csv` and logs.")
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    return os.path.join(out, "report.md")


def plots(out, designs, curve_rows, share_rows, objects):
    plt = xpersif_plots.pyplot()
    if plt is None:
        return
    fig, ax = plt.subplots(figsize=(8, 5))
    for design in designs:
        rows = [r for r in curve_rows if r["design"] == design]
        # Only where every seed has a point: past the fewest successful experiments of a seed, the mean would be
        # over fewer and fewer seeds (the CSV keeps those rows, with their count).
        everyone = max((r["seeds"] for r in rows), default=0)
        rows = [r for r in rows if r["seeds"] == everyone]
        k = [r["experiments"] for r in rows]
        colour = xpersif_plots.design_colour(design, designs)
        ax.plot(k, [r["mean"] for r in rows], label=design, color=colour)
        ax.fill_between(k, [r["ci_low"] for r in rows], [r["ci_high"] for r in rows], alpha=0.2, color=colour)
    ax.set_title("Learning curves, mean and 95 % interval over seeds")
    xpersif_plots.learning_curve_axes(ax, "experiments learned from (while every seed has that many)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "learning_curves.png"), dpi=100)
    plt.close(fig)
    fig, axes = plt.subplots(1, max(1, len(designs)), figsize=(4.5 * max(1, len(designs)), 4), sharey=True, squeeze=False)
    for ax, design in zip(axes[0], designs):
        rows = [r for r in share_rows if r["design"] == design]
        starts = sorted({r["from"] for r in rows})
        ys = [[next((r["share"] for r in rows if r["from"] == s and r["object"] == o), 0) for s in starts] for o in objects]
        ax.stackplot(starts, ys, labels=objects, step="post")
        ax.set_title(design)
        ax.set_xlabel("experiment")
        ax.set_ylim(0, 1)
    axes[0][0].set_ylabel("share of experiments")
    axes[0][-1].legend(loc="upper right", fontsize="small")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "object_share.png"), dpi=100)
    plt.close(fig)


def check_study_is_there(args):
    """--report-only works on what is there: a directory that holds no study is refused with a sentence."""
    if not os.path.isdir(args.out):
        fail("--report-only: %s does not exist; there is no study to report on" % args.out, 3)
    if not os.path.exists(os.path.join(args.out, "study.json")):
        fail("--report-only: %s holds no study (no study.json: run the study there first)" % args.out, 3)


def check_world(world):
    """A world the runs cannot load (its robot's URDF missing, a malformed file) is refused before any cell starts,
    with `xpersif check-world`'s sentence, instead of every cell failing twice on it."""
    try:
        out = subprocess.run(["xpersif", "check-world", world], capture_output=True, text=True, timeout=600)
    except (OSError, subprocess.TimeoutExpired):
        return  # no checker here: the cells will say what is wrong
    if out.returncode == 3:  # a bad input file (doc/exit-codes.md)
        why = out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "xpersif check-world refused it"
        fail("the world %s cannot be used: %s" % (world, re.sub(r"^xpersif: ", "", why)), 3)


def main(argv):
    args = parse_args(argv)
    if args.report_only:
        check_study_is_there(args)
    else:
        check_world(args.world)
    eval_objects, eval_why = evaluation_objects(args)
    args.eval_objects = eval_objects
    if args.evaluation_size is None:
        args.evaluation_size = EVALUATION_PUSHES_PER_OBJECT * len(eval_objects)
    cells = plan(args, eval_objects)
    if args.report_only and not any(cell.finished() for cell in cells):
        fail("--report-only: no cell of the study in %s has finished; there is nothing to report" % args.out, 3)
    print("study: %s: %d designs x %d seeds x %d experiments, evaluation set %d pushes of %s; %s" % (
        args.out, len(args.designs), len(args.seed_list), args.budget, args.evaluation_size, ", ".join(eval_objects),
        "through Slurm, %d cells per array task%s" % (args.cells_per_task, ", at most %d tasks at once" % args.jobs
                                                        if args.array_limit else "") if args.backend == "slurm" else
        "%d at once" % args.jobs), file=sys.stderr)
    failed = [] if args.report_only else run_cells(args, cells)
    path = report(args, cells, eval_objects, eval_why)
    print("study: report in %s" % path, file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
