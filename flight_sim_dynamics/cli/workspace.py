"""``flight-sim-dynamics workspace``: for the 3-DOF machine, per roll angle a
panel of the (surge, heave) plane at rest (:mod:`..machines.staicu.workspace`),
reachable cells coloured by condition, unreachable ones hatched by cause, with
the stroke limits, singular curves and the paper's motions (eq. 6); the summary
on stdout (``--markdown``: a page). A machine that gives its workspace as maps
(``Machine.workspace``, the hexapod) is drawn by :mod:`.workspace_maps`.
matplotlib is imported by :func:`plot` only.
"""
from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import time
from typing import Sequence

import numpy as np

import flight_sim_dynamics as fsd

from ..machines import MACHINES
from ..machines.staicu.model import Model
from ..machines.staicu.trajectories import paper_example, sample_times
from ..machines.staicu.workspace import (DEFAULT_RANGE, DEFAULT_ZOOM, DEGENERATE, E2_OFF_ROD,
                                         INVALID, KINDS, LEGS, LOOP_D, LOOP_E, REACHABLE,
                                         LineRanges, MotionReport, RollMap, RollResult,
                                         boundary_shares, general_pose_at_roll,
                                         near_singular_share, paper_motions, sample_roll)
from . import workspace_maps
from .bench import table
from .csv_io import atomic_output
from .main import CliError, load_model
from .plotting import output_format

#: Default roll angles, degrees (negative ones mirror these: legs B and C exchanged).
DEFAULT_ROLLS = (0.0, 15.0, 30.0, 45.0)
DEFAULT_RESOLUTION = 201


def _intervals_text(line: LineRanges, which: str) -> str:
    ivs = line.intervals[which]
    if not ivs:
        return 'none'
    centre = line.through_centre(which)
    ordered = ([centre] if centre else []) + [iv for iv in ivs if iv is not centre]
    parts = [iv.text() for iv in ordered]
    if centre is None:
        return 'not through 0: ' + '; '.join(parts)
    return parts[0] + ('' if len(parts) == 1 else '; also ' + '; '.join(parts[1:]))


def _fmt_statuses(counts: dict[str, int]) -> str:
    total = sum(counts.values())
    if set(counts) == {'ok'}:
        return f'all {total} ok'
    return ', '.join(f'{n} {s}' for s, n in counts.items()) + f' (of {total})'


def _shares_text(shares: dict[str, float]) -> str:
    return ', '.join(f'{name} {100 * share:.0f} %' for name, share in shares.items()
                     if share >= 0.005) or 'none'


def bounds(results: Sequence[RollResult], model: Model) -> list[tuple[str, str, str, str]]:
    """Per roll angle: the boundary shares of the reachable set (overview) and
    of the within-stroke region (zoom if any), and the near_singular share.
    """
    rows = []
    for r in results:
        rm = r.zoom if r.zoom is not None else r.overview
        near = near_singular_share(rm)
        rows.append((f'{r.roll_deg:+g} deg',
                     _shares_text(boundary_shares(model, r.overview, KINDS[0])),
                     _shares_text(boundary_shares(model, rm, KINDS[1])),
                     '-' if math.isnan(near) else f'{100 * near:.1f} %'))
    return rows


