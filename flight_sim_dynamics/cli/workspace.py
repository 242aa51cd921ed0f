"""``flight-sim-dynamics workspace``: any machine's survey
(``Machine.workspace``, :mod:`flight_sim_dynamics.core.workspace`) as a figure
(one panel per map: reachable cells coloured by the condition figure, cells
beyond a limit dimmed, unreachable ones hatched by cause, the machine's curves
and paths), a summary on stdout and, with ``--markdown``, a page of tables. The
machine's own options come from its record (``Machine.workspace_options``);
another machine's are refused. matplotlib is imported by :func:`plot` only.
"""
from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import time
from typing import Any, Sequence

import numpy as np

import flight_sim_dynamics as fsd

from .. import machines as registry
from ..core.machine import Machine
from ..core.workspace import Option, PlaneMap, Quantity, Range, Survey
from .bench import table
from .csv_io import atomic_output
from .main import CliError, load_model
from .plotting import output_format

DEFAULT_RESOLUTION = 201


# ----------------------------------------------------------------------------
# Words and tables
# ----------------------------------------------------------------------------
def _end(value: float, unit: str) -> str:
    return f'{value:+.3f} {unit}' if unit == 'm' else f'{value:+.1f} {unit}'


def _shares(shares: dict[str, float]) -> str:
    return ', '.join(f'{name} {100 * share:.0f} %' for name, share in shares.items()
                     if share >= 0.005) or 'none'


def _area_unit(plane: PlaneMap) -> str:
    a, b = plane.units
    return f'{a}^2' if a == b else f'{a} {b}'


def _interval(lo: Any, hi: Any, unit: str) -> str:
    return f'[{_end(lo.value, unit)} ({lo.cause}), {_end(hi.value, unit)} ({hi.cause})]'


def _range_text(r: Range) -> str:
    if not r.intervals:
        return 'none (home is not reachable)'
    parts = [_interval(lo, hi, r.unit) for lo, hi in r.intervals]
    if not r.through:
        return 'not through home: ' + '; '.join(parts)
    return parts[0] + ('' if len(parts) == 1 else '; also ' + '; '.join(parts[1:]))


def range_rows(survey: Survey) -> tuple[tuple[str, ...], list[tuple[str, ...]]]:
    """Columns and rows of the ranges: one row per interval (``also``: not the
    one through home); the group and set columns only when the survey has them.
    """
    grouped = any(r.group for r in survey.ranges)
    sets = len(survey.sets) > 1
    columns = (('where',) if grouped else ()) + ('coordinate',) + (('set',) if sets else ()) \
        + ('from', 'to', 'bounded below by', 'bounded above by')
    rows = []
    for r in survey.ranges:
        head = ((r.group,) if grouped else ()) + (r.name,) + \
            ((survey.sets[r.which],) if sets else ())
        if not r.intervals:
            rows.append(head + ('-', '-', 'home is not reachable', ''))
        for k, (lo, hi) in enumerate(r.intervals):
            also = ' (also)' if k or not r.through else ''
            rows.append(head[:-1] + (head[-1] + also,) + (
                _end(lo.value, r.unit), _end(hi.value, r.unit), lo.cause, hi.cause))
    return columns, rows


def _area_text(plane: PlaneMap, which: int) -> str:
    if which in plane.areas:        # measured finely: to the mm^2
        text = f'{plane.area(which):.3f} {_area_unit(plane)}'
    else:
        text = f'{plane.area(which):.3g} {_area_unit(plane)}'
    return text + (' (clipped by the edge of the map: widen it)'
                   if plane.clipped and which == 0 else '')


