"""Sweeps on real cluster software: a one-node Slurm cluster on this machine
(Debian's slurm-wlm and munge) and GNU Parallel over a real ssh login
(Debian's openssh-server), each compared byte for byte with one process.

Every daemon runs from a configuration in the test's temporary folder: its
own munge key and socket, slurm.conf with free ports and its state, spool,
log and pid files there, an sshd with a throwaway host key, user key and
port. No systemd is needed: the daemons run in the foreground as children of
the test, which stops exactly those processes, by PID, when it ends (also
after a failure). The tests need root (slurmd launches jobs as their user,
sshd changes user); without root, or when a daemon cannot start, they are
skipped with the reason.

Run by `make check` with POOLREPS=<abs path to poolreps>.
"""
import csv
import getpass
import os
import shutil
import signal
import socket
import subprocess
import time
from pathlib import Path

import pytest

from conftest import ROOT, run_poolreps, run_cmd
from test_sweep import (EXP1_TINY, SWEEPS, assert_points_match_single_process,
                        assert_summary_is_the_points_summaries, make_sweep, run_ok, wait_for)

pytestmark = pytest.mark.slow

# Experiment 3 at a tiny size: 2 grid points x 2 repetitions x 2 policies = 8 jobs
EXP3_SETS = [s for s in SWEEPS["exp3"][1]
             if not s.startswith(("experiment.repetitions", "exp3.policies"))] + [
    "experiment.repetitions=2", "exp3.policies=nrvr_rs,handcrafted"]
EXP3_GRID = ["value.n_min=12,20"]
WAIT = 60  # seconds: the bound on every wait for a daemon