def summary_lines(results: Sequence[RollResult], motions: Sequence[MotionReport],
                  model: Model) -> list[str]:
    lim = model.limits
    lines = [f'Stroke limits [{lim.stroke_min:g}, {lim.stroke_max:g}] m; near-singular '
             f'thresholds: kinematic condition {lim.max_kinematic_condition:g}, actuator '
             f'Jacobian condition {lim.max_jacobian_condition:g}. Intervals in m; each end '
             'names the constraint just beyond it; the interval through the central '
             'configuration comes first.', '']
    for r in results:
        lines.append(f'roll {r.roll_deg:+g} deg:')
        for line in (r.surge_line, r.heave_line):
            lines.append(f'  reachable {line.name}: {_intervals_text(line, "reachable")}')
            lines.append(f'    within stroke limits: '
                         f'{_intervals_text(line, "within stroke limits")}')
        clip = ' (clipped by the edge of --range: widen it)' if r.areas.clipped else ''
        lines.append(f'  area: reachable {r.areas.reachable:.3f} m^2{clip}, within stroke limits '
                     f'{r.areas.within:.3f} m^2')
    lines.append('')
    lines.append("The paper's motions (eq. 6, 100 Hz, with their rates and accelerations):")
    for m in motions:
        lines.append(f'  {m.name}: {_fmt_statuses(m.statuses)}; end pose surge '
                     f'{m.end_pose[0]:.3f} m, heave {m.end_pose[1]:.3f} m, roll '
                     f'{math.degrees(m.end_pose[2]):.1f} deg; strokes '
                     + ', '.join(f'{leg} [{lo:+.3f}, {hi:+.3f}]' for leg, lo, hi in
                                 zip(LEGS, m.stroke_min, m.stroke_max))
                     + f' m; max cond(Q) {m.max_cond:.3g}, kinematic condition '
                     f'{m.max_kinematic_condition:.3g}, Jacobian condition '
                     f'{m.max_jacobian_condition:.3g}')
    lines += ['', 'Boundary shares (reachable set, overview panel | within stroke limits, '
              'zoomed panel if any) and near_singular share of the cells within the stroke '
              'limits:']
    lines += [f'  {roll}: {reach} | {within} | near_singular {near}'
              for roll, reach, within, near in bounds(results, model)]
    return lines


def markdown(results: Sequence[RollResult], motions: Sequence[MotionReport], model: Model,
             args: argparse.Namespace, image: str | None, md_path: str) -> str:
    """The summary as a markdown page that shows the figure ``image``."""
    lim = model.limits
    command = shlex.join(['flight-sim-dynamics', 'workspace', *getattr(args, 'argv', [])])
    out = ['# Workspace of the flight simulator\n\n'
           f'Generated by `{command}` (grid of {args.resolution} x {args.resolution} cell '
           'centres per panel; interval ends and areas refined by bisection). Do not edit by '
           'hand: rerun the command.\n']
    if image:
        rel = os.path.relpath(os.path.abspath(image), os.path.dirname(os.path.abspath(md_path)))
        out.append(f'![reachable (surge, heave) region per roll angle, coloured by the '
                   f'condition number]({rel})\n')
    colour = 'cond(Q) (SVD)' if args.color_by == 'cond' else 'the kinematic condition'
    out.append(f'One panel per roll angle, at rest; the bottom row (if any) zooms onto the '
               f'central configuration (+). Colour: {colour}, log scale; dimmed: outside the '
               f'stroke limits ({lim.stroke_min:g} m dashed, {lim.stroke_max:g} m solid); '
               'hatched: unreachable, by cause. Roll enters legs B and C only: the reachable '
               'set is the same at every roll angle.\n')
    out.append('## What bounds the workspace\n\nShare of the length of each boundary made by '
               'each constraint (grid estimate), and the share of the cells within the stroke '
               'limits whose status is `near_singular`.\n\n' + table(
                   ('roll', 'boundary of the reachable set (overview)',
                    'boundary within the stroke limits '
                    f'({"zoom" if results[0].zoom is not None else "overview"})',
                    'near_singular'), bounds(results, model)) + '\n')
    out.append('## Reachable ranges and the paper\'s motions\n\n```text\n'
               + '\n'.join(summary_lines(results, motions, model)) + '\n```\n')
    return '\n'.join(out)


_CAUSE_STYLE = {LOOP_D: dict(color='0.86', hatch='//', label='unreachable: loop D cannot close '
                             '(crank D cannot reach the rod), outside and in the enclosed disk'),
                LOOP_E: dict(color='0.62', hatch='\\\\', label='unreachable: loop E cannot close'),
                E2_OFF_ROD: dict(color='#f4c58f', hatch='xx',
                                 label='unreachable: slider E2 off the rod (outside A3-G)'),
                DEGENERATE: dict(color='0.3', hatch='', label='unreachable: degenerate leg'),
                INVALID: dict(color='k', hatch='', label='invalid')}
#: Legs A, B, C: colour, line width (B drawn wide under a narrow C: they coincide at roll 0).
_LEG_STYLE = (('#d62728', 1.6), ('#ff7f0e', 3.2), ('#e377c2', 1.3))
_KIN_COLOUR, _JAC_COLOUR, _NEAR_COLOUR = '#17becf', '#ffffff', '#ff0000'
_PATHS = {'vertical': dict(color='#00ff00', linewidth=2.4),
          'rectilinear': dict(color='#1f77ff', linewidth=2.4, linestyle=(0, (3, 1.5)))}
