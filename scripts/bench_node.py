#!/usr/bin/env python3
"""Measure the node, and a bare rclpy echo, under a setpoint stream (docs/node.md,
"Executor"; docs/performance.md).

Three roles, each its own process:

* the **target**: the node (``python -m flight_sim_dynamics.node --executor E``
  with the packaged parameters) or the bare echo (``python scripts/bench_node.py
  echo``: PoseStamped in, JointState out, nothing else);
* the **driver** (``python scripts/bench_node.py drive ...``): publishes pose +
  twist + accel with one stamp per sample (``--input trajectory``: one
  ``trajectory_msgs/JointTrajectory`` per sample on ``platform_setpoint``
  instead) at a fixed rate (the paper's general
  motion then the motion-cueing sequence, looped; reliable QoS, KEEP_LAST depth
  = the node's ``qos.depth``), receives ``actuator_states`` and records, per
  sample, the time just before its pose was published and the time its
  JointState arrived (both CLOCK_MONOTONIC, which all processes of the machine
  share), plus every ``/diagnostics`` message. It publishes messages
  serialized once before the stream (per sample only the stamp is put in) and
  takes ``actuator_states`` serialized (only the stamp is read), so that its
  own Python message conversions (tens of microseconds per message, on the
  measured path of both targets, and for the node twice more: its twist and
  accel go out after the pose) stay out of the latency; ``--python-messages``
  restores message objects;
* this script's caller (:func:`run_stream`, no rclpy): starts both, samples the
  target's resident memory and CPU time (per thread) from /proc, stops everything.

``python scripts/bench_node.py profiled-node OUT [node arguments]`` runs the node
with cProfile enabled from SIGUSR1 on (:func:`run_stream` sends it when the
measured stream starts) and writes the stats to OUT when it exits.

The default command prints the executor table of docs/node.md:

    python scripts/bench_node.py [--rates 200 500] [--seconds 3] [--executors events single]
                                 [--echo] [--inputs topics trajectory] [--repeat 1]
                                 [--python-messages] [--domain-id 87]

"driver publishing" is the time the driver takes to publish one sample (three
messages with the topics, one with the trajectory); "after publishing" is the
latency counted from the end of that instead of its start. Every row also
gives the hypervisor's steal over the stream (``steal %``, from
/proc/stat): on a virtual machine a stolen core stalls every process on it,
which no executor or node code can avoid.

``benchmarks/performance.py`` uses :func:`run_stream` for its node, echo and
soak sections.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import queue
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

PARAMS_FILE = ROOT / 'config' / 'flight_sim_dynamics.yaml'
STAMP_BASE_S = 1_700_000_000          # stamps: base + k / rate (k = sample index)
LEG_NAMES = ('leg_a', 'leg_b', 'leg_c')
#: A stream "keeps up" when nothing is lost and its p99 latency stays below
#: this fraction of the time a full queue (qos.depth samples) represents at
#: the stream's rate: no standing backlog (at 1 kHz and depth 1000: 500 ms).
KEEPS_UP_QUEUE_FRACTION = 0.5
#: How the driver sends a setpoint to the node: 'topics' = PoseStamped on
#: pose_setpoint + TwistStamped on twist_setpoint + AccelStamped on
#: accel_setpoint; 'trajectory' = one trajectory_msgs/JointTrajectory (names
#: surge, heave, roll; one point) on platform_setpoint (docs/node.md).
SETPOINT_INPUTS = ('topics', 'trajectory')


# ----------------------------------------------------------------------------
# Environment and processes (no rclpy in this part)
# ----------------------------------------------------------------------------
def ros_env(domain_id: int | None = None) -> dict[str, str]:
    """The environment of every ROS process started here: own domain, discovery
    on this machine only, the repository importable, unbuffered output."""
    env = dict(os.environ)
    if domain_id is not None:
        env['ROS_DOMAIN_ID'] = str(domain_id)
    elif not env.get('ROS_DOMAIN_ID'):
        env['ROS_DOMAIN_ID'] = str(random.randint(1, 100))
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['PYTHONPATH'] = os.pathsep.join(filter(None, [str(ROOT), env.get('PYTHONPATH')]))
    env['PYTHONUNBUFFERED'] = '1'
    env.setdefault('RCUTILS_LOGGING_BUFFERED_STREAM', '0')
    return env


def node_qos_depth(params_file: Path = PARAMS_FILE) -> int:
    """KEEP_LAST depth of the node's setpoints and outputs: its default QoS
    (changed only by ``qos_overrides.*`` start-up parameters, which
    ``params_file`` does not set: a params file with them is refused here)."""
    from flight_sim_dynamics.config import parameters as prm
    from flight_sim_dynamics.ros.dynamics_node import default_qos

    if params_file.is_file() and any(k.startswith('qos_overrides.')
                                     for k in prm.read_params_file(params_file)):
        raise ValueError(f'{params_file} sets qos_overrides: pass --depth instead')
    return default_qos().depth


def node_command(executor: str = 'events', params_file: Path | None = PARAMS_FILE,
                 cprofile_out: Path | None = None) -> list[str]:
    """The node as a user starts it; with ``cprofile_out``, through
    :func:`profiled_node_main` (cProfile enabled on SIGUSR1, written at exit)."""
    if cprofile_out is not None:
        cmd = [sys.executable, str(Path(__file__).resolve()), 'profiled-node',
               str(cprofile_out)]
    else:
        cmd = [sys.executable, '-m', 'flight_sim_dynamics.ros.node']
    cmd += ['--executor', executor, '--ros-args']
    if params_file is not None:
        cmd += ['--params-file', str(params_file)]
    return cmd


def echo_command(executor: str = 'events', depth: int = 1000) -> list[str]:
    return [sys.executable, str(Path(__file__).resolve()), 'echo', '--executor', executor,
            '--depth', str(depth)]


class Proc:
    """A child process with its output in a log file; always stopped with
    :meth:`stop` (SIGINT as Ctrl-C, then SIGKILL)."""

    def __init__(self, cmd: Sequence[str], env: dict[str, str], log: Path,
                 stdout_pipe: bool = False) -> None:
        self.cmd = list(cmd)
        self.log_path = log
        self._log = open(log, 'w')
        self.proc = subprocess.Popen(
            self.cmd, cwd=ROOT, env=env,
            stdout=subprocess.PIPE if stdout_pipe else self._log,
            stderr=self._log if stdout_pipe else subprocess.STDOUT,
            text=True, start_new_session=True)
        self.pid = self.proc.pid

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout: float = 10.0) -> int | None:
        if self.proc.poll() is None:
            try:
                self.proc.send_signal(signal.SIGINT)
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        self._log.close()
        return self.proc.returncode

    def output(self) -> str:
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors='replace')


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far (all its threads)."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def thread_cpu(pid: int) -> dict[int, tuple[str, float]]:
    """CPU time (user + system, s) of each thread of a process: {tid: (name, s)}."""
    out = {}
    tick = os.sysconf('SC_CLK_TCK')
    for task in Path(f'/proc/{pid}/task').iterdir():
        try:
            fields = (task / 'stat').read_text().rsplit(')', 1)[1].split()
            name = (task / 'comm').read_text().strip()
        except OSError:          # the thread ended meanwhile
            continue
        out[int(task.name)] = (name, (int(fields[11]) + int(fields[12])) / tick)
    return out


def thread_cpu_delta(pid: int, before: dict, after: dict) -> tuple[float, list]:
    """(CPU s of the main thread, [(thread name, CPU s), ...] of the others,
    summed by name, largest first) between two :func:`thread_cpu` readings."""
    main = after.get(pid, ('', 0.0))[1] - before.get(pid, ('', 0.0))[1]
    others: dict[str, float] = {}
    for tid, (name, cpu) in after.items():
        if tid == pid:
            continue
        others[name] = others.get(name, 0.0) + cpu - before.get(tid, (name, 0.0))[1]
    return main, sorted(others.items(), key=lambda kv: -kv[1])


def rss_kb(pid: int) -> int:
    """VmRSS of a process, kB (from /proc/<pid>/status)."""
    for line in Path(f'/proc/{pid}/status').read_text().splitlines():
        if line.startswith('VmRSS:'):
            return int(line.split()[1])
    return -1


def host_cpu_jiffies() -> tuple[int, int]:
    """(steal, total) CPU time of the whole machine so far, in clock ticks, from
    the first line of /proc/stat. Steal is the time the hypervisor ran something
    else while this (virtual) machine had work: a stall no process here can
    avoid. (0, 0) where /proc/stat has no steal column."""
    try:
        with open('/proc/stat') as f:
            fields = f.readline().split()
        ticks = [int(x) for x in fields[1:9]]
    except (OSError, ValueError, IndexError):   # pragma: no cover
        return 0, 0
    return (ticks[7], sum(ticks)) if len(ticks) == 8 else (0, 0)


def steal_percent(before: tuple[int, int], after: tuple[int, int]) -> float:
    """Share (%) of the machine's CPU time stolen by the hypervisor between two
    :func:`host_cpu_jiffies` readings (nan if unknown)."""
    total = after[1] - before[1]
    return 100.0 * (after[0] - before[0]) / total if total > 0 else math.nan


def load_average() -> tuple[float, float, float]:
    try:
        return os.getloadavg()
    except OSError:   # pragma: no cover
        return (math.nan,) * 3


# ----------------------------------------------------------------------------
# One stream: target + driver
# ----------------------------------------------------------------------------
@dataclass
class StreamResult:
    """What one stream measured. Times in ms unless named otherwise."""

    kind: str                   # 'node' or 'echo'
    executor: str
    setpoint_input: str         # 'topics' (pose + twist + accel) or 'trajectory' (one message)
    rate: float
    depth: int                  # KEEP_LAST depth of every endpoint
    seconds: float
    sent: int
    answered: int
    lost: int
    latency_ms: np.ndarray      # per answered sample, publish -> receipt
    send_times: np.ndarray      # monotonic s, per sample
    recv_times: np.ndarray      # monotonic s, nan = never received
    publisher_late_ms: np.ndarray     # send time - scheduled time, per sample
    target_cpu_s: float         # CPU time of the target over the stream (+ drain)
    stream_wall_s: float        # first publish -> last publish or receipt
    drain_s: float              # last publish -> last receipt (or drain timeout)
    duplicates: int
    discovery_s: float
    diagnostics: list = field(default_factory=list)   # (monotonic s, {key: value})
    # (s since start, rss kB, cpu s, load 1 min, machine steal ticks, machine total ticks)
    memory: list = field(default_factory=list)
    main_thread_cpu_s: float = math.nan        # the Python (main) thread's share of target_cpu_s
    other_threads_cpu: list = field(default_factory=list)   # [(name, CPU s)], DDS & co.
    load: tuple = (math.nan,) * 3                     # load average at the end
    load_start: tuple = (math.nan,) * 3
    steal_pct: float = math.nan     # the hypervisor's steal over the stream (host_cpu_jiffies)
    target_log: str = ''
    profile_file: str | None = None
    #: per sample, ms from just before its first message was published to just
    #: after its last (the driver's own publishing; three messages with topics)
    publish_ms: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def after_publish_ms(self) -> np.ndarray:
        """Per answered sample, ms from the end of its publishing to the receipt
        of the answer: the latency without the driver's own publishing."""
        ok = np.isfinite(self.recv_times)
        if self.publish_ms.size != ok.size:
            return np.zeros(0)
        return self.latency_ms - self.publish_ms[ok]

    def pct(self, q: float) -> float:
        return float(np.percentile(self.latency_ms, q)) if self.latency_ms.size else math.nan

    @property
    def median(self) -> float:
        return self.pct(50)

    @property
    def p99(self) -> float:
        return self.pct(99)

    @property
    def max(self) -> float:
        return float(self.latency_ms.max()) if self.latency_ms.size else math.nan

    @property
    def cpu_ms_per_setpoint(self) -> float:
        return 1e3 * self.target_cpu_s / max(self.answered, 1)

    @property
    def cpu_fraction(self) -> float:
        """Target's CPU time / wall time of the stream (1.0 = one core busy)."""
        return self.target_cpu_s / self.stream_wall_s if self.stream_wall_s > 0 else math.nan

    @property
    def keeps_up_p99_ms(self) -> float:
        return 1e3 * KEEPS_UP_QUEUE_FRACTION * self.depth / self.rate

    @property
    def keeps_up(self) -> bool:
        """Nothing lost and no standing backlog (p99 below half a full queue)."""
        return self.lost == 0 and self.answered > 0 and self.p99 <= self.keeps_up_p99_ms

    def tenth_medians(self) -> tuple[float, float]:
        """Median latency of the answered samples in the first and last tenth
        of the stream (a growing backlog shows as last >> first)."""
        n = self.sent
        lat = (self.recv_times - self.send_times) * 1e3
        first, last = lat[: max(1, n // 10)], lat[n - max(1, n // 10):]
        f = first[np.isfinite(first)]
        la = last[np.isfinite(last)]
        return (float(np.median(f)) if f.size else math.nan,
                float(np.median(la)) if la.size else math.nan)

    def lost_where(self) -> str:
        """Where the lost samples are: mid-stream or only at the end."""
        if self.lost == 0:
            return ''
        missing = np.flatnonzero(~np.isfinite(self.recv_times))
        answered = np.flatnonzero(np.isfinite(self.recv_times))
        last_ok = answered.max() if answered.size else -1
        tail = int(np.sum(missing > last_ok))
        return (f'{self.lost - tail} mid-stream, {tail} at the end (never answered '
                f'before the drain timeout)')


def _reader(pipe: Any, out: 'queue.Queue[str]') -> None:
    for line in pipe:
        out.put(line.rstrip('\n'))
    out.put('')       # EOF


def run_stream(kind: str, rate: float, seconds: float, *, env: dict[str, str],
               executor: str = 'events', depth: int | None = None,
               sample_every: float | None = None, workdir: Path | None = None,
               py_spy: tuple[str, Path, float] | None = None,
               cprofile_out: Path | None = None,
               progress: Callable[[str], None] | None = None,
               drain: float = 3.0, python_messages: bool = False,
               setpoint_input: str = 'topics') -> StreamResult:
    """Start the target (``kind`` 'node' or 'echo') and the driver, stream
    ``rate`` Hz for ``seconds`` s, and return what was measured.

    ``sample_every``: also sample the target's VmRSS and CPU time every that
    many seconds of the stream (soak). ``py_spy``: (py-spy executable, output
    file, seconds) to attach to the target once streaming (raw format,
    non-blocking). ``cprofile_out``: run the node under cProfile (stats written
    when it stops). ``python_messages``: the driver publishes and receives
    Python message objects (its old way) instead of serialized messages.
    ``setpoint_input``: how the driver sends a setpoint to the node: ``topics``
    (a pose, a twist and an acceleration with one stamp) or ``trajectory`` (one
    ``trajectory_msgs/JointTrajectory`` on ``platform_setpoint``)."""
    if setpoint_input not in SETPOINT_INPUTS:
        raise ValueError(f'setpoint_input must be one of {SETPOINT_INPUTS}, not '
                         f'{setpoint_input!r}')
    if kind == 'echo' and setpoint_input != 'topics':
        raise ValueError('the echo answers pose_setpoint: setpoint_input must be topics')
    depth = node_qos_depth() if depth is None else depth
    own_tmp = workdir is None
    workdir = Path(tempfile.mkdtemp(prefix='fsd_bench_')) if own_tmp else workdir
    workdir.mkdir(parents=True, exist_ok=True)
    tag = f'{kind}_{rate:g}hz_{int(time.time() * 1000) % 10**8}'
    out_file = workdir / f'{tag}.npz'
    cmd = (node_command(executor, cprofile_out=cprofile_out) if kind == 'node'
           else echo_command(executor, depth))
    load_start = load_average()
    target = Proc(cmd, env, workdir / f'{tag}_target.log')
    driver = None
    spy = None
    lines: 'queue.Queue[str]' = queue.Queue()
    memory: list[tuple[float, int, float, float, int, int]] = []
    cpu0 = cpu1 = math.nan
    host0 = host1 = (0, 0)

    def sample(t: float, cpu: float) -> None:
        memory.append((t, rss_kb(target.pid), cpu, load_average()[0], *host_cpu_jiffies()))

    threads0: dict = {}
    threads1: dict = {}
    try:
        driver = Proc([sys.executable, str(Path(__file__).resolve()), 'drive',
                       '--expect', kind, '--rate', f'{rate:g}', '--seconds', f'{seconds:g}',
                       '--depth', str(depth), '--out', str(out_file),
                       '--progress', f'{sample_every or 0:g}', '--drain', f'{drain:g}',
                       '--input', setpoint_input]
                      + (['--python-messages'] if python_messages else []),
                      env, workdir / f'{tag}_driver.log', stdout_pipe=True)
        threading.Thread(target=_reader, args=(driver.proc.stdout, lines), daemon=True).start()
        t_start = None
        next_sample = math.inf
        deadline = time.monotonic() + seconds + 300.0      # discovery + drain, generous
        while True:
            try:
                line = lines.get(timeout=0.2)
            except queue.Empty:
                line = None
            now = time.monotonic()
            if t_start is not None and now >= next_sample and target.alive():
                sample(now - t_start, cpu_seconds(target.pid))
                next_sample += sample_every
            if line is None:
                if not target.alive():
                    raise RuntimeError(f'{kind} process died:\n' + target.output()[-3000:])
                if now > deadline:
                    raise RuntimeError('driver did not finish in time:\n'
                                       + Path(driver.log_path).read_text()[-3000:])
                continue
            if line == '':                      # driver's EOF
                break
            if line.startswith('START'):
                t_start = time.monotonic()
                host0 = host_cpu_jiffies()
                threads0 = thread_cpu(target.pid)
                cpu0 = cpu_seconds(target.pid)
                if cprofile_out is not None:
                    os.kill(target.pid, signal.SIGUSR1)     # start profiling now
                if sample_every:
                    sample(0.0, cpu0)
                    next_sample = t_start + sample_every
                if py_spy is not None:
                    exe, spy_out, spy_seconds = py_spy
                    spy = subprocess.Popen(
                        [exe, 'record', '--pid', str(target.pid), '--nonblocking',
                         '--rate', '250', '--duration', f'{spy_seconds:g}', '--format', 'raw',
                         '--output', str(spy_out)],
                        stdout=subprocess.DEVNULL, stderr=open(workdir / f'{tag}_spy.log', 'w'))
            elif line.startswith('STREAMED'):
                pass
            elif line.startswith('DRAINED'):
                cpu1 = cpu_seconds(target.pid)
                host1 = host_cpu_jiffies()
                threads1 = thread_cpu(target.pid)
                if sample_every and t_start is not None:
                    sample(time.monotonic() - t_start, cpu1)
            elif line.startswith('PROGRESS') and progress is not None:
                progress(f'{kind} {rate:g} Hz: {line[9:]}')
        rc = driver.proc.wait(30)
        if rc != 0 or not out_file.exists():
            raise RuntimeError(f'driver failed (exit {rc}):\n'
                               + Path(driver.log_path).read_text()[-3000:])
        if spy is not None:
            try:
                spy.wait(60)
            except subprocess.TimeoutExpired:
                spy.kill()
                spy.wait(5)
    finally:
        if spy is not None and spy.poll() is None:
            spy.kill()
            spy.wait(5)
        if driver is not None:
            driver.stop()
        target.stop(timeout=30.0 if cprofile_out is not None else 10.0)
    data = np.load(out_file, allow_pickle=False)
    meta = json.loads(str(data['meta']))
    send, recv, sched = data['send'], data['recv'], data['scheduled']
    main_cpu, other_cpu = thread_cpu_delta(target.pid, threads0, threads1)
    ok = np.isfinite(recv)
    last = max(float(np.nanmax(send)), float(recv[ok].max()) if ok.any() else -math.inf)
    result = StreamResult(
        kind=kind, executor=executor, setpoint_input=setpoint_input, rate=rate, depth=depth, seconds=seconds,
        sent=int(send.size),
        answered=int(ok.sum()), lost=int((~ok).sum()),
        latency_ms=(recv[ok] - send[ok]) * 1e3, send_times=send, recv_times=recv,
        publisher_late_ms=(send - sched) * 1e3,
        publish_ms=(data['sent'] - send) * 1e3 if 'sent' in data else np.full(send.size, math.nan),
        target_cpu_s=cpu1 - cpu0,
        stream_wall_s=last - meta['start'], drain_s=meta['drain_s'],
        duplicates=meta['duplicates'], discovery_s=meta['discovery_s'],
        diagnostics=[(t, v) for t, v in meta['diagnostics']], memory=memory,
        main_thread_cpu_s=main_cpu, other_threads_cpu=other_cpu,
        load=load_average(), load_start=load_start, steal_pct=steal_percent(host0, host1),
        target_log=target.output()[-4000:],
        profile_file=str(py_spy[1]) if py_spy else (str(cprofile_out) if cprofile_out else None))
    if own_tmp:
        shutil.rmtree(workdir, ignore_errors=True)
    return result


# ----------------------------------------------------------------------------
# The motion streamed
# ----------------------------------------------------------------------------
def stream_motion(rate: float) -> tuple[list, list, list]:
    """One period of the stream at ``rate`` Hz: the paper's general motion, its
    return to neutral, the motion-cueing sequence (flight_sim_dynamics.cueing.
    PlannerSequence), as lists of (surge, heave, roll) and derivatives."""
    from flight_sim_dynamics.core.cueing import PlannerSequence

    seq = PlannerSequence(['general', 'cueing'], loop=True)
    n = int(round(seq.period * rate))
    q, qd, qdd = [], [], []
    for k in range(n):
        a, b, c, _ = seq.sample(k / rate)
        q.append(tuple(float(x) for x in a))
        qd.append(tuple(float(x) for x in b))
        qdd.append(tuple(float(x) for x in c))
    return q, qd, qdd


# ----------------------------------------------------------------------------
# The driver process (rclpy)
# ----------------------------------------------------------------------------
def drive_main(argv: Sequence[str]) -> int:
    p = argparse.ArgumentParser(prog='bench_node.py drive')
    p.add_argument('--expect', choices=('node', 'echo'), default='node')
    p.add_argument('--input', choices=SETPOINT_INPUTS, default='topics',
                   help='how a setpoint is sent (topics: pose + twist + accel; trajectory: '
                        'one JointTrajectory on platform_setpoint)')
    p.add_argument('--rate', type=float, required=True)
    p.add_argument('--seconds', type=float, required=True)
    p.add_argument('--depth', type=int, default=1000)
    p.add_argument('--out', required=True)
    p.add_argument('--progress', type=float, default=0.0,
                   help='print a PROGRESS line every this many seconds (0: never)')
    p.add_argument('--drain', type=float, default=3.0,
                   help='after the last publish, wait until every answer is in or none '
                        'came for this long')
    p.add_argument('--discovery-timeout', type=float, default=60.0)
    p.add_argument('--python-messages', action='store_true',
                   help='publish and receive Python message objects (converted to and from '
                        'C by rclpy in this process) instead of serialized messages')
    args = p.parse_args(argv)

    import struct

    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
    from rclpy.context import Context
    from rclpy.experimental import EventsExecutor
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from flight_sim_dynamics.ros.inputs import PLATFORM_DOF_NAMES, rpy_to_quaternion

    rate = args.rate
    n = int(round(args.seconds * rate))
    period_ns = int(round(1e9 / rate))
    base_ns = STAMP_BASE_S * 1_000_000_000
    motion_q, motion_qd, motion_qdd = stream_motion(rate)
    quats = [rpy_to_quaternion(q[2]) for q in motion_q]
    m = len(motion_q)

    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node('bench_driver', context=context)
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=args.depth,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.VOLATILE)
    pose_pub = node.create_publisher(PoseStamped, 'pose_setpoint', qos)
    twist_pub = node.create_publisher(TwistStamped, 'twist_setpoint', qos)
    accel_pub = node.create_publisher(AccelStamped, 'accel_setpoint', qos)
    trajectory = args.input == 'trajectory'
    traj_pub = node.create_publisher(JointTrajectory, 'platform_setpoint', qos)
    # measured samples are k = 0..n-1; warm-up samples use negative k (earlier stamps)
    warm = 200
    recv = [math.nan] * n
    counts = {'dup': 0, 'warm': 0, 'last': 0.0}
    clock = time.monotonic
    first_ns = base_ns + warm * period_ns       # stamp of sample k = 0

    # The stamp of a serialized (CDR) message: int32 sec, uint32 nanosec right
    # after the 4-byte encapsulation header (byte 1: 1 = little endian).
    stamp_le, stamp_be = struct.Struct('<iI'), struct.Struct('>iI')
    raw = not args.python_messages

    def on_actuator(msg: Any) -> None:
        t = clock()
        if raw:
            sec, nanosec = (stamp_le if msg[1] == 1 else stamp_be).unpack_from(msg, 4)
        else:
            sec, nanosec = msg.header.stamp.sec, msg.header.stamp.nanosec
        k = (sec * 1_000_000_000 + nanosec - first_ns) // period_ns
        if 0 <= k < n:
            if recv[k] != recv[k]:       # nan: first answer
                recv[k] = t
            else:
                counts['dup'] += 1
        else:
            counts['warm'] += 1
        counts['last'] = t

    diagnostics: list = []

    def on_diagnostics(msg: Any) -> None:
        t = clock()
        for status in msg.status:
            if status.hardware_id == 'flight_sim_dynamics':
                diagnostics.append((t, {kv.key: kv.value for kv in status.values}))

    node.create_subscription(JointState, 'actuator_states', on_actuator, qos, raw=raw)
    node.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics, 10)
    executor = EventsExecutor(context=context)
    executor.add_node(node)

    def spin_until(pred: Callable[[], bool], timeout: float) -> bool:
        end = clock() + timeout
        while not pred():
            left = end - clock()
            if left <= 0:
                return pred()
            executor.spin_once(timeout_sec=min(0.05, left))   # always with a timeout
        return True

    pose, twist, accel = PoseStamped(), TwistStamped(), AccelStamped()
    pose.header.frame_id = 'simulator_base'
    pp, po = pose.pose.position, pose.pose.orientation
    tl, ta = twist.twist.linear, twist.twist.angular
    al, aa = accel.accel.linear, accel.accel.angular
    stamp = pose.header.stamp
    traj = JointTrajectory()
    traj.header.frame_id = 'simulator_base'
    traj.joint_names = list(PLATFORM_DOF_NAMES)
    point = JointTrajectoryPoint()
    traj.points = [point]
    dof = [('surge', 'heave', 'roll').index(name) for name in PLATFORM_DOF_NAMES]

    def fill(i: int) -> None:
        """The messages of motion sample i (stamp aside)."""
        q, qd, qdd = motion_q[i], motion_qd[i], motion_qdd[i]
        pp.x, pp.z = q[0], q[1]
        po.x, po.y, po.z, po.w = quats[i]
        tl.x, tl.z, ta.x = qd
        al.x, al.z, aa.x = qdd
        point.positions = [float(q[j]) for j in dof]
        point.velocities = [float(qd[j]) for j in dof]
        point.accelerations = [float(qdd[j]) for j in dof]
        traj.points = [point]

    def publish_messages(j: int) -> None:
        """Sample j (>= 0: measured k = j - warm) of the whole run."""
        sec, nsec = divmod(base_ns + j * period_ns, 1_000_000_000)
        stamp.sec, stamp.nanosec = sec, nsec
        twist.header.stamp = stamp
        accel.header.stamp = stamp
        traj.header.stamp = stamp
        fill(j % m)
        if trajectory:
            traj_pub.publish(traj)
            return
        pose_pub.publish(pose)
        twist_pub.publish(twist)
        accel_pub.publish(accel)

    # Serialized: each motion sample's three messages are serialized once, before
    # the stream; per sample only the stamp (bytes 4-11 of every *Stamped
    # message) is put in, so the driver's own cost per publish is the
    # middleware's, as for a planner written in C++.
    serialized: list[tuple[bytes, ...]] = []
    head = b''
    if raw:
        for i in range(m):
            fill(i)
            serialized.append(tuple(serialize_message(x)[12:]
                                    for x in (pose, twist, accel, traj)))
        head = serialize_message(pose)[:4]
        stamp_pack = (stamp_le if head[1] == 1 else stamp_be).pack
        # check one sample the slow way
        fill(1 % m)
        stamp.sec, stamp.nanosec = 12345, 678
        back = deserialize_message(head + stamp_pack(12345, 678) + serialized[1 % m][0],
                                   PoseStamped)
        if back != pose:
            print('ERROR serialized pose template does not read back', flush=True)
            return 3
        traj.header.stamp = stamp
        back = deserialize_message(head + stamp_pack(12345, 678) + serialized[1 % m][3],
                                   JointTrajectory)
        if back != traj:
            print('ERROR serialized trajectory template does not read back', flush=True)
            return 3

    def publish_serialized(j: int) -> None:
        """Sample j (>= 0: measured k = j - warm) of the whole run."""
        p_, t_, a_, s_ = serialized[j % m]
        h = head + stamp_pack(*divmod(base_ns + j * period_ns, 1_000_000_000))
        if trajectory:
            traj_pub.publish(h + s_)
            return
        pose_pub.publish(h + p_)
        twist_pub.publish(h + t_)
        accel_pub.publish(h + a_)

    publish = publish_serialized if raw else publish_messages

    subs = ([pose_pub] if args.expect == 'echo' else [traj_pub] if trajectory
            else [pose_pub, twist_pub, accel_pub])
    t0 = clock()
    found = spin_until(lambda: all(pb.get_subscription_count() > 0 for pb in subs)
                       and node.count_publishers('actuator_states') > 0,
                       args.discovery_timeout)
    if not found:
        print('ERROR discovery timed out', flush=True)
        return 3
    discovery_s = clock() - t0
    # warm-up (not measured): until answers flow both ways, at most `warm` samples at 100 Hz
    for j in range(warm):
        publish(j)
        spin_until(lambda: False, 0.01)
        if counts['warm'] >= 20:
            break
    spin_until(lambda: False, 0.3)

    send = [math.nan] * n
    sent = [math.nan] * n           # just after the sample's last message was published
    sched = [math.nan] * n
    period = 1.0 / rate
    start = clock() + 0.01
    print(f'START {start:.6f}', flush=True)
    next_progress = start + args.progress if args.progress > 0 else math.inf
    spin_once = executor.spin_once
    for k in range(n):
        target = start + k * period
        now = clock()
        while now < target:
            spin_once(timeout_sec=target - now)
            now = clock()
        sched[k] = target
        send[k] = clock()
        publish(warm + k)
        sent[k] = clock()
        if now >= next_progress:
            got = sum(1 for r in recv if r == r)
            print(f'PROGRESS t={now - start:.0f}s sent={k + 1} answered={got} '
                  f'load={os.getloadavg()[0]:.2f}', flush=True)
            next_progress += args.progress
    streamed = clock()
    print('STREAMED', flush=True)

    def all_in() -> bool:
        return all(r == r for r in recv)

    while not all_in():
        before = counts['last']
        spin_until(all_in, args.drain)
        if counts['last'] == before:      # nothing new for a whole drain period
            break
    end = clock()
    print('DRAINED', flush=True)
    received = [r for r in recv if r == r]
    meta = dict(start=start, end=end, duplicates=counts['dup'], discovery_s=discovery_s,
                drain_s=(max(received) - streamed) if received else math.nan,
                diagnostics=diagnostics)
    np.savez(args.out, send=np.array(send), sent=np.array(sent), recv=np.array(recv),
             scheduled=np.array(sched), meta=np.array(json.dumps(meta)))
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    return 0


