"""Force and power plots of the three actuators (the paper's Figs. 3-8).

Uses matplotlib's object-oriented API (``matplotlib.figure.Figure``, no
pyplot, no global backend state): rendering goes through the Agg canvas, so
no display is needed.
"""
from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from .csv_io import atomic_output

ACTUATORS = ('A', 'B', 'C')
#: The colour of each actuator in every figure (plot, animate).
LEG_COLOURS = ('tab:blue', 'tab:orange', 'tab:green')
# B and C are equal in the vertical example: C dashed on top of a solid B
# keeps both visible where they coincide.
_STYLES = (dict(color=LEG_COLOURS[0], linestyle='-', linewidth=1.8),
           dict(color=LEG_COLOURS[1], linestyle='-', linewidth=3.0, alpha=0.8),
           dict(color=LEG_COLOURS[2], linestyle='--', linewidth=1.6))


class PlotError(ValueError):
    """The figure cannot be written (unsupported format, ...)."""


def output_format(path: str | os.PathLike[str]) -> str:
    """The image format named by the file extension (png, pdf, svg, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    ext = os.path.splitext(os.fspath(path))[1].lower().lstrip('.')
    supported = FigureCanvasBase.get_supported_filetypes()
    if ext not in supported:
        raise PlotError(f"cannot tell the image format of '{os.fspath(path)}': use one of "
                        + ', '.join('.' + e for e in sorted(supported)))
    return ext


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of each run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2], edges[1::2] - 1))


def force_power_figure(t: np.ndarray, force: np.ndarray, power: np.ndarray, *,
                       title: str, labels: Sequence[str] = ACTUATORS,
                       unsolved: np.ndarray | None = None):
    """A two-axes figure: actuator forces (N) above, powers (W) below, vs t (s).

    Rows in ``unsolved`` (no solution: unreachable or invalid input, written as
    zeros by ``solve``) are left out of the curves and shaded, so that no
    flat 0 N line passes for a force.
    """
    from matplotlib.figure import Figure

    t = np.asarray(t, dtype=float)
    force = np.asarray(force, dtype=float).reshape(len(t), -1).copy()
    power = np.asarray(power, dtype=float).reshape(len(t), -1).copy()
    unsolved = np.zeros(len(t), bool) if unsolved is None else np.asarray(unsolved, bool)
    force[unsolved], power[unsolved] = np.nan, np.nan
    fig = Figure(figsize=(8.0, 7.0), dpi=100, layout='constrained')
    ax_f, ax_p = fig.subplots(2, 1, sharex=True)
    for i, name in enumerate(labels):
        style = _STYLES[i % len(_STYLES)]
        ax_f.plot(t, force[:, i], label=f'actuator {name}', **style)
        ax_p.plot(t, power[:, i], label=f'actuator {name}', **style)
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    for k, (first, last) in enumerate(_runs(unsolved)):
        for ax in (ax_f, ax_p):
            ax.axvspan(t[first] - step / 2, t[last] + step / 2, facecolor='0.88', hatch='//',
                       edgecolor='0.6', linewidth=0,
                       label=f'no solution ({int(unsolved.sum())} rows)' if k == 0 else None)
    ax_f.set_ylabel('input force $f$ (N)\n+ pushes the leg\'s joints apart')
    ax_f.set_title('Input forces of the three actuators', fontsize='medium')
    ax_p.set_ylabel('power $P = f\\,\\dot{L}$ (W)\n+ the actuator drives the motion')
    ax_p.set_title('Powers of the three actuators', fontsize='medium')
    ax_p.set_xlabel('time $t$ (s)')
    for ax in (ax_f, ax_p):
        ax.grid(True, alpha=0.35)
        ax.legend(loc='best')
        ax.margins(x=0)
    ax_p.axhline(0.0, color='0.4', linewidth=0.8)
    fig.suptitle(title)
    return fig


def plot_forces_powers(t: np.ndarray, force: np.ndarray, power: np.ndarray,
                       output: str | os.PathLike[str], *, title: str, dpi: int = 100,
                       unsolved: np.ndarray | None = None) -> None:
    """Write the force/power figure to ``output`` (format from the extension),
    atomically: a failed run leaves no partial image and keeps an old one.
    """
    fmt = output_format(output)
    fig = force_power_figure(t, force, power, title=title, unsolved=unsolved)
    with atomic_output(output) as f:
        fig.savefig(f, format=fmt, dpi=dpi)