_STAR = dict(marker='*', markersize=13, color='#ffff00', markeredgecolor='k', linestyle='')


def _halo(width: float = 2.8) -> list:
    """A dark outline: the line stays visible on any colour."""
    import matplotlib.patheffects as pe

    return [pe.withStroke(linewidth=width, foreground='k')]


def _regions(mask: np.ndarray) -> list[np.ndarray]:
    """The 4-connected regions of a boolean grid, one mask each (flood fill)."""
    label = np.zeros(mask.shape, dtype=np.int32)
    regions = []
    for start in zip(*np.nonzero(mask)):
        if label[start]:
            continue
        n = len(regions) + 1
        label[start] = n
        stack = [start]
        while stack:
            i, j = stack.pop()
            for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
                if 0 <= a < mask.shape[0] and 0 <= b < mask.shape[1] and mask[a, b] \
                        and not label[a, b]:
                    label[a, b] = n
                    stack.append((a, b))
        regions.append(label == n)
    return regions


def _draw_panel(ax, rm: RollMap, model: Model, norm, cmap, extent, show_paths: bool):
    lim = model.limits
    S, H = np.meshgrid(rm.surge, rm.heave)
    reach = rm.category == REACHABLE
    # one contourf per region, the largest first: else an enclosed region loses its hatch
    regions = [(region, _CAUSE_STYLE[code]) for code in _CAUSE_STYLE
               for region in _regions(rm.category == code)]
    for region, style in sorted(regions, key=lambda r: -int(r[0].sum())):
        ax.contourf(S, H, region.astype(float), levels=[0.5, 1.5],
                    colors=[style['color']], hatches=[style['hatch']])
    mesh = ax.pcolormesh(S, H, np.ma.masked_invalid(np.where(reach, rm.colour, np.nan)),
                         norm=norm, cmap=cmap, shading='nearest', rasterized=True)
    dim = np.ma.masked_where(~(reach & ~rm.within), np.ones(S.shape))
    ax.pcolormesh(S, H, dim, cmap='Greys', vmin=0.0, vmax=10.0, alpha=0.5, shading='nearest',
                  rasterized=True)
    near = np.ma.masked_where(~rm.near_singular, np.ones(S.shape))
    ax.pcolormesh(S, H, near, cmap='Reds', vmin=0.0, vmax=1.0, alpha=0.8, shading='nearest',
                  rasterized=True)
    # the boundary: thick where loop D or E stops closing (Q singular), thin at E2's ends
    singular_side = np.isin(rm.category, (LOOP_D, LOOP_E))
    for other, width in ((singular_side, 2.2), (rm.category == E2_OFF_ROD, 1.0)):
        f = np.where(reach, 0.0, np.where(other, 1.0, np.nan))
        if other.any():
            ax.contour(S, H, f, levels=[0.5], colors='k', linewidths=width)
    for j, (colour, width) in enumerate(_LEG_STYLE):
        for level, style in ((lim.stroke_min, '--'), (lim.stroke_max, '-')):
            ax.contour(S, H, rm.stroke[:, :, j], levels=[level], colors=colour,
                       linewidths=width, linestyles=style)
    with np.errstate(divide='ignore', invalid='ignore'):
        logk = np.log10(np.clip(rm.kinematic_condition, 1e-300, 1e300))
    cs = ax.contour(S, H, logk, levels=[math.log10(lim.max_kinematic_condition)],
                    colors=_KIN_COLOUR, linewidths=1.4, linestyles=':')
    cs.set(path_effects=_halo())
    if np.nanmin(rm.jacobian_det) < 0.0 < np.nanmax(rm.jacobian_det):
        cs = ax.contour(S, H, rm.jacobian_det, levels=[0.0], colors=_JAC_COLOUR,
                        linewidths=1.3, linestyles='-.')
        cs.set(path_effects=_halo())
    ax.plot([0], [0], marker='+', color='k', markersize=11, markeredgewidth=2.4, zorder=6)
    ax.plot([0], [0], marker='+', color='w', markersize=9, markeredgewidth=1.0, zorder=7)
    if show_paths:
        for name, style in _PATHS.items():
            q, _, _ = paper_example(name, sample_times(20.0))
            ax.plot(q[:, 0], q[:, 1], zorder=5, path_effects=_halo(), **style)
    gp = general_pose_at_roll(rm.roll_deg)
    if gp is not None and rm.roll_deg > 0:
        ax.plot([gp[0]], [gp[1]], zorder=8, **_STAR)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_aspect('equal')
    ax.grid(True, alpha=0.25, color='0.3', linewidth=0.6)
    return mesh


