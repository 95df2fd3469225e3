"""The study as a Slurm array: a single-node Slurm started here, a tiny study run by
scripts/study_slurm.sh as an array of 4 shards into one --out, and the report made
by the job that follows them.

The cluster is the test's own: munged with its own key and socket, slurmctld and
slurmd on localhost with their own ports, state and logs under --out
(proctrack/linuxproc, task/none: no cgroups), all as this user.  Checks that the
4 shards ran (one invocation each, every planned run done once) and that the report
job wrote the report from all of them.  Skips (exit 77) with the reason when
Slurm is not installed (Debian: slurmctld slurmd slurm-client munge), when it
cannot start here, or without matplotlib; stops only the daemons it started.
"""
import getpass
import json
import os
import pathlib
import shutil
import signal
import socket
import subprocess
import sys
import time

from check_quick import STUDY, arguments_or_skip, check

SLURM = STUDY.parent / "study_slurm.sh"
DAEMONS = ("munged", "slurmctld", "slurmd", "sbatch", "sinfo", "squeue")
SHARDS = 4
TINY = ["--quick", "--threads", "1", "--experiments", "sweep,pairs", "--scenes", "1,4",
        "--objects", "40,60", "--algos", "bvh,cpubf,cpusap", "--frames", "3",
        "--figure-objects", "40", "--pairs-objects", "40", "--pairs-frames", "3",
        "--pairs-algos", "bf,cpusap"]


def skip(reason: str) -> int:
    print(f"SKIP: {reason}")
    return 77


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def slurm_conf(root: pathlib.Path, host: str) -> str:
    user = getpass.getuser()
    return "\n".join([
        "ClusterName=overlaptest", f"SlurmctldHost={host}(127.0.0.1)",
        f"SlurmUser={user}", f"SlurmdUser={user}",
        f"SlurmctldPort={free_port()}", f"SlurmdPort={free_port()}",
        "AuthType=auth/munge", f"AuthInfo=socket={root}/munge.socket",
        f"StateSaveLocation={root}/state", f"SlurmdSpoolDir={root}/spool",
        f"SlurmctldPidFile={root}/slurmctld.pid", f"SlurmdPidFile={root}/slurmd.pid",
        f"SlurmctldLogFile={root}/slurmctld.log", f"SlurmdLogFile={root}/slurmd.log",
        "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none",
        "JobAcctGatherType=jobacct_gather/none", "AccountingStorageType=accounting_storage/none",
        "JobCompType=jobcomp/none", "MpiDefault=none", "SchedulerType=sched/builtin",
        "SelectType=select/cons_tres", "SelectTypeParameters=CR_Core", "ReturnToService=2",
        "SlurmctldTimeout=30", "SlurmdTimeout=30", "InactiveLimit=0", "KillWait=5",
        f"NodeName=testnode NodeAddr=127.0.0.1 CPUs={os.cpu_count()} State=UNKNOWN",
        "PartitionName=test Nodes=testnode Default=YES MaxTime=INFINITE State=UP", ""])


class Cluster:
    """munged, slurmctld and slurmd of this test, under `root`; stop() ends only them."""

    def __init__(self, root: pathlib.Path):
        self.root, self.daemons = root, []
        for folder in ("state", "spool"):
            (root / folder).mkdir(parents=True)
        (root / "slurm.conf").write_text(slurm_conf(root, socket.gethostname().split(".")[0]))
        self.env = {**os.environ, "SLURM_CONF": str(root / "slurm.conf")}

    def start(self) -> str:
        """Starts the daemons; returns why the cluster could not start, or ''."""
        key = self.root / "munge.key"
        key.write_bytes(os.urandom(1024))
        key.chmod(0o600)
        r = self.root
        self.spawn(["munged", "-F", "--force", f"--key-file={key}", f"--socket={r}/munge.socket",
                    f"--pid-file={r}/munged.pid", f"--log-file={r}/munged.log",
                    f"--seed-file={r}/munged.seed"])
        time.sleep(0.5)
        conf = str(r / "slurm.conf")
        self.spawn(["slurmctld", "-D", "-i", "-f", conf])
        self.spawn(["slurmd", "-D", "-N", "testnode", "-f", conf])
        return self.wait_idle()

    def spawn(self, command: list) -> None:
        log = open(self.root / f"{command[0]}.out", "w")
        self.daemons.append(subprocess.Popen(command, env=self.env, stdout=log,
                                             stderr=subprocess.STDOUT))

    def wait_idle(self, seconds: float = 30) -> str:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            dead = [d.args[0] for d in self.daemons if d.poll() is not None]
            if dead:
                return f"{', '.join(dead)} stopped at start: {self.logs()}"
            state = subprocess.run(["sinfo", "-h", "-N", "-o", "%t"], env=self.env,
                                   capture_output=True, text=True).stdout.strip()
            if state in ("idle", "mix"):
                return ""
            time.sleep(0.5)
        return f"the node never became idle: {self.logs()}"

    def logs(self) -> str:
        return " | ".join(f"{p.name}: {p.read_text()[-300:].strip()}"
                          for p in sorted(self.root.glob("*.log")) + sorted(self.root.glob("*.out"))
                          if p.stat().st_size)

    def stop(self) -> None:
        for daemon in reversed(self.daemons):
            if daemon.poll() is None:
                daemon.send_signal(signal.SIGTERM)
                try:
                    daemon.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    daemon.kill()
                    daemon.wait()


def check_study(out: pathlib.Path, ran: subprocess.CompletedProcess) -> None:
    check(ran.returncode == 0, f"study_slurm.sh exited {ran.returncode}:\n{ran.stdout}"
          f"{ran.stderr}\n" + "\n".join(p.read_text()[-600:] for p in (out / "slurm").glob("*.log")))
    log = json.loads((out / "study_invocations.json").read_text())
    shards = sorted(entry["argv"][entry["argv"].index("--shard") + 1] for entry in log
                    if "--shard" in entry["argv"])
    check(shards == [f"{i}/{SHARDS}" for i in range(1, SHARDS + 1)],
          f"the shards that ran: {shards}")
    keys = [job["key"] for entry in log for job in entry.get("jobs", [])]
    check(len(keys) == len(set(keys)) == 2 * 2 * 3 + 2, f"the runs: {sorted(keys)}")
    report = (out / "REPORT.md").read_text()
    check("## Findings" in report and "What ran beside what" in report,
          "the report job wrote no report")
    check("study: report:" in (out / "slurm" / "report.log").read_text(),
          "the report job's log does not name the report")


def main() -> int:
    missing = [name for name in DAEMONS if shutil.which(name) is None]
    if missing:
        return skip(f"Slurm is not installed ({', '.join(missing)} not on PATH; Debian: "
                    "apt-get install slurmctld slurmd slurm-client munge)")
    args = arguments_or_skip()
    if args is None:
        return 77
    cluster = Cluster(args.out / "cluster")
    try:
        why = cluster.start()
        if why:
            return skip(f"a single-node Slurm cannot start here: {why}")
        started = time.monotonic()
        out = args.out / "study"
        ran = subprocess.run(["bash", str(SLURM), "--out", str(out), "--shards", str(SHARDS),
                              "--profile", "quick", "--wait", "--", "--overlap", args.overlap,
                              "--emulation", str(args.out / "no-emulation"), *TINY[1:]],
                             env=cluster.env, capture_output=True, text=True, timeout=150)
        check_study(out, ran)
    finally:
        cluster.stop()
    print(f"study.slurm: {SHARDS} shards as a Slurm array and the report after them, "
          f"{time.monotonic() - started:.1f} s: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