def plane_rows(survey: Survey) -> tuple[tuple[str, ...], list[tuple[str, ...]]]:
    """Columns and rows of the maps: area, condition over the reachable cells,
    near_singular share and boundary shares of each set the map reports.
    """
    one = len(survey.sets) == 1
    name = survey.sets[0]
    columns = ('map (at rest)', f'{name} area' if one else 'area',
               survey.condition_name, 'near_singular',
               f'boundary of the {name} region' if one else 'boundary')
    rows = []
    for plane in survey.planes:
        values = plane.condition[plane.inside(0) & np.isfinite(plane.condition)]
        cond = f'{values.min():.3g} to {values.max():.3g}' if values.size else '-'
        inner = max(plane.report)
        near = plane.near_singular_share(inner)
        near = '-' if math.isnan(near) else f'{100 * near:.1f} %'
        if one:
            area, bound = _area_text(plane, 0), _shares(plane.boundary_shares(0))
        else:
            area = '; '.join(f'{survey.sets[w]} {_area_text(plane, w)}'
                             for w in sorted(set(plane.report) | set(plane.areas)))
            bound = '; '.join(f'{survey.sets[w]}: {_shares(plane.boundary_shares(w))}'
                              for w in plane.report)
        rows.append((plane.title, area, cond, near, bound))
    return columns, rows


def _quantity(q: Quantity) -> str:
    value = np.asarray(q.value, dtype=float)
    if value.shape == (2,):
        text = f'[{value[0]:+.3f}, {value[1]:+.3f}]'
    elif q.unit == 'm':
        text = f'{float(value):.3f}'
    elif q.unit == 'deg':
        text = f'{float(value):.1f}'
    else:
        text = f'{float(value):.3g}'
    return f'{text} {q.unit}'.rstrip()


def _statuses(counts: dict[str, int]) -> str:
    total = sum(counts.values())
    if set(counts) == {'ok'}:
        return f'all {total} ok'
    return ', '.join(f'{n} {s}' for s, n in counts.items()) + f' (of {total})'


def check_rows(survey: Survey) -> tuple[tuple[str, ...], list[tuple[str, ...]]]:
    """Columns and rows of the checks of motions: statuses, then each figure."""
    if not survey.checks:
        return (), []
    columns = ('motion', 'statuses') + tuple(q.label for q in survey.checks[0].figures)
    return columns, [(c.name, _statuses(dict(c.statuses))) + tuple(_quantity(q)
                                                                    for q in c.figures)
                     for c in survey.checks]


def tables(survey: Survey) -> str:
    """The markdown tables: ranges, maps, then the checks of motions (if any)."""
    out = [table(*range_rows(survey)), table(*plane_rows(survey))]
    if survey.checks:
        out.append(table(*check_rows(survey)))
    return '\n\n'.join(out)


def summary_lines(survey: Survey) -> list[str]:
    """The summary printed on stdout."""
    lines = list(survey.notes) + [
        '', 'Ranges along a line through home (each end names what is just beyond it; the '
        'interval through home first):']
    group = None
    for r in survey.ranges:
        if r.group and r.group != group:
            group = r.group
            lines.append(f'  {group}:')
        which = f' ({survey.sets[r.which]})' if len(survey.sets) > 1 else ''
        lines.append(f'{"    " if r.group else "  "}{r.name}{which}: {_range_text(r)}')
    columns, rows = plane_rows(survey)
    lines += ['', 'Maps:']
    lines += [f'  {title}: {columns[1]} {area}; {columns[2]} {cond}; near_singular {near}; '
              f'{columns[4]}: {bound}' for title, area, cond, near, bound in rows]
    if survey.checks:
        lines += ['', f'{survey.checks_title}:']
        lines += [f'  {c.name}: {_statuses(dict(c.statuses))}; '
                  + ', '.join(f'{q.label} {_quantity(q)}' for q in c.figures)
                  for c in survey.checks]
    return lines


def markdown(survey: Survey, args: argparse.Namespace, image: str | None, md_path: str) -> str:
    """The summary as a markdown page that shows the figure ``image``."""
    command = shlex.join(['flight-sim-dynamics', 'workspace', *getattr(args, 'argv', [])])
    out = [f'# {survey.title}\n\nGenerated by `{command}` (grid of {args.resolution} x '
           f'{args.resolution} cell centres per map; range ends refined by bisection). Do not '
           'edit by hand: rerun the command.\n']
    if image:
        rel = os.path.relpath(os.path.abspath(image), os.path.dirname(os.path.abspath(md_path)))
        out.append(f'![reachable regions at rest, coloured by the {survey.condition_label}]'
                   f'({rel})\n')
    if survey.caption:
        out.append(survey.caption + '\n')
    out.append(' '.join(survey.notes) + '\n')
    out.append('## Ranges along a line through home\n\nEach end names what is just beyond '
               'it.\n\n' + table(*range_rows(survey)) + '\n')
    out.append('## Maps\n\nArea, condition and `near_singular` share of the cells, and the '
               'share of the length of each boundary made by each cause (grid estimate).\n\n'
               + table(*plane_rows(survey)) + '\n')
    if survey.checks:
        out.append(f'## {survey.checks_title}\n\n' + table(*check_rows(survey)) + '\n')
    return '\n'.join(out)