def _legend_handles(model: Model, categories: set[int]) -> tuple[list, list[str]]:
    """The legend's (handles, labels), related entries grouped so that it stays short."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    lim = model.limits
    entries = [(Patch(facecolor=_CAUSE_STYLE[c]['color'], hatch=_CAUSE_STYLE[c]['hatch'],
                      edgecolor='0.35'), _CAUSE_STYLE[c]['label'])
               for c in sorted(categories) if c != REACHABLE]
    entries.append((Patch(facecolor='0.82', edgecolor='0.35'),
                    'reachable, outside the stroke limits (dimmed)'))
    entries.append(((Line2D([], [], color='k', linewidth=2.2),
                     Line2D([], [], color='k', linewidth=1.0)),
                    'reachable boundary: at loop D / E (thick: crank tangent, Q singular); '
                    'where E2 reaches A3 or G (thin)'))
    for j, leg in enumerate(LEGS):
        colour, width = _LEG_STYLE[j]
        entries.append(((Line2D([], [], color=colour, linestyle='--', linewidth=width),
                         Line2D([], [], color=colour, linestyle='-', linewidth=width)),
                        f'stroke {leg} = {lim.stroke_min:g} m (dashed), {lim.stroke_max:g} m'))
    entries.append((Line2D([], [], color=_KIN_COLOUR, linestyle=':', linewidth=1.4,
                           path_effects=_halo()),
                    f'kinematic condition (blocks of Q) = {lim.max_kinematic_condition:g}'))
    entries.append((Line2D([], [], color=_JAC_COLOUR, linestyle='-.', linewidth=1.3,
                           path_effects=_halo()),
                    'actuator Jacobian singular: det(dL/dq) = 0'))
    entries.append((Patch(facecolor=_NEAR_COLOUR, alpha=0.8),
                    f'near_singular: kinematic condition > {lim.max_kinematic_condition:g} or '
                    f'Jacobian condition > {lim.max_jacobian_condition:g}'))
    entries.append(((Line2D([], [], color='k', marker='+', linestyle='', markersize=10,
                            markeredgewidth=2),
                     Line2D([], [], path_effects=_halo(), **_PATHS['vertical']),
                     Line2D([], [], path_effects=_halo(), **_PATHS['rectilinear']),
                     Line2D([], [], **_STAR)),
                    "central configuration; the paper's vertical and rectilinear (= general "
                    "at roll 0) motions; the general one at the panel's roll (star)"))
    return [e[0] for e in entries], [e[1] for e in entries]


def plot(results: Sequence[RollResult], model: Model, path: str, args: argparse.Namespace
         ) -> None:
    """Draw every roll angle's panels (and the zoomed row) to ``path``."""
    import matplotlib
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure
    from matplotlib.legend_handler import HandlerTuple

    fmt = output_format(path)
    ncol = len(results)
    maps = [[r.overview for r in results]] + ([[r.zoom for r in results]]
                                              if results[0].zoom is not None else [])
    extents = [args.range, args.zoom][:len(maps)]
    col_w = 3.5
    heights = [col_w * (e[3] - e[2]) / (e[1] - e[0]) for e in extents]
    fig = Figure(figsize=(col_w * ncol + 1.4, sum(heights) + 2.3), dpi=args.dpi,
                 layout='compressed')
    axes = fig.subplots(len(maps), ncol, squeeze=False,
                        gridspec_kw=dict(height_ratios=heights))
    values = np.concatenate([rm.colour[np.isfinite(rm.colour) & (rm.colour > 0)].ravel()
                             for row in maps for rm in row])
    lo = max(1.0, float(values.min())) if values.size else 1.0
    norm = LogNorm(vmin=lo, vmax=max(10.0 * lo, 1e3))
    cmap = matplotlib.colormaps['viridis']
    mesh = None
    categories: set[int] = set()
    for i, (row, extent) in enumerate(zip(maps, extents)):
        for k, rm in enumerate(row):
            ax = axes[i, k]
            mesh = _draw_panel(ax, rm, model, norm, cmap, extent, show_paths=rm.roll_deg == 0)
            categories |= set(np.unique(rm.category).tolist())
            ax.set_title(f'roll {rm.roll_deg:+g} deg' + (' (zoom)' if i else ''),
                         fontsize='medium')
            ax.set_xlabel('surge (m)')
            if k == 0:
                ax.set_ylabel('heave (m)')
    label = ('cond(Q), exact (SVD)' if args.color_by == 'cond' else
             'kinematic condition (blocks of Q)') + ', log scale'
    fig.colorbar(mesh, ax=axes, label=label, extend='max', shrink=0.5, pad=0.01)
    handles, labels = _legend_handles(model, categories)
    fig.legend(handles, labels, loc='outside lower center', ncol=2, fontsize=8, frameon=False,
               handler_map={tuple: HandlerTuple(ndivide=None)})
    fig.suptitle('Workspace of the flight simulator: reachable (surge, heave) of G per roll '
                 'angle, at rest', fontsize='large')
    with atomic_output(path) as f:
        fig.savefig(f, format=fmt, dpi=args.dpi)


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument('-o', '--output', default='workspace.png', metavar='IMAGE',
                   help='figure to write, format by extension (default workspace.png)')
    p.add_argument('--rolls', type=float, nargs='+', default=None,
                   metavar='DEG', help='3-DOF machine: roll angles in degrees, one panel each '
                   '(default ' + ' '.join(f'{r:g}' for r in DEFAULT_ROLLS) + ')')
    p.add_argument('--resolution', type=int, default=DEFAULT_RESOLUTION, metavar='N',
                   help=f'grid points per axis of each panel (default {DEFAULT_RESOLUTION})')
    p.add_argument('--range', type=float, nargs=4, default=None,
                   metavar=('SURGE_MIN', 'SURGE_MAX', 'HEAVE_MIN', 'HEAVE_MAX'),
                   help='extent of the (surge, heave) panels, m (3-DOF machine: the overview '
                   'panels, intervals and areas; default: the machine\'s; 3-DOF '
                   + ' '.join(f'{v:g}' for v in DEFAULT_RANGE) + ')')
    p.add_argument('--zoom', type=float, nargs=4, default=None,
                   metavar=('SURGE_MIN', 'SURGE_MAX', 'HEAVE_MIN', 'HEAVE_MAX'),
                   help='3-DOF machine: extent of the zoomed panels, m (default '
                   + ' '.join(f'{v:g}' for v in DEFAULT_ZOOM) + ')')
    p.add_argument('--no-zoom', action='store_true',
                   help='3-DOF machine: leave out the zoomed row')
    p.add_argument('--color-by', choices=('cond', 'kinematic'), default=None,
                   help='3-DOF machine: colour: exact cond(Q) (default) or the kinematic '
                   'condition')
    p.add_argument('--at', type=float, nargs=4, default=None,
                   metavar=('SWAY', 'ROLL', 'PITCH', 'YAW'),
                   help='hexapod: the pose of the surge-heave map, m and degrees (default 0 0 '
                   '0 0)')
    p.add_argument('--yaws', type=float, nargs='+', default=None, metavar='DEG',
                   help='hexapod: yaw angles of the roll-pitch maps at home, one map each '
                   '(default: the machine\'s)')
    p.add_argument('--orientation-range', type=float, nargs=4, default=None,
                   metavar=('ROLL_MIN', 'ROLL_MAX', 'PITCH_MIN', 'PITCH_MAX'),
                   help='hexapod: extent of the roll-pitch maps, degrees (default: the '
                   'machine\'s)')
    p.add_argument('--markdown', metavar='MD', default=None,
                   help='also write the summary as a markdown page showing the figure')
    p.add_argument('--params', metavar='YAML', default=None,
                   help='parameter file, which names the machine (default: the packaged '
                   'parameters)')
    p.add_argument('--dpi', type=int, default=100, help='resolution of raster images '
                   '(default 100)')