# ----------------------------------------------------------------------------
# The bare echo (rclpy)
# ----------------------------------------------------------------------------
def echo_main(argv: Sequence[str]) -> int:
    """PoseStamped in (``pose_setpoint``), JointState out (``actuator_states``,
    the pose's stamp, 3 names, 3 x 3 values): the middleware's own cost, with
    the node's QoS and executor and nothing else."""
    import array

    import rclpy
    from geometry_msgs.msg import PoseStamped
    from rclpy.executors import ExternalShutdownException
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from flight_sim_dynamics.ros.node import make_executor, spin

    own = rclpy.utilities.remove_ros_args(['bench_echo', *argv])[1:]
    p = argparse.ArgumentParser(prog='bench_node.py echo')
    p.add_argument('--executor', choices=('events', 'single'), default='events')
    p.add_argument('--depth', type=int, default=100)
    args = p.parse_args(own)
    rclpy.init(args=['bench_echo', *argv])
    node = rclpy.create_node('bench_echo')
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=args.depth,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.VOLATILE)
    out = JointState()
    out.name = list(LEG_NAMES)
    pub = node.create_publisher(JointState, 'actuator_states', qos)

    def on_pose(msg: Any) -> None:
        out.header.stamp = msg.header.stamp
        p_, o = msg.pose.position, msg.pose.orientation
        values = array.array('d', (p_.x, p_.z, o.x))
        out.position = values
        out.velocity = values
        out.effort = values
        pub.publish(out)

    node.create_subscription(PoseStamped, 'pose_setpoint', on_pose, qos)
    executor = make_executor(args.executor)
    executor.add_node(node)
    try:
        spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