# ----------------------------------------------------------------------------
# The figure
# ----------------------------------------------------------------------------
#: Outside the reachable set, one (colour, hatch) per kind of cause, in order of kind.
_SHADES = (('0.86', '//'), ('0.62', '\\\\'), ('#f4c58f', 'xx'), ('#a6cee3', '..'),
           ('#fb9a99', '++'), ('0.3', ''), ('k', ''))
#: Curves and paths, by the order of their labels.
_CURVE_COLOURS = ('#d62728', '#ff7f0e', '#e377c2', '#17becf', '#ffffff', '#9467bd', '#8c564b')
_PATH_COLOURS = ('#00ff00', '#1f77ff', '#ffff00', '#ff00ff')
_NEAR = '#ff0000'
_STAR = dict(marker='*', markersize=13, markeredgecolor='k', linestyle='')


def _halo(width: float = 2.8) -> list:
    """A dark outline: the line stays visible on any colour."""
    import matplotlib.patheffects as pe

    return [pe.withStroke(linewidth=width, foreground='k')]


def regions(mask: np.ndarray) -> list[np.ndarray]:
    """The 4-connected regions of a boolean grid, one mask each (flood fill)."""
    label = np.zeros(mask.shape, dtype=np.int32)
    found = []
    for start in zip(*np.nonzero(mask)):
        if label[start]:
            continue
        n = len(found) + 1
        label[start] = n
        stack = [start]
        while stack:
            i, j = stack.pop()
            for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
                if 0 <= a < mask.shape[0] and 0 <= b < mask.shape[1] and mask[a, b] \
                        and not label[a, b]:
                    label[a, b] = n
                    stack.append((a, b))
        found.append(label == n)
    return found


class _Styles:
    """The look of each kind of cause, curve label and path label, fixed in
    order of first appearance over the whole figure.
    """

    def __init__(self, planes: Sequence[PlaneMap]) -> None:
        self.kinds: list[str] = []
        self.dimmed: list[str] = []
        self.curves: list[str] = []
        self.paths: list[str] = []
        for p in planes:
            for code in np.unique(p.cause).tolist():
                cause = p.causes[code]
                if code:
                    target = self.dimmed if cause.reachable else self.kinds
                    if cause.kind not in target:
                        target.append(cause.kind)
            for c in p.curves:
                if c.label not in self.curves:
                    self.curves.append(c.label)
            for path in p.paths:
                if path.label not in self.paths:
                    self.paths.append(path.label)

    def shade(self, kind: str) -> tuple[str, str]:
        return _SHADES[self.kinds.index(kind) % len(_SHADES)]

    def curve(self, c: Any) -> dict:
        k = self.curves.index(c.label)
        style = dict(colors=_CURVE_COLOURS[k % len(_CURVE_COLOURS)],
                     linewidths=3.2 if c.wide else 1.4, linestyles=c.line)
        return style

    def path(self, label: str) -> dict:
        k = self.paths.index(label)
        return dict(color=_PATH_COLOURS[k % len(_PATH_COLOURS)], linewidth=2.4,
                    linestyle=(0, (3, 1.5)) if k % 2 else '-')


