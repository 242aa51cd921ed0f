"""The twin part of the demo (``flight-sim-dynamics demo --twin``): the twin
node ``platform_sim`` started next to the dynamics node, driven by its
``actuator_states`` (``-r actuator_commands:=actuator_states``), its
simulated pose recorded and plotted against the commanded motion.

No rclpy here (the recording node is :class:`.demo.TwinMonitor`);
matplotlib is imported lazily, by :func:`plot_tracking` only.
"""
from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Protocol

import numpy as np

from ..core.motions import PlannerSequence
from ..ros.process import SIM_MODULE, start_node

#: How the twin reads the dynamics node's answers: one remap.
TWIN_REMAP = ('-r', 'actuator_commands:=actuator_states')


def start_twin(log: Path) -> subprocess.Popen:
    """``platform_sim`` as a process, remapped to the dynamics node's output
    (default parameters: the packaged plant, 1 kHz, 5 Hz servos).
    """
    return start_node(None, TWIN_REMAP, log=log, module=SIM_MODULE)


class PoseRecord(Protocol):
    """What :class:`.demo.TwinMonitor` records: (stamp ns, surge, heave, roll) rows."""

    rows: list[tuple[int, float, float, float]]


def tracking(monitor: PoseRecord, sequence: PlannerSequence, t0_ns: int, end_ns: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t s from the start, simulated q (N, 3), commanded q (N, 3)) of the
    poses stamped within the planner's run.
    """
    rows = np.array([r for r in monitor.rows if t0_ns <= r[0] <= end_ns], dtype=float)
    if rows.size == 0:
        return np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3))
    t = (rows[:, 0] - t0_ns) * 1e-9
    commanded = np.array([sequence.sample(ti)[0] for ti in t])
    return t, rows[:, 1:], commanded


def plot_tracking(t: np.ndarray, simulated: np.ndarray, commanded: np.ndarray,
                  sequence: PlannerSequence, path: Path) -> None:
    """Commanded against simulated surge, heave and roll, and the tracking
    error, against time.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    error = simulated - commanded
    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(10, 9))
    for i, (name, unit) in enumerate((('surge', 'm'), ('heave', 'm'), ('roll', 'rad'))):
        ax = axes[i]
        ax.plot(t, commanded[:, i], color='0.3', lw=2.5, alpha=0.5, label='commanded')
        ax.plot(t, simulated[:, i], color='tab:blue', lw=1.0, label='simulated (twin)')
        ax.set_ylabel(f'{name} ({unit})')
    ax_e = axes[3]
    ax_e.plot(t, 1e3 * error[:, 0], label='surge (mm)')
    ax_e.plot(t, 1e3 * error[:, 1], label='heave (mm)')
    ax_e.plot(t, 1e3 * error[:, 2], label='roll (mrad)')
    ax_e.set_ylabel('simulated - commanded')
    ax_e.set_xlabel('stamp (s from start)')
    for ax in axes:
        for label, start, end in sequence.segments:
            if label != 'return':
                ax.axvspan(start, end, color='0.93', zorder=0)
                if ax is axes[0]:
                    ax.text(0.5 * (start + end), 1.0, label, transform=ax.get_xaxis_transform(),
                            ha='center', va='bottom', fontsize=8)
        ax.grid(True, alpha=0.3)
        ax.legend(loc='upper right', fontsize=8)
    peak = np.abs(error).max(axis=0) if len(t) else np.full(3, np.nan)
    fig.suptitle(f'digital twin (platform_sim) driven by dynamics_node: {len(t)} poses; max error '
                 f'{1e3 * peak[0]:.2f} mm, {1e3 * peak[1]:.2f} mm, {1e3 * peak[2]:.2f} mrad',
                 y=0.995)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def summary(t: np.ndarray, simulated: np.ndarray, commanded: np.ndarray) -> str:
    """One line: poses and max / RMS tracking error per coordinate."""
    if not len(t):
        return 'no twin pose received within the run'
    e = simulated - commanded
    peak, rms = np.abs(e).max(axis=0), np.sqrt((e * e).mean(axis=0))
    return (f'{len(t)} twin poses; tracking error max / RMS: surge {1e3 * peak[0]:.2f} / '
            f'{1e3 * rms[0]:.2f} mm, heave {1e3 * peak[1]:.2f} / {1e3 * rms[1]:.2f} mm, roll '
            f'{1e3 * peak[2]:.2f} / {1e3 * rms[2]:.2f} mrad')