# ----------------------------------------------------------------------------
# The executor table (docs/node.md)
# ----------------------------------------------------------------------------
def _p99(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return float(np.percentile(values, 99)) if values.size else math.nan


def table_main(argv: Sequence[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--rates', type=float, nargs='+', default=[200.0, 500.0])
    parser.add_argument('--seconds', type=float, default=3.0)
    parser.add_argument('--executors', nargs='+', default=['events', 'single'])
    parser.add_argument('--echo', action='store_true',
                        help='also measure the bare rclpy echo with each executor')
    parser.add_argument('--inputs', nargs='+', choices=SETPOINT_INPUTS, default=['topics'],
                        help='how the driver sends setpoints to the node (topics: pose + '
                             'twist + accel; trajectory: one JointTrajectory on '
                             'platform_setpoint); each is measured (default: topics)')
    parser.add_argument('--repeat', type=int, default=1,
                        help='run every stream this many times (echo and node alternate)')
    parser.add_argument('--python-messages', action='store_true',
                        help='the driver publishes and receives Python message objects '
                             '(default: serialized messages, see the module docstring)')
    parser.add_argument('--domain-id', type=int, default=None,
                        help='ROS_DOMAIN_ID of every process (default: $ROS_DOMAIN_ID or '
                             'random 1..100)')
    args = parser.parse_args(argv)
    env = ros_env(args.domain_id)
    print(f'# {os.cpu_count()} CPUs, load average {load_average()[0]:.2f} at start, '
          f'ROS_DOMAIN_ID={env["ROS_DOMAIN_ID"]}, driver '
          f'{"message objects" if args.python_messages else "serialized"}')
    print('| target | executor | rate Hz | answered / sent | lost | latency median ms '
          '| p90 ms | p99 ms | max ms | driver publishing p99 ms | p99 after publishing ms '
          '| target CPU per setpoint ms (Python thread) | load avg | steal % |')
    print('|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|')
    targets = ([('echo', 'topics')] if args.echo else []) + [('node', i) for i in args.inputs]
    for executor in args.executors:
        for rate in args.rates:
            for _ in range(args.repeat):
                for kind, setpoint_input in targets:
                    r = run_stream(kind, rate, args.seconds, env=env, executor=executor,
                                   python_messages=args.python_messages,
                                   setpoint_input=setpoint_input)
                    main_ms = 1e3 * r.main_thread_cpu_s / max(r.answered, 1)
                    name = kind if kind == 'echo' else f'node ({setpoint_input})'
                    print(f'| {name} | {executor} | {rate:g} | {r.answered} / {r.sent} '
                          f'| {r.lost} | {r.median:.2f} | {r.pct(90):.2f} | {r.p99:.2f} '
                          f'| {r.max:.1f} | {_p99(r.publish_ms):.2f} '
                          f'| {_p99(r.after_publish_ms):.2f} '
                          f'| {r.cpu_ms_per_setpoint:.3f} ({main_ms:.3f}) '
                          f'| {r.load[0]:.2f} | {r.steal_pct:.1f} |', flush=True)
    print(f'# load average {load_average()[0]:.2f} at end')
    return 0


def profiled_node_main(argv: Sequence[str]) -> int:
    """``profiled-node OUT [node arguments]``: the node with cProfile enabled from
    SIGUSR1 on (sent when the measured stream starts, so start-up, imports and
    discovery stay out), stats written to OUT when it exits."""
    import cProfile

    from flight_sim_dynamics.ros import node

    out, rest = argv[0], list(argv[1:])
    prof = cProfile.Profile()
    signal.signal(signal.SIGUSR1, lambda *_: prof.enable())
    try:
        return node.main(rest)
    finally:
        prof.disable()
        prof.dump_stats(out)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == 'profiled-node':
        return profiled_node_main(argv[1:])
    if argv and argv[0] == 'drive':
        return drive_main(argv[1:])
    if argv and argv[0] == 'echo':
        return echo_main(argv[1:])
    return table_main(argv)


if __name__ == '__main__':
    sys.exit(main())
