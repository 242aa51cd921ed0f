"""One measured stream: the target (the node or a bare rclpy echo) and the
driver, each its own process, and what this process reads of them from /proc
(no rclpy here). See :mod:`benchmarks.bench_node` for the roles and the
commands; the driver and the echo are in :mod:`benchmarks.node_driver`.
"""
from __future__ import annotations

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

from flight_sim_dynamics.config.files import read_params_file
from flight_sim_dynamics.ros.dynamics_node import default_qos
from flight_sim_dynamics.core.motions import PlannerSequence
from flight_sim_dynamics.ros.process import start_node, stop_node

#: The repository root: the working directory of every process started here
#: (``python -m benchmarks.bench_node ...`` imports from it).
ROOT = Path(__file__).resolve().parent.parent
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
    on this machine only, unbuffered output (they run in the repository root,
    so ``python -m benchmarks...`` and the package import from it).
    """
    env = dict(os.environ)
    if domain_id is not None:
        env['ROS_DOMAIN_ID'] = str(domain_id)
    elif not env.get('ROS_DOMAIN_ID'):
        env['ROS_DOMAIN_ID'] = str(random.randint(1, 100))
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['PYTHONUNBUFFERED'] = '1'
    env.setdefault('RCUTILS_LOGGING_BUFFERED_STREAM', '0')
    return env


def node_qos_depth(params_file: Path = PARAMS_FILE) -> int:
    """KEEP_LAST depth of the node's setpoints and outputs: its default QoS
    (changed only by ``qos_overrides.*`` start-up parameters, which
    ``params_file`` must not set: a params file with them is refused here).
    """
    if params_file.is_file() and any(k.startswith('qos_overrides.')
                                     for k in read_params_file(params_file)):
        raise ValueError(f'{params_file} sets qos_overrides: pass --depth instead')
    return default_qos().depth


#: How the profiled node is launched: cProfile around the node's ``main``.
PROFILED_NODE = [sys.executable, '-m', 'benchmarks.bench_node', 'profiled-node']


def module_command(*args: str) -> list[str]:
    """``python -m benchmarks.bench_node ARGS`` (run in the repository root)."""
    return [sys.executable, '-m', 'benchmarks.bench_node', *args]


class Proc:
    """A child process with its output in a log file; always stopped with
    :meth:`stop` (SIGINT as Ctrl-C, then SIGKILL).
    """

    def __init__(self, proc: subprocess.Popen, log: Path, log_file: Any = None) -> None:
        self.proc, self.pid = proc, proc.pid
        self.log_path = log
        self._log = log_file

    @classmethod
    def start(cls, cmd: Sequence[str], env: dict[str, str], log: Path,
              stdout_pipe: bool = False) -> 'Proc':
        """``cmd`` in the repository root, in its own session."""
        out = open(log, 'w')
        proc = subprocess.Popen(list(cmd), cwd=ROOT, env=env,
                                stdout=subprocess.PIPE if stdout_pipe else out,
                                stderr=out if stdout_pipe else subprocess.STDOUT,
                                text=True, start_new_session=True)
        return cls(proc, log, out)

    @classmethod
    def node(cls, env: dict[str, str], log: Path, executor: str = 'events',
             cprofile_out: Path | None = None) -> 'Proc':
        """The node with the packaged parameters, as a user starts it; with
        ``cprofile_out``, through ``bench_node profiled-node`` (cProfile
        enabled on SIGUSR1, written at exit).
        """
        launcher = None if cprofile_out is None else PROFILED_NODE + [str(cprofile_out)]
        return cls(start_node(PARAMS_FILE, log=log, executor=executor, launcher=launcher,
                              env=env, cwd=ROOT), log)

    @property
    def cmd(self) -> list[str]:
        return list(self.proc.args)

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout: float = 10.0) -> int | None:
        rc = stop_node(self.proc, timeout)
        if self._log is not None:
            self._log.close()
        return rc

    def output(self) -> str:
        if self._log is not None and not self._log.closed:
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
    summed by name, largest first) between two :func:`thread_cpu` readings.
    """
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
    avoid. (0, 0) where /proc/stat has no steal column.
    """
    try:
        with open('/proc/stat') as f:
            fields = f.readline().split()
        ticks = [int(x) for x in fields[1:9]]
    except (OSError, ValueError, IndexError):   # pragma: no cover
        return 0, 0
    return (ticks[7], sum(ticks)) if len(ticks) == 8 else (0, 0)


def steal_percent(before: tuple[int, int], after: tuple[int, int]) -> float:
    """Share (%) of the machine's CPU time stolen by the hypervisor between two
    :func:`host_cpu_jiffies` readings (nan if unknown).
    """
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
        of the answer: the latency without the driver's own publishing.
        """
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
        of the stream (a growing backlog shows as last >> first).
        """
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
    ``trajectory_msgs/JointTrajectory`` on ``platform_setpoint``).
    """
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
    load_start = load_average()
    target_log = workdir / f'{tag}_target.log'
    target = (Proc.node(env, target_log, executor, cprofile_out) if kind == 'node' else
              Proc.start(module_command('echo', '--executor', executor, '--depth', str(depth)),
                         env, target_log))
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
        driver = Proc.start(
            module_command('drive', '--expect', kind, '--rate', f'{rate:g}',
                           '--seconds', f'{seconds:g}', '--depth', str(depth),
                           '--out', str(out_file), '--progress', f'{sample_every or 0:g}',
                           '--drain', f'{drain:g}', '--input', setpoint_input,
                           *(['--python-messages'] if python_messages else [])),
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
        kind=kind, executor=executor, setpoint_input=setpoint_input, rate=rate, depth=depth,
        seconds=seconds,
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
    return to neutral, the motion-cueing sequence (a looping
    :class:`~flight_sim_dynamics.core.motions.PlannerSequence`), as lists of
    (surge, heave, roll) and of their derivatives, plain floats.
    """
    q, qd, qdd = PlannerSequence(['general', 'cueing'], loop=True).states(rate)
    return ([tuple(x) for x in q.tolist()], [tuple(x) for x in qd.tolist()],
            [tuple(x) for x in qdd.tolist()])
