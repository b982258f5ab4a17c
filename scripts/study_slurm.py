#!/usr/bin/python3
"""A study's cells as Slurm job arrays (issue 39; doc/slurm.md): the backend scripts/study.py uses with
`--backend slurm`, and the array task that runs cells on a node.

The runner (study.py's run_cells) hands this backend the cells that are ready; at the end of each round they go out
as one job array (`sbatch --array`), --cells-per-task cells per task. A task runs its cells one after the other
exactly as the local backend does (study.start: a ROS master of its own on a free port, ROS_LOG_DIR and the run
directory under the study's directory, which must be on a filesystem every node shares) and writes, after each cell,
`slurm_exit` ("CODE SENTENCE") into the cell's run directory. The runner watches those files, the cells' consoles
(progress) and `squeue`; a task that left the queue without finishing a cell fails that cell with Slurm's reason
(`sacct` where the cluster keeps accounting, `scontrol show job` otherwise). Jobs are submitted with --no-requeue:
the runner, not Slurm, submits a failed cell once more, so that a cell is tried twice at most whatever failed.
Every submitted array is recorded in OUT/slurm/jobs.json: the same command again adopts the cells of this study's
arrays that are still queued or running instead of submitting them twice. Ctrl-C or SIGTERM cancels them (scancel).

    study_slurm.py task MANIFEST      (run by OUT/slurm/task.sh inside an array task)
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study  # noqa: E402  (scripts/, beside this file)

EXIT_FILE = "slurm_exit"
GONE_GRACE_S = 10.0
MAX_ARRAY = 1000  # tasks per array: Slurm's MaxArraySize is 1001 unless a site raises it
TASK_SCRIPT = """#!/bin/bash
# Written by scripts/study_slurm.py: one array task of the study in %(out)s (doc/slurm.md). It sets up the build's
# environment (%(repo)s/scripts/env.sh: the devel space of %(repo)s/build) and runs the task's cells.
set -eo pipefail
source %(repo)s/scripts/env.sh
exec /usr/bin/python3 %(repo)s/scripts/study_slurm.py task "$1"
"""


def run(command):
    """(exit code, stdout, stderr) of a Slurm client command; 127 when it is not there."""
    try:
        out = subprocess.run(command, capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as e:
        return 127, "", str(e)
    return out.returncode, out.stdout, out.stderr.strip()


class SlurmCells:
    """The cells of one study on Slurm: start (prepare) cells, submit them as one array, poll, cancel."""
    slots = float("inf")  # Slurm queues what the cluster cannot run yet

    def __init__(self, args):
        for tool in ("sbatch", "squeue", "scancel", "scontrol"):
            if not shutil.which(tool):
                study.fail("--backend slurm: '%s' is not on the PATH; run the study where Slurm's client commands are "
                           "(a login node; Debian: slurm-client)" % tool)
        self.args = args
        self.dir = os.path.join(args.out, "slurm")
        os.makedirs(self.dir, exist_ok=True)
        self.jobs_file = os.path.join(self.dir, "jobs.json")
        self.name = "xpersif-study-%s" % os.path.basename(args.out.rstrip("/"))
        self.pending = []  # cells prepared this round, not submitted yet
        self.where = {}  # cell name -> "JOBID_TASK"
        self.queue_seen, self.queue_time, self.queue_warned = None, 0.0, 0.0
        self.submitted = 0
        self.gone = {}  # cell name -> when its task was first seen out of the queue without its exit file
        with open(os.path.join(self.dir, "task.sh"), "w") as f:
            f.write(TASK_SCRIPT % {"out": args.out, "repo": study.REPO})

    def jobs(self):
        try:
            with open(self.jobs_file) as f:
                return json.load(f)
        except (OSError, ValueError):
            return {}

    def queued(self, fresh=False):
        """The set of "JOBID_TASK" of this study's array tasks still in the queue; None when squeue cannot say."""
        if fresh or self.queue_seen is None or time.time() - self.queue_time > 0.9:
            code, out, err = run(["squeue", "-h", "-r", "-n", self.name, "-o", "%i|%T"])
            if code != 0:
                if time.time() - self.queue_warned > 60:
                    print("\nstudy: squeue failed (%s); waiting for the controller" % (err or "exit %d" % code),
                          file=sys.stderr)
                    self.queue_warned = time.time()
                return None
            self.queue_seen = {line.split("|")[0] for line in out.split()}
            self.queue_time = time.time()
        return self.queue_seen

    def adopt(self, cells):
        """The cells of this study's arrays that are still queued or running (a runner before this one submitted
        them): they are watched, not submitted again."""
        queued = self.queued(fresh=True) or set()
        by_name = {c.name: c for c in cells}
        adopted = []
        for job, manifest in self.jobs().items():
            try:
                with open(manifest) as f:
                    tasks = json.load(f)["tasks"]
            except (OSError, ValueError, KeyError):
                continue
            for index, task in enumerate(tasks):
                where = "%s_%d" % (job, index)
                for entry in task:
                    cell = by_name.get(entry["name"])
                    if where in queued and cell and cell not in adopted and \
                            not os.path.exists(os.path.join(cell.run_dir, EXIT_FILE)):
                        self.where[cell.name] = where
                        cell.attempts = 1
                        adopted.append(cell)
        if adopted:
            print("study: %d cells are still queued or running in Slurm (%s); watching them" % (
                len(adopted), ", ".join(sorted({self.where[c.name].split("_")[0] for c in adopted}))), file=sys.stderr)
        return adopted

    def start(self, cell):
        """Prepare the cell (an empty run directory: nothing left from an earlier attempt); submit() sends it."""
        if os.path.exists(cell.run_dir):
            shutil.rmtree(cell.run_dir)
        os.makedirs(cell.run_dir)
        cell.attempts += 1
        cell.done_units = 0
        cell.started = time.time()
        self.gone.pop(cell.name, None)
        self.pending.append(cell)

    def sbatch_command(self, tasks, manifest):
        a = self.args
        limit = "%%%d" % a.array_limit if a.array_limit else ""
        command = ["sbatch", "--parsable", "--array=0-%d%s" % (tasks - 1, limit), "--job-name=" + self.name,
                   "--output=" + os.path.join(self.dir, "%A_%a.out"), "--chdir=" + self.dir, "--no-requeue"]
        for option, value in (("--partition", a.partition), ("--time", a.time), ("--mem", a.mem)):
            if value:
                command.append("%s=%s" % (option, value))
        return command + list(a.sbatch_arg) + [os.path.join(self.dir, "task.sh"), manifest]

    def submit(self):
        """The cells prepared this round as one job array (several when they are more than MAX_ARRAY tasks)."""
        k = self.args.cells_per_task
        tasks = [self.pending[i:i + k] for i in range(0, len(self.pending), k)]
        for i in range(0, len(tasks), MAX_ARRAY):
            self.submit_array(tasks[i:i + MAX_ARRAY])
        self.pending = []

    def submit_array(self, tasks):
        jobs = self.jobs()
        manifest = os.path.join(self.dir, "round-%03d.json" % (len(jobs) + 1))
        with open(manifest, "w") as f:
            json.dump({"out": self.args.out, "timeout": self.args.timeout,
                       "tasks": [[{"name": c.name, "file": c.file, "run_dir": c.run_dir, "experiments": c.experiments}
                                  for c in task] for task in tasks]}, f, indent=1)
        code, out, err = run(self.sbatch_command(len(tasks), manifest))
        if code != 0 or not out.strip().split(";")[0].isdigit():
            later = "; the arrays submitted before keep running: the same command again watches them"
            study.fail("sbatch refused the array: %s%s" % (err or out.strip() or "exit %d" % code,
                                                           later if self.submitted else ""),
                       2 if self.submitted == 0 else 1)
        job = out.strip().split(";")[0]
        jobs[job] = manifest
        with open(self.jobs_file, "w") as f:
            json.dump(jobs, f, indent=1)
        for index, task in enumerate(tasks):
            for cell in task:
                self.where[cell.name] = "%s_%d" % (job, index)
        self.submitted += 1
        self.queue_seen = None  # the new tasks are not in the last answer

    def poll(self, cell):
        """The cell's exit code (its task wrote it), None while it is queued or running, 1 when its task left the
        queue without it (cell.outcome then holds Slurm's reason)."""
        exit_file = os.path.join(cell.run_dir, EXIT_FILE)
        if not os.path.exists(exit_file):
            queued = self.queued()
            if queued is None or self.where[cell.name] in queued:
                return None
            # A shared filesystem may show the task's last file late (NFS caches attributes): a grace period.
            gone = self.gone.setdefault(cell.name, time.time())
            if time.time() - gone < GONE_GRACE_S:
                return None
            if not os.path.exists(exit_file):
                where = self.where[cell.name]
                cell.outcome = (1, "its Slurm task %s ended without it: %s" % (where, self.reason(where)))
                return 1
        try:
            with open(exit_file) as f:
                code, _, sentence = f.read().strip().partition(" ")
            code = int(code)
        except (OSError, ValueError):
            code, sentence = 1, "unreadable %s" % exit_file
        status = cell.status()
        if code != 0 or not cell.finished():
            own = status[1] if status and status[0] != 0 else sentence
            cell.outcome = (1, "%s (Slurm task %s)" % (own, self.where[cell.name]))
        return code

    def reason(self, where):
        """Slurm's word on an array task that ended: sacct where there is accounting, else scontrol."""
        code, out, _ = run(["sacct", "-n", "-P", "-X", "-j", where, "-o", "State,Reason,ExitCode"])
        line = out.strip().splitlines()[-1] if code == 0 and out.strip() else ""
        if line:
            state, reason, exit_code = (line.split("|") + ["", "", ""])[:3]
            return "State=%s Reason=%s ExitCode=%s (sacct)" % (state, reason, exit_code)
        code, out, _ = run(["scontrol", "-o", "show", "job", where])
        if code == 0 and out.strip():
            fields = dict(w.split("=", 1) for w in out.split() if "=" in w)
            return "State=%s Reason=%s ExitCode=%s (scontrol)" % (
                fields.get("JobState", "?"), fields.get("Reason", "?"), fields.get("ExitCode", "?"))
        return "Slurm no longer knows the task (no accounting, and past MinJobAge)"

    def stop(self, cells):
        """Cancel the arrays of these cells (Ctrl-C, SIGTERM)."""
        jobs = {self.where[c.name].split("_")[0] for c in cells if c.name in self.where}
        if jobs:
            run(["scancel"] + sorted(jobs))
            print("study: cancelled Slurm job%s %s" % ("s" if len(jobs) > 1 else "", " ".join(sorted(jobs))),
                  file=sys.stderr)