def _draw_panel(ax, plane: PlaneMap, styles: _Styles, norm, cmap) -> Any:
    X, Y = np.meshgrid(plane.x, plane.y)
    reach = plane.inside(0)
    # one contourf per region, the largest first: else an enclosed region loses its hatch
    shaded = []
    for code, cause in enumerate(plane.causes):
        if code and not cause.reachable:
            shaded += [(r, styles.shade(cause.kind)) for r in regions(plane.cause == code)]
    for region, (colour, hatch) in sorted(shaded, key=lambda r: -int(r[0].sum())):
        ax.contourf(X, Y, region.astype(float), levels=[0.5, 1.5], colors=[colour],
                    hatches=[hatch])
    mesh = ax.pcolormesh(X, Y, np.ma.masked_invalid(np.where(reach, plane.condition, np.nan)),
                         norm=norm, cmap=cmap, shading='nearest', rasterized=True)
    beyond = reach & ~plane.inside(1)
    if beyond.any():
        ax.pcolormesh(X, Y, np.ma.masked_where(~beyond, np.ones(X.shape)), cmap='Greys',
                      vmin=0.0, vmax=10.0, alpha=0.5, shading='nearest', rasterized=True)
    near = plane.near_singular & reach
    if near.any():
        ax.pcolormesh(X, Y, np.ma.masked_where(~near, np.ones(X.shape)), cmap='Reds',
                      vmin=0.0, vmax=1.0, alpha=0.8, shading='nearest', rasterized=True)
    # the boundary of the reachable set: thick where a singular cause is beyond it
    singular = np.array([c.singular for c in plane.causes])[plane.cause]
    for other, width in ((~reach & singular, 2.2), (~reach & ~singular, 1.0)):
        if other.any() and reach.any():
            f = np.where(reach, 0.0, np.where(other, 1.0, np.nan))
            ax.contour(X, Y, f, levels=[0.5], colors='k', linewidths=width)
    for c in plane.curves:
        field = np.asarray(c.field, dtype=float)
        if np.nanmin(field, initial=np.inf) <= c.level <= np.nanmax(field, initial=-np.inf):
            cs = ax.contour(X, Y, field, levels=[c.level], **styles.curve(c))
            if c.line in ('dotted', 'dashdot'):
                cs.set(path_effects=_halo())
    ax.plot([0], [0], marker='+', color='k', markersize=11, markeredgewidth=2.4, zorder=6)
    ax.plot([0], [0], marker='+', color='w', markersize=9, markeredgewidth=1.0, zorder=7)
    for path in plane.paths:
        style = styles.path(path.label)
        if len(path.x) == 1:
            ax.plot(path.x, path.y, zorder=8, color=style['color'], **_STAR)
        else:
            ax.plot(path.x, path.y, zorder=5, path_effects=_halo(), **style)
    ax.set_xlim(plane.x[0] - 0.5 * (plane.x[1] - plane.x[0]),
                plane.x[-1] + 0.5 * (plane.x[1] - plane.x[0]))
    ax.set_ylim(plane.y[0] - 0.5 * (plane.y[1] - plane.y[0]),
                plane.y[-1] + 0.5 * (plane.y[1] - plane.y[0]))
    ax.set_aspect('equal')
    ax.set_xlabel(f'{plane.names[0]} ({plane.units[0]})')
    ax.set_ylabel(f'{plane.names[1]} ({plane.units[1]})')
    ax.set_title(plane.title.replace(' at ', '\nat ', 1), fontsize='medium')
    ax.grid(True, alpha=0.25, color='0.3', linewidth=0.6)
    return mesh


