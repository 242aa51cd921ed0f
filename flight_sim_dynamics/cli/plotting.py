"""``flight-sim-dynamics plot``: force and power plots of the actuators (a
machine's examples titled with the published figures they compare with,
:attr:`Machine.example_figures`) from the output of
``solve`` for any machine (told by its ``force_<leg>`` columns); matplotlib's
object-oriented API, no pyplot, no display.
"""
from __future__ import annotations

import argparse
import os

import numpy as np

from ..machines import MACHINES
from .columns import DEFAULT_MACHINE, machine_of_columns, per_leg, plot_columns
from .csv_io import CsvError, atomic_output, read_table
from .main import CliError, number_word

#: The default machine's actuators, as figures name them.
ACTUATORS = tuple(label.upper() for label in DEFAULT_MACHINE.leg_labels)
#: The colour of each actuator in every figure (plot, animate), in leg order.
LEG_COLOURS = ('tab:blue', 'tab:orange', 'tab:green', 'tab:red', 'tab:purple', 'tab:brown')


def leg_style(k: int) -> dict:
    """Line style of leg ``k`` (0-based): every second leg wide and translucent,
    the one after it dashed on top, so that legs with equal forces (symmetric
    legs) both stay visible.
    """
    colour = LEG_COLOURS[k % len(LEG_COLOURS)]
    if k % 2:
        return dict(color=colour, linestyle='-', linewidth=3.0, alpha=0.8)
    return dict(color=colour, linestyle='--' if k else '-', linewidth=1.6 if k else 1.8)


