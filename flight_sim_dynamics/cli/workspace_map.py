"""The figure of ``flight-sim-dynamics workspace``: one panel per roll angle
(and a zoomed row): reachable region coloured by the condition number,
unreachable regions hatched by cause, boundaries, stroke-limit contours,
singular curves, the central configuration and the paper's motions.
matplotlib is imported here only.
"""
from __future__ import annotations

import argparse
import math
from typing import Sequence

import matplotlib
import matplotlib.patheffects as pe
import numpy as np
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.legend_handler import HandlerTuple
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from ..core.model import Model
from ..core.trajectories import paper_example, sample_times
from ..core.workspace import (DEGENERATE, E2_OFF_ROD, INVALID, LEGS, LOOP_D, LOOP_E,
                              REACHABLE, RollMap, RollResult, general_pose_at_roll)
from .csv_io import atomic_output
from .plotting import output_format

_CAUSE_STYLE = {LOOP_D: dict(color='0.86', hatch='//', label='unreachable: loop D cannot close'),
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
    """A dark outline that keeps a line visible on any colour."""
    return [pe.withStroke(linewidth=width, foreground='k')]


def _regions(mask: np.ndarray) -> list[np.ndarray]:
    """The 4-connected regions of a boolean grid, one mask each (a flood fill:
    a few ms on a 201 x 201 map).
    """
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
    # one contourf per connected region, the largest first: a region drawn
    # around the hole where a smaller one sits loses that one's hatch
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
    # Boundary of the reachable set: where loop D or E stops closing (a crank
    # tangent to its circle: Q singular) drawn apart from where E2 reaches A3 or G.
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
    """The legend's (handles, labels): one entry per kind of thing drawn, the
    related ones grouped (both strokes of a leg, both kinds of boundary, the
    markers of the paper's motions), so that it stays short.
    """
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
                    f'near_singular: kinematic or actuator-Jacobian condition > '
                    f'{max(lim.max_kinematic_condition, lim.max_jacobian_condition):g}'
                    if lim.max_kinematic_condition == lim.max_jacobian_condition else
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