def clean_env(**extra):
    """This environment without a surrounding Slurm job's variables."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SLURM_", "SBATCH_"))}
    env.update(LC_ALL="C", **extra)
    return env


def free_ports(n):
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


class Daemons:
    """Foreground daemons started by this test, stopped by PID."""

    def __init__(self, folder):
        self.folder = folder
        self.procs = []

    def start(self, name, argv, env):
        log = open(self.folder / f"{name}.out", "wb")
        p = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=env,
                             start_new_session=True)
        log.close()
        self.procs.append((name, p))
        return p

    def check_alive(self):
        for name, p in self.procs:
            if p.poll() is not None:
                self.skip(f"{name} exited with status {p.returncode}")

    def log(self, name):
        path = self.folder / f"{name}.out"
        return path.read_text(errors="replace")[-1500:] if path.exists() else ""

    def skip(self, why):
        logs = " | ".join(f"{n}: {self.log(n).strip()[-400:]}" for n, _ in self.procs)
        self.stop()
        pytest.skip(f"cannot start the daemons: {why}; {logs}")

    def stop(self):
        for _, p in reversed(self.procs):
            if p.poll() is None:
                p.terminate()
        for _, p in reversed(self.procs):
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.procs = []


def need_root(*programs):
    if os.geteuid() != 0:
        pytest.skip("needs root: slurmd and sshd run jobs and logins as the user")
    for prog in programs:
        if not (shutil.which(prog) or os.access(prog, os.X_OK)):
            pytest.skip(f"{prog} not installed (scripts/install-deps.sh installs it)")


# ---- Slurm ----

SLURM_CONF = """\
ClusterName=poolrepstest
SlurmctldHost=localhost(127.0.0.1)
SlurmUser={user}
SlurmdUser=root
SlurmctldPort={ctld_port}
SlurmdPort={d_port}
AuthType=auth/munge
AuthInfo=socket={dir}/munge.socket
CredType=cred/munge
StateSaveLocation={dir}/state
SlurmdSpoolDir={dir}/spool
SlurmctldPidFile={dir}/slurmctld.pid
SlurmdPidFile={dir}/slurmd.pid
SlurmctldLogFile={dir}/slurmctld.log
SlurmdLogFile={dir}/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/builtin
SchedulerParameters=batch_sched_delay=0,sched_min_interval=0
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
KillWait=2
# sbatch --wait polls every 2 s while MinJobAge / 2 allows it (else 8, 32 s...)
MinJobAge=4
NodeName=poolrepsnode NodeHostname={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN
PartitionName=poolreps Nodes=poolrepsnode Default=YES MaxTime=INFINITE State=UP
"""


@pytest.fixture(scope="module")
def slurm(tmp_path_factory):
    """A one-node Slurm cluster: yields the environment its clients need."""
    need_root("munged", "slurmctld", "slurmd", "sbatch", "sinfo")
    d = tmp_path_factory.mktemp("slurm")
    (d / "state").mkdir()
    (d / "spool").mkdir()
    key = d / "munge.key"
    key.write_bytes(os.urandom(1024))
    key.chmod(0o400)
    ctld_port, d_port = free_ports(2)
    conf = d / "slurm.conf"
    conf.write_text(SLURM_CONF.format(user=getpass.getuser(), ctld_port=ctld_port,
                                      d_port=d_port, dir=d, host=socket.gethostname(),
                                      cpus=os.cpu_count() or 1))
    env = clean_env(SLURM_CONF=str(conf))
    daemons = Daemons(d)
    try:
        daemons.start("munged", ["munged", "--foreground", "--force", f"--key-file={key}",
                                 f"--socket={d}/munge.socket", f"--pid-file={d}/munged.pid",
                                 f"--seed-file={d}/munged.seed", f"--log-file={d}/munged.log"],
                      env)
        if not wait_for(lambda: (d / "munge.socket").exists(), WAIT):
            daemons.skip("munged made no socket")
        daemons.start("slurmctld", ["slurmctld", "-D", "-f", str(conf)], env)
        daemons.start("slurmd", ["slurmd", "-D", "-N", "poolrepsnode", "-f", str(conf)], env)

        def idle():
            daemons.check_alive()
            r = run_cmd(["sinfo", "-h", "-n", "poolrepsnode", "-o", "%T"],
                               capture_output=True, text=True, env=env, timeout=WAIT)
            return r.returncode == 0 and r.stdout.strip() == "idle"
        if not wait_for(idle, WAIT):
            daemons.skip("the node did not become idle")
        yield env
    finally:
        # jobs of this private cluster only, then its daemons
        run_cmd(["scancel", "--full", "--user", getpass.getuser()], env=env,
                       capture_output=True, timeout=WAIT)
        daemons.stop()


def sbatch(env, *args, check=True):
    """sbatch --wait: returns once every task ended."""
    r = run_cmd(["sbatch", "--wait", *map(str, args)], capture_output=True, text=True,
                       env=env, timeout=300)
    if check:
        assert r.returncode == 0, r.stdout + r.stderr
    return r


def test_slurm_array_matches_single_process(slurm, tmp_path):
    sweep = tmp_path / "sweep"
    man, jobs = make_sweep(ROOT / "data" / "exp3.ini", sweep, EXP3_SETS, EXP3_GRID, split="both")
    assert len(jobs) == 8
    t0 = time.monotonic()
    r = sbatch(slurm, sweep / "slurm.sbatch")
    print(f"slurm: 8 jobs in {time.monotonic() - t0:.1f} s")
    job = r.stdout.split()[-1]
    logs = sorted(p.name for p in (sweep / "logs").iterdir())
    assert logs == [f"{job}_{i}.out" for i in sorted(range(8), key=str)], logs
    for m in man:
        assert (sweep / m["output"] / "provenance.txt").is_file(), m["output"]
    run_ok(["collect", "-q", sweep])
    assert_points_match_single_process(sweep, tmp_path)
    assert_summary_is_the_points_summaries(sweep, ["value.n_min"], "exp3_final.csv")


def test_slurm_killed_job_is_named_and_resubmitted(slurm, tmp_path):
    """One array task's poolreps killed on purpose while it runs (SIGKILL, as
    by the out-of-memory killer): Slurm reports the failure, collect names
    the job and its leftover folder, --missing lists it, a second array runs
    it, and the result is complete and identical to one process."""
    sweep = tmp_path / "sweep"
    # 500 iterations: the victim must still run when the kill reaches it (~0.5 s)
    man, jobs = make_sweep(ROOT / "data" / "exp3.ini", sweep, EXP3_SETS + ["exp3.iterations=500"],
                           split="both")
    victim = next(j for j, m in enumerate(man) if m["variant_name"] == "nrvr_rs" and j > 0)
    out = sweep / man[victim]["output"]
    p = subprocess.Popen(["sbatch", "--wait", str(sweep / "slurm.sbatch")], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=slurm)
    try:
        assert wait_for(lambda: out.is_dir() and any(out.glob(".partial-*")), 120)
        # the staging folder .partial-PID names the job's process
        pid = int(next(out.glob(".partial-*")).name.split("-")[1])
        assert Path(f"/proc/{pid}/exe").resolve() == Path(jobs[victim].split()[0]).resolve()
        os.kill(pid, signal.SIGKILL)
        _, stderr = p.communicate(timeout=300)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode != 0, "sbatch --wait reports the killed task"
    if (out / "provenance.txt").exists():
        pytest.fail("the task finished before the kill reached it")
    r = run_poolreps(["collect", sweep])
    err = r.stderr.decode()
    assert r.returncode == 2 and err.count("\n") == 1, err
    assert f"1 of {len(jobs)} jobs not done" in err
    m = man[victim]
    assert (f"job {victim} (point 0, repetition {m['repetition']}, variant nrvr_rs) failed: "
            f"incomplete folder {m['output']}") in err
    assert not (sweep / "sweep_summary.csv").exists()
    retry = tmp_path / "retry.txt"
    retry.write_bytes(run_ok(["sweep", "--missing", sweep]).stdout)
    assert retry.read_text().splitlines() == [jobs[victim]]
    sbatch(slurm, "--array=0-0", sweep / "slurm.sbatch", retry)
    run_ok(["collect", "-q", sweep])
    assert_points_match_single_process(sweep, tmp_path)


# ---- GNU Parallel over ssh ----

SSHD_CONFIG = """\
Port {port}
ListenAddress 127.0.0.1
HostKey {dir}/host_key
PidFile {dir}/sshd.pid
AuthorizedKeysFile {dir}/authorized_keys
AllowUsers {user}
PermitRootLogin prohibit-password
PubkeyAuthentication yes
PasswordAuthentication no
KbdInteractiveAuthentication no
UsePAM no
StrictModes no
"""

SSH_CONFIG = """\
Host poolrepstest
  HostName 127.0.0.1
  Port {port}
  User {user}
  IdentityFile {dir}/user_key
  IdentitiesOnly yes
  UserKnownHostsFile {dir}/known_hosts
  StrictHostKeyChecking yes
  BatchMode yes