def legend_entries(survey: Survey, styles: _Styles) -> tuple[list, list[str]]:
    """The legend's (handles, labels): causes by kind, boundary, curves, paths."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    entries = []
    for kind in styles.kinds:
        colour, hatch = styles.shade(kind)
        entries.append((Patch(facecolor=colour, hatch=hatch, edgecolor='0.35'), kind))
    entries += [(Patch(facecolor='0.82', edgecolor='0.35'), kind) for kind in styles.dimmed]
    entries.append(((Line2D([], [], color='k', linewidth=2.2),
                     Line2D([], [], color='k', linewidth=1.0)),
                    'boundary of the reachable region: at a singularity (thick), at another '
                    'cause (thin)'))
    for label in styles.curves:
        style = styles.curve(next(c for p in survey.planes for c in p.curves if c.label == label))
        effects = _halo() if style['linestyles'] in ('dotted', 'dashdot') else None
        entries.append((Line2D([], [], color=style['colors'], linewidth=style['linewidths'],
                               linestyle=style['linestyles'], path_effects=effects), label))
    if any((p.near_singular & p.inside(0)).any() for p in survey.planes):
        entries.append((Patch(facecolor=_NEAR, alpha=0.8),
                        f'near_singular: {survey.near_singular_rule}'))
    home = [Line2D([], [], color='k', marker='+', linestyle='', markersize=10,
                   markeredgewidth=2)]
    entries.append((tuple(home), 'home (q = 0)'))
    for label in styles.paths:
        single = any(len(p.x) == 1 for pl in survey.planes for p in pl.paths if p.label == label)
        style = styles.path(label)
        handle = (Line2D([], [], color=style['color'], **_STAR) if single
                  else Line2D([], [], path_effects=_halo(), **style))
        entries.append((handle, label))
    return [e[0] for e in entries], [e[1] for e in entries]


def _plain_log_ticks(bar: Any, lo: float, hi: float) -> None:
    """The log colour bar's ticks as plain numbers (3, 10, 100; not 3x10^0), and
    within less than a decade a few round values, since a log axis would label
    at most one.
    """
    from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator, NullLocator

    axis = bar.ax.yaxis
    if hi / lo < 10.0:
        ticks = [t for t in MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
                 if lo <= t <= hi]
        axis.set_major_locator(FixedLocator(ticks))
        axis.set_minor_locator(NullLocator())
    axis.set_major_formatter(FuncFormatter(lambda v, _: f'{v:g}'))
    axis.set_minor_formatter(FuncFormatter(lambda v, _: ''))


def plot(survey: Survey, path: str, dpi: int) -> None:
    """One panel per map, in the maps' rows; one colour scale for all."""
    import matplotlib
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure
    from matplotlib.legend_handler import HandlerTuple

    fmt = output_format(path)
    planes = survey.planes
    rows = sorted({p.row for p in planes})
    grid = [[p for p in planes if p.row == r] for r in rows]
    ncol = max(len(g) for g in grid)
    col_w = 3.5
    heights = [max(col_w * (g[0].y[-1] - g[0].y[0]) / (g[0].x[-1] - g[0].x[0]), 1.0)
               for g in grid]
    fig = Figure(figsize=(max(col_w * ncol + 1.4, 7.0), sum(heights) + 2.3), dpi=dpi,
                 layout='compressed')
    axes = fig.subplots(len(grid), ncol, squeeze=False, gridspec_kw=dict(height_ratios=heights))
    values = np.concatenate([p.condition[p.inside(0) & np.isfinite(p.condition)
                                         & (p.condition > 0)] for p in planes])
    lo = max(1.0, float(values.min())) if values.size else 1.0
    top = float(values.max()) if values.size else 10.0
    hi = max(min(top, 10.0 * survey.max_condition), 1.01 * lo)
    norm = LogNorm(vmin=lo, vmax=hi)
    cmap = matplotlib.colormaps['viridis']
    styles = _Styles(planes)
    mesh = None
    for i, g in enumerate(grid):
        for k in range(ncol):
            if k < len(g):
                mesh = _draw_panel(axes[i, k], g[k], styles, norm, cmap)
                # the left neighbour's label names the same axis (heave beside heave);
                # a new quantity (pitch beside heave) keeps its own
                if k and (g[k].names[1], g[k].units[1]) == (g[k - 1].names[1],
                                                            g[k - 1].units[1]):
                    axes[i, k].set_ylabel('')
            else:
                axes[i, k].set_visible(False)
    bar = fig.colorbar(mesh, ax=axes, label=f'{survey.condition_label}, log scale',
                       extend='max' if top > hi else 'neither', shrink=0.5, pad=0.01)
    _plain_log_ticks(bar, lo, hi)
    handles, labels = legend_entries(survey, styles)
    fig.legend(handles, labels, loc='outside lower center', ncol=2 if ncol > 2 else 1,
               fontsize=8, frameon=False,
               handler_map={tuple: HandlerTuple(ndivide=None)})
    fig.suptitle(survey.title, fontsize='large')
    with atomic_output(path) as f:
        fig.savefig(f, format=fmt, dpi=dpi)


# ----------------------------------------------------------------------------
# The command
# ----------------------------------------------------------------------------
def _flag(option: Option) -> str:
    return '--' + (option.flag or option.name).replace('_', '-')