#: The options of the 3-DOF machine's roll panels and of a machine's maps.
ROLL_PANEL_OPTIONS = ('rolls', 'zoom', 'no_zoom', 'color_by')
MAP_OPTIONS = ('at', 'yaws', 'orientation_range')


def _refuse(args: argparse.Namespace, names: Sequence[str], machine: str) -> None:
    """CliError naming an option given that the machine's workspace does not use."""
    given = [n for n in names if getattr(args, n) not in (None, False)]
    if given:
        raise CliError(f"--{given[0].replace('_', '-')}: not an option of machine "
                       f"'{machine}' (its workspace does not use it)")


def _check(args: argparse.Namespace) -> None:
    output_format(args.output)
    if not 20 <= args.resolution <= 2000:
        raise ValueError(f'--resolution must be between 20 and 2000, got {args.resolution}')
    if args.rolls is not None and not 1 <= len(args.rolls) <= 8:
        raise ValueError('--rolls takes 1 to 8 angles')
    if not all(math.isfinite(r) and abs(r) <= 180.0 for r in args.rolls or ()):
        raise ValueError('--rolls must be finite angles in [-180, 180] degrees')
    for name in ('range', 'zoom'):
        e = getattr(args, name)
        if e is not None and not (all(math.isfinite(v) for v in e) and e[0] < e[1]
                                  and e[2] < e[3]):
            raise ValueError(f'--{name} needs SURGE_MIN < SURGE_MAX and HEAVE_MIN < HEAVE_MAX '
                             f'(finite, m), got {" ".join(f"{v:g}" for v in e)}')
    if not 1 <= args.dpi <= 1200:
        raise ValueError(f'--dpi must be between 1 and 1200, got {args.dpi}')
    workspace_maps.check(args)
    if args.markdown is not None and not args.markdown.endswith('.md'):
        raise ValueError(f'--markdown {args.markdown}: give a .md file')
    for path in (args.output, args.markdown):     # fail before the computation, not after
        if path is not None and not os.path.isdir(os.path.dirname(os.path.abspath(path))):
            raise ValueError(f"{path}: cannot write: directory '{os.path.dirname(path)}' does "
                             'not exist')