def output_format(path: str | os.PathLike[str]) -> str:
    """The image format named by the file extension (png, pdf, svg, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    ext = os.path.splitext(os.fspath(path))[1].lower().lstrip('.')
    supported = FigureCanvasBase.get_supported_filetypes()
    if ext not in supported:
        raise CliError(f"cannot tell the image format of '{os.fspath(path)}': use one of "
                        + ', '.join('.' + e for e in sorted(supported)))
    return ext


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of each run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2], edges[1::2] - 1))


def force_power_figure(t: np.ndarray, force: np.ndarray, power: np.ndarray, *,
                       title: str, unsolved: np.ndarray | None = None,
                       actuators: tuple[str, ...] = ACTUATORS,
                       length_error: np.ndarray | None = None):
    """A figure of the forces (N) of ``actuators`` above, their powers (W)
    below, vs t (s), and with ``length_error`` (m, one column per actuator:
    ``simulate``'s leg length minus its reference) a third axes of that
    tracking error in mm; ``unsolved`` rows are shaded, not drawn as 0 N.
    """
    from matplotlib.figure import Figure

    t = np.asarray(t, dtype=float)
    force = np.asarray(force, dtype=float).reshape(len(t), -1).copy()
    power = np.asarray(power, dtype=float).reshape(len(t), -1).copy()
    unsolved = np.zeros(len(t), bool) if unsolved is None else np.asarray(unsolved, bool)
    force[unsolved], power[unsolved] = np.nan, np.nan
    tracked = length_error is not None
    fig = Figure(figsize=(8.0, 9.5 if tracked else 7.0), dpi=100, layout='constrained')
    axes = fig.subplots(3 if tracked else 2, 1, sharex=True,
                        height_ratios=(1.0, 1.0, 0.8) if tracked else None)
    ax_f, ax_p = axes[:2]
    for k, (name, f, p) in enumerate(zip(actuators, force.T, power.T)):
        ax_f.plot(t, f, label=f'actuator {name}', **leg_style(k))
        ax_p.plot(t, p, label=f'actuator {name}', **leg_style(k))
    if tracked:
        error = 1e3 * np.asarray(length_error, dtype=float).reshape(len(t), -1)
        ax_e = axes[2]
        for k, (name, e) in enumerate(zip(actuators, error.T)):
            ax_e.plot(t, e, label=f'actuator {name}', **leg_style(k))
        peak = float(np.nanmax(np.abs(error))) if error.size else 0.0
        ax_e.set_title(f'Tracking error of the leg lengths (max {peak:.3g} mm)',
                       fontsize='medium')
        ax_e.set_ylabel('simulated - reference\nleg length (mm)')
        ax_e.axhline(0.0, color='0.4', linewidth=0.8)
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    for k, (first, last) in enumerate(_runs(unsolved)):
        for ax in (ax_f, ax_p):
            ax.axvspan(t[first] - step / 2, t[last] + step / 2, facecolor='0.88', hatch='//',
                       edgecolor='0.6', linewidth=0,
                       label=f'no solution ({int(unsolved.sum())} rows)' if k == 0 else None)
    ax_f.set_ylabel('input force $f$ (N)\n+ pushes the leg\'s joints apart')
    count = number_word(len(actuators))
    # more than three legs: the legend in rows of three, smaller
    legend = dict(loc='best') if len(actuators) <= 3 else dict(loc='best', ncol=3,
                                                                fontsize='small')
    ax_f.set_title(f'Input forces of the {count} actuators', fontsize='medium')
    ax_p.set_ylabel('power $P = f\\,\\dot{L}$ (W)\n+ the actuator drives the motion')
    ax_p.set_title(f'Powers of the {count} actuators', fontsize='medium')
    axes[-1].set_xlabel('time $t$ (s)')
    for ax in axes:
        ax.grid(True, alpha=0.35)
        ax.legend(**legend)
        ax.margins(x=0)
    ax_p.axhline(0.0, color='0.4', linewidth=0.8)
    fig.suptitle(title)
    return fig


def configure(p: argparse.ArgumentParser) -> None:
    """The options of ``plot``."""
    p.add_argument('input', metavar='OUT_CSV_OR_NPZ',
                   help='output of solve, CSV or .npz (needs t, force_<leg>, power_<leg>: '
                        + '; '.join(f"the {m.title}'s " + ','.join(plot_columns(m)[1:])
                                    for m in MACHINES)
                        + "), or of simulate (its powers: force x rate; closed loop: its leg "
                          "length tracking error too)")
    p.add_argument('-o', '--output', required=True, metavar='IMAGE',
                   help='image to write; the format follows the extension (.png, .svg, .pdf)')
    p.add_argument('--title', default=None,
                   help='figure title (default: from the input file name)')
    p.add_argument('--dpi', type=int, default=100, help='resolution of raster images '
                   '(default 100)')


def default_title(path: str, actuators: tuple[str, ...] = ACTUATORS) -> str:
    """Title from the file name; a machine's example with published figures
    (:attr:`Machine.example_figures`; the file named for it, that machine's
    actuators) names them.
    """
    stem = os.path.splitext(os.path.basename(path))[0] if path != '-' else 'stdin'
    for machine in MACHINES:
        figures = machine.example_figures.get(stem)
        if figures and actuators == tuple(label.upper() for label in machine.leg_labels):
            return f'{stem} example: actuator forces and powers (cf. {figures})'
    return f"{stem}: input forces and powers of actuators {', '.join(actuators)}"


def run(args: argparse.Namespace) -> int:
    """The ``plot`` command: the figure written atomically."""
    fmt = output_format(args.output)      # fail before reading a large file
    if not 1 <= args.dpi <= 1200:
        raise CliError(f'--dpi must be between 1 and 1200, got {args.dpi}')
    every = tuple({c for m in MACHINES
                   for field in ('length', 'force', 'power', 'rate', 'length_error')
                   for c in per_leg(m, field)})
    table = read_table(args.input, required=('t',), optional=every)
    machine = machine_of_columns(table.names, 'force')
    forces, powers, rates = (per_leg(machine, field) for field in ('force', 'power', 'rate'))
    missing = [n for n in forces if n not in table.names]
    if missing:
        raise CsvError(f"missing column{'s' if len(missing) > 1 else ''} "
                       f"{', '.join(repr(n) for n in missing)}: the {machine.title}'s forces "
                       f"are {','.join(forces)}", path=table.path, line=1)

    def legs(names: tuple[str, ...]) -> np.ndarray:
        return np.column_stack([table[n] for n in names])

    force = legs(forces)
    if set(powers) <= set(table.names):
        power = legs(powers)
    elif set(rates) <= set(table.names):       # simulate's output: P = f dL/dt
        power = force * legs(rates)
    else:
        missing = ', '.join(repr(n) for n in powers if n not in table.names)
        raise CsvError(f"missing {missing} (or {','.join(rates)}, to compute the powers)",
                       path=table.path, line=1)
    actuators = tuple(label.upper() for label in machine.leg_labels)
    title = args.title if args.title is not None else default_title(args.input, actuators)
    # solve writes the rows it cannot solve as zeros; a leg length is never 0
    lengths = [n for n in per_leg(machine, 'length') if n in table.names]
    unsolved = (np.all(np.column_stack([table[n] for n in lengths]) == 0.0, axis=1)
                if lengths else None)
    # simulate's closed loop: its leg length tracking error, drawn too
    errors = per_leg(machine, 'length_error')
    length_error = legs(errors) if set(errors) <= set(table.names) else None
    fig = force_power_figure(table['t'], force, power, title=title, unsolved=unsolved,
                             actuators=actuators, length_error=length_error)
    with atomic_output(args.output) as f:
        fig.savefig(f, format=fmt, dpi=args.dpi)
    return 0