def options_of(machines: Sequence[Machine]) -> dict[str, tuple[Option, list[Machine]]]:
    """Every machine's workspace options by flag, with the machines that take
    each; ValueError if two machines give one flag different shapes.
    """
    found: dict[str, tuple[Option, list[Machine]]] = {}
    for machine in machines:
        for option in machine.workspace_options:
            flag = _flag(option)
            if flag in found:
                first = found[flag][0]
                if (first.nargs, first.type, first.choices) != (option.nargs, option.type,
                                                                option.choices):
                    raise ValueError(f'{flag}: machines {found[flag][1][0].name} and '
                                     f'{machine.name} give it different shapes')
                found[flag][1].append(machine)
            else:
                found[flag] = (option, [machine])
    return found


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument('-o', '--output', default='workspace.png', metavar='IMAGE',
                   help='figure to write, format by extension (default workspace.png)')
    p.add_argument('--params', metavar='YAML', default=None,
                   help='parameter file, which names the machine (default: the packaged '
                   'parameters)')
    p.add_argument('--resolution', type=int, default=DEFAULT_RESOLUTION, metavar='N',
                   help=f'grid points per axis of each map (default {DEFAULT_RESOLUTION})')
    p.add_argument('--markdown', metavar='MD', default=None,
                   help='also write the summary as a markdown page showing the figure')
    p.add_argument('--dpi', type=int, default=100, help='resolution of raster images '
                   '(default 100)')
    for flag, (option, machines) in options_of(registry.MACHINES).items():
        helps = '; '.join(f'{m.title or m.name}: ' + next(
            o.help for o in m.workspace_options if _flag(o) == flag) for m in machines)
        dest = flag[2:].replace('-', '_')
        if option.nargs == 0:
            p.add_argument(flag, dest=dest, action='store_true', help=helps)
        elif option.choices:
            p.add_argument(flag, dest=dest, choices=option.choices, default=None, help=helps)
        else:
            p.add_argument(flag, dest=dest, type=option.type, nargs=option.nargs,
                           metavar=option.metavar, default=None, help=helps)


def survey_options(args: argparse.Namespace, machine: Machine) -> dict[str, Any]:
    """The keywords of the machine's survey that were given; CliError for an
    option of another machine or a bad value (before any computation).
    """
    own = {_flag(o): o for o in machine.workspace_options}
    for flag in options_of(registry.MACHINES):
        value = getattr(args, flag[2:].replace('-', '_'), None)
        if value in (None, False) or flag in own:
            continue
        raise CliError(f"{flag}: not an option of machine '{machine.name}' (its workspace "
                       'does not use it)')
    given = {}
    for flag, option in own.items():
        value = getattr(args, flag[2:].replace('-', '_'), None)
        if value in (None, False):
            continue
        if option.check is not None:
            try:
                option.check(value)
            except ValueError as exc:
                raise CliError(f'{flag} {exc}') from None
        given[option.name] = value
    return given


def _check(args: argparse.Namespace) -> None:
    output_format(args.output)
    if not 20 <= args.resolution <= 2000:
        raise ValueError(f'--resolution must be between 20 and 2000, got {args.resolution}')
    if not 1 <= args.dpi <= 1200:
        raise ValueError(f'--dpi must be between 1 and 1200, got {args.dpi}')
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
    model = load_model(args.params, machines=registry.MACHINES)
    machine = fsd.machine_of(model)
    if machine.workspace is None:
        raise CliError(f"machine '{machine.name}' has no workspace survey")
    options = survey_options(args, machine)

    def progress(msg: str) -> None:
        print(f'[workspace] {msg}', file=sys.stderr, flush=True)

    progress(f'surveying the {machine.title or machine.name}')
    survey = machine.workspace(model, resolution=args.resolution, **options)
    progress(f'plotting {args.output}')
    plot(survey, args.output, args.dpi)
    print('\n'.join(summary_lines(survey)))
    if args.markdown:
        text = markdown(survey, args, args.output, args.markdown)
        with atomic_output(args.markdown) as f:
            f.write(text.encode())
    progress(f'wrote {args.output}' + (f' and {args.markdown}' if args.markdown else '')
             + f' in {time.perf_counter() - t0:.1f} s')
    return 0