def run(args: argparse.Namespace) -> int:
    """The ``workspace`` subcommand: figure, summary on stdout, optional markdown."""
    t0 = time.perf_counter()
    _check(args)
    model = load_model(args.params, machines=MACHINES)
    machine = fsd.machine_of(model)

    def progress(msg: str) -> None:
        print(f'[workspace] {msg}', file=sys.stderr, flush=True)

    if machine.workspace is not None:
        _refuse(args, ROLL_PANEL_OPTIONS, machine.name)
        workspace_maps.run(model, machine.workspace, args, progress)
    else:
        _refuse(args, MAP_OPTIONS, machine.name)
        _roll_panels(model, args, progress)
    progress(f'wrote {args.output}' + (f' and {args.markdown}' if args.markdown else '')
             + f' in {time.perf_counter() - t0:.1f} s')
    return 0


def _roll_panels(model: Model, args: argparse.Namespace, progress) -> None:
    """The 3-DOF machine's panels per roll angle (module docstring)."""
    for name, default in (('rolls', DEFAULT_ROLLS), ('range', DEFAULT_RANGE),
                          ('zoom', DEFAULT_ZOOM), ('color_by', 'cond')):
        if getattr(args, name) is None:
            setattr(args, name, default if isinstance(default, str) else list(default))
    results = []
    for roll in args.rolls:
        progress(f'roll {roll:+g} deg')
        results.append(sample_roll(model, roll, args.range, None if args.no_zoom else args.zoom,
                                   args.resolution, args.color_by == 'cond'))
    motions = paper_motions(model)
    progress(f'plotting {args.output}')
    plot(results, model, args.output, args)
    print('\n'.join(summary_lines(results, motions, model)))
    if args.markdown:
        text = markdown(results, motions, model, args, args.output, args.markdown)
        with atomic_output(args.markdown) as f:
            f.write(text.encode())