# ---- the array task -------------------------------------------------------------------------------------------

def run_task(manifest_path):
    """Run this array task's cells (SLURM_ARRAY_TASK_ID) one after the other, each as study.start does."""
    with open(manifest_path) as f:
        manifest = json.load(f)
    index = int(os.environ["SLURM_ARRAY_TASK_ID"])

    def stopped(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stopped)
    worst = 0
    for entry in manifest["tasks"][index]:
        cell = study.Cell(entry["name"], None, None, entry["experiments"], entry["file"], entry["run_dir"])
        try:
            study.start(cell)
            code, sentence = wait(cell, manifest["timeout"])
        except KeyboardInterrupt:
            study.stop(cell)
            write_exit(cell, 143, "stopped by Slurm (SIGTERM: scancel, or the job's time limit)")
            return 143
        write_exit(cell, code, sentence)
        worst = worst or code
    return worst


def wait(cell, timeout):
    while True:
        code = cell.process.poll()
        if code is not None:
            return code, "roslaunch exited %d" % code
        if time.time() - cell.started > timeout:
            study.stop(cell)
            return 1, "timed out after %d s" % timeout
        time.sleep(1.0)


def write_exit(cell, code, sentence):
    with open(os.path.join(cell.run_dir, EXIT_FILE), "w") as f:
        f.write("%d %s\n" % (code, sentence))
    print("%s: %s on %s" % (cell.name, sentence, os.environ.get("SLURMD_NODENAME", os.uname().nodename)), flush=True)


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] != "task":
        print("usage: study_slurm.py task MANIFEST   (run by a study's OUT/slurm/task.sh in a Slurm array task)",
              file=sys.stderr)
        sys.exit(2)
    sys.exit(run_task(sys.argv[2]))