"""


@pytest.fixture(scope="module")
def ssh(tmp_path_factory):
    """An sshd on 127.0.0.1: yields the ssh command that logs into it."""
    sshd = "/usr/sbin/sshd"
    need_root(sshd, "ssh", "ssh-keygen", "parallel")
    d = tmp_path_factory.mktemp("ssh")
    for k in ("host_key", "user_key"):
        run_cmd(["ssh-keygen", "-q", "-t", "ed25519", "-N", "", "-f", d / k], check=True,
                       timeout=WAIT)
    (d / "authorized_keys").write_bytes((d / "user_key.pub").read_bytes())
    (port,) = free_ports(1)
    user = getpass.getuser()
    (d / "sshd_config").write_text(SSHD_CONFIG.format(port=port, dir=d, user=user))
    (d / "ssh_config").write_text(SSH_CONFIG.format(port=port, dir=d, user=user))
    host_key = (d / "host_key.pub").read_text().split()
    (d / "known_hosts").write_text(f"[127.0.0.1]:{port} {host_key[0]} {host_key[1]}\n")
    command = f"ssh -F {d}/ssh_config"
    # sshd insists on its privilege separation folder; make it only if missing
    privsep = Path("/run/sshd")
    made = not privsep.exists()
    daemons = Daemons(d)
    try:
        if made:
            privsep.mkdir(mode=0o755, parents=True)
        daemons.start("sshd", [sshd, "-D", "-e", "-f", str(d / "sshd_config")], clean_env())

        def login():
            daemons.check_alive()
            r = run_cmd(command.split() + ["poolrepstest", "true"], capture_output=True,
                               env=clean_env(), timeout=WAIT)
            return r.returncode == 0
        if not wait_for(login, WAIT):
            daemons.skip("no ssh login to 127.0.0.1")
        yield command, d
    finally:
        daemons.stop()
        if made:
            privsep.rmdir()


def test_parallel_over_ssh_matches_single_process(ssh, tmp_path):
    """Experiment 1 over a 2-point grid, every setting a job, through the
    sweep's parallel.sh with --sshlogin: 2 jobs at once on the ssh host."""
    command, d = ssh
    sweep = tmp_path / "sweep"
    man, jobs = make_sweep(ROOT / "data" / "exp1.ini", sweep, EXP1_TINY, ["forest.cuts=2,4"],
                           split="variant")
    assert len(jobs) == 16
    t0 = time.monotonic()
    r = run_cmd(["sh", sweep / "parallel.sh", "--ssh", command, "--sshlogin",
                        "2/poolrepstest", "--halt", "now,fail=1"], capture_output=True, text=True,
                       env=clean_env(), timeout=300)
    print(f"parallel over ssh: {len(jobs)} jobs in {time.monotonic() - t0:.1f} s")
    assert r.returncode == 0, r.stdout + r.stderr
    # every job ran on the ssh host, each through a login of its own
    log = list(csv.DictReader(open(sweep / "parallel.log", newline=""), delimiter="\t"))
    assert len(log) == len(jobs)
    assert {row["Host"] for row in log} == {"poolrepstest"}
    assert {row["Exitval"] for row in log} == {"0"}
    assert (d / "sshd.out").read_text().count("Accepted publickey") >= len(jobs)
    run_ok(["collect", "-q", sweep])
    assert_points_match_single_process(sweep, tmp_path)
    assert_summary_is_the_points_summaries(sweep, ["forest.cuts"], "exp1_summary.csv")
