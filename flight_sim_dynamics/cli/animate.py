"""``flight-sim-dynamics animate``: the machine following the output of
``solve`` (its views, forces as bars, each frame's status) as .gif, .mp4 or a
.png still, drawn from its :class:`~flight_sim_dynamics.core.drawing.Drawing`
(``Machine.drawing``). A frame's pose: the file's pose columns, else forward
kinematics of its leg lengths. A row without a solution repeats the last pose
drawn, grey, without forces.
"""
from __future__ import annotations

import argparse
import math
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass
from typing import Iterator, Sequence, TextIO

import numpy as np

import flight_sim_dynamics as fsd

from ..core.drawing import Point3
from ..core.machine import Machine
from ..machines import MACHINES
from ..machines.api import poses_along
from .csv_io import atomic_output, read_table, require_columns
from .main import CliError, load_model, refuse_other_machine
from .progress import Progress

#: Sampling rate of a built-in motion (--motion), Hz.
MOTION_RATE = 100.0
#: Statuses whose rows hold no solution (every number 0).
VOID = (str(fsd.Status.UNREACHABLE), str(fsd.Status.INVALID_INPUT))


def leg_columns(machine: Machine, field: str) -> tuple[str, ...]:
    """The per-leg columns of ``field`` in solve's output (``force_a``, ``force_1``)."""
    return tuple(f"{field}_{leg.split('_', 1)[-1]}" for leg in machine.legs)


def required_columns(machine: Machine) -> tuple[str, ...]:
    """Columns the animation needs (others are ignored)."""
    return ('t',) + leg_columns(machine, 'length') + leg_columns(machine, 'force')


@dataclass(frozen=True)
class Solved:
    """The columns of a solved trajectory the animation reads."""

    path: str
    t: np.ndarray            # (N,) s
    lengths: np.ndarray      # (N, legs) m
    force: np.ndarray        # (N, legs) N
    status: list[str]        # one word per row ('ok' when the file has none)
    pose: np.ndarray | None  # (N, dof) the pose coordinates if the file has them


@dataclass(frozen=True)
class Frame:
    """One frame: row ``row`` at time ``t``; unsolved: the last pose drawn,
    ``force`` None, ``note`` says why.
    """

    row: int
    t: float
    status: str
    solved: bool
    points: dict[str, Point3]
    force: tuple[float, ...] | None
    note: str = ''


def read_solved(path: str, machine: Machine = MACHINES[0]) -> Solved:
    """Read the output of ``solve`` (CSV, '-' for standard input, or .npz)."""
    pose_columns = machine.coordinates
    every = {c for m in MACHINES for c in required_columns(m) + m.coordinates}
    table = read_table(path, required=(), optional=tuple(sorted(every)))
    refuse_other_machine(table.names, machine, lambda m: leg_columns(m, 'length'),
                         'the output of solve', table.path)
    require_columns(table.names, required_columns(machine), table.path)
    words = table.text.get('status', ['ok'] * len(table))
    pose = None
    if all(n in table.names for n in pose_columns):
        pose = np.column_stack([table[n] for n in pose_columns])
    return Solved(path=table.path, t=table['t'].copy(),
                  lengths=np.column_stack([table[n] for n in leg_columns(machine, 'length')]),
                  force=np.column_stack([table[n] for n in leg_columns(machine, 'force')]),
                  status=list(words), pose=pose)


def solve_motion(model, name: str) -> Solved:
    """The built-in motion ``name`` of the model's machine, solved at MOTION_RATE."""
    machine = fsd.machine_of(model)
    if name not in machine.motions:
        raise CliError(f"--motion {name}: not a motion of machine '{machine.name}'; choose "
                       f"one of {', '.join(machine.motions)}")
    t, q, qd, qdd = machine.motions[name].sampled(MOTION_RATE)
    sol = machine.solve_batch(model, q, qd, qdd)
    return Solved(path=name, t=t, lengths=np.asarray(sol.length, dtype=float),
                  force=np.asarray(sol.force, dtype=float),
                  status=[str(s) for s in sol.status], pose=q)


def frame_rows(t: np.ndarray, fps: float, every: int | None) -> np.ndarray:
    """Every ``every``-th row, or (None) the stride that plays in real time at ``fps``."""
    if every is None:
        steps = np.diff(t)
        step = float(np.median(steps)) if steps.size else 0.0
        every = max(1, round(1.0 / (fps * step))) if step > 0 else 1
    return np.arange(0, len(t), every)


def unsolved(solved: Solved) -> np.ndarray:
    """Rows without a solution (status, or every leg length 0)."""
    void = np.isin(np.asarray(solved.status, dtype=object), VOID)
    return void | np.all(solved.lengths == 0.0, axis=1)


def frames(model, solved: Solved, rows: np.ndarray) -> list[Frame]:
    """The frames of ``rows`` (module docstring: poses, unsolved rows)."""
    machine = fsd.machine_of(model)
    drawing = machine.drawing(model)
    rows = np.asarray(rows, dtype=int)
    void = unsolved(solved)[rows]
    if solved.pose is not None:
        poses = [solved.pose[i] for i in rows]
        why = [''] * len(rows)
    else:
        found = poses_along(model, solved.lengths[rows[~void]])
        it = iter(found)
        poses, why = [], []
        for v in void:
            r = None if v else next(it)
            ok = r is not None and r.status == fsd.Status.OK
            poses.append(r.pose if ok else None)
            why.append('' if v or ok else f'no pose of these leg lengths ({r.status})')
    last = drawing.points((0.0,) * machine.dof)
    shown = drawing.home
    out = []
    for k, i in enumerate(rows):
        points = None
        if not void[k] and poses[k] is not None:
            q = tuple(float(v) for v in poses[k])
            try:
                points = drawing.points(q)
            except ValueError as exc:      # a pose column of the file
                why[k] = f'pose unreachable: {exc}'
        word = solved.status[i]
        if points is None:
            out.append(Frame(int(i), float(solved.t[i]), word, False, last, None,
                             f"{why[k] or 'no solution'}; grey: {shown}"))
        else:
            last, shown = points, 'the last solved pose'
            out.append(Frame(int(i), float(solved.t[i]), word, True, points,
                             tuple(float(f) for f in solved.force[i])))
    return out


#: Output suffix -> the matplotlib movie writer that encodes it (None: a still).
ENCODERS = {'.gif': 'pillow', '.mp4': 'ffmpeg', '.png': None}
DEFAULT_FPS = 25.0
DEFAULT_DPI = 80
FIGSIZE = (11.0, 4.6)          # inches: 880 x 368 pixels at the default dpi

#: Leg colours, leg k the k-th (matplotlib's tab10: A, B, C as plot draws them).
LEG_PALETTE = ('tab:blue', 'tab:orange', 'tab:green', 'tab:red', 'tab:purple', 'tab:brown',
               'tab:pink', 'tab:gray', 'tab:olive', 'tab:cyan')
#: A legend's sample of a part drawn in its leg's colour.
LEGEND_GREY = '0.4'
VOID_COLOUR = '0.6'
STATUS_COLOURS = {'ok': 'darkgreen', 'limit': 'darkorange', 'near_singular': 'darkmagenta'}


def configure(p: argparse.ArgumentParser) -> None:
    """The options of ``animate``."""
    p.add_argument('input', metavar='OUT_CSV_OR_NPZ', nargs='?', default=None,
                   help="output of solve, CSV ('-' for standard input) or .npz; needs t and "
                        'per leg length_* and force_* (and reads status); the pose of each '
                        'frame comes from its leg lengths (forward kinematics) unless the '
                        f"file has the pose coordinates ({','.join(MACHINES[0].coordinates)} "
                        f'for the {MACHINES[0].title})')
    p.add_argument('--motion', metavar='NAME', default=None,
                   help='instead of a file: a built-in motion of the machine of --params, '
                        f'solved at {MOTION_RATE:g} Hz (e.g. violent)')
    p.add_argument('-o', '--output', required=True, metavar='GIF_MP4_OR_PNG',
                   help='animation to write: .gif, or .mp4 (needs ffmpeg); .png writes the '
                        'one frame at --at')
    p.add_argument('--fps', type=float, default=DEFAULT_FPS,
                   help=f'frames per second of the animation (default {DEFAULT_FPS:g})')
    p.add_argument('--every', type=int, default=None, metavar='N',
                   help='draw every N-th row (default: the stride that plays the trajectory '
                        'in about real time at --fps)')
    p.add_argument('--dpi', type=int, default=DEFAULT_DPI,
                   help=f'resolution: the frame is {FIGSIZE[0]:g} x {FIGSIZE[1]:g} inches '
                        f'(default {DEFAULT_DPI}: {FIGSIZE[0] * DEFAULT_DPI:.0f} x '
                        f'{FIGSIZE[1] * DEFAULT_DPI:.0f} pixels)')
    p.add_argument('--at', type=float, default=None, metavar='SECONDS',
                   help='for a .png: the time of the frame drawn (the row nearest to it; '
                        'default: the middle of the trajectory)')
    p.add_argument('--title', default=None, help='title (default: the input file name)')
    p.add_argument('--params', metavar='YAML', default=None,
                   help='the parameter file solve used, which names the machine (default: '
                        'the packaged parameters)')


def encoder_available(name: str) -> bool:
    """Whether matplotlib can run the movie writer ``name`` (pillow, ffmpeg)."""
    from matplotlib import animation

    return animation.writers.is_available(name)


def run(args: argparse.Namespace) -> int:
    """Render the animation (module docstring)."""
    suffix = os.path.splitext(args.output)[1].lower()
    if suffix not in ENCODERS:
        raise CliError(f"cannot tell what to write to '{args.output}': use .gif, .mp4 (needs "
                       'ffmpeg) or .png (one frame)')
    encoder = ENCODERS[suffix]
    if encoder is not None and not encoder_available(encoder):
        raise CliError(f"writing {suffix} needs the {encoder} encoder, which is not installed "
                       f"(no '{encoder}' found by matplotlib); install it or write a .gif")
    if not (math.isfinite(args.fps) and 0 < args.fps <= 100):
        raise CliError(f'--fps must be a number of frames per second in (0, 100], got '
                       f'{args.fps:g}')
    if args.every is not None and args.every < 1:
        raise CliError(f'--every must be a positive number of rows, got {args.every}')
    if not 10 <= args.dpi <= 600:
        raise CliError(f'--dpi must be between 10 and 600, got {args.dpi}')
    if args.at is not None and not np.isfinite(args.at):
        raise CliError(f'--at must be a time in seconds, got {args.at:g}')
    folder = os.path.dirname(os.path.abspath(args.output))
    if not os.path.isdir(folder):        # before rendering, not after
        raise CliError(f"cannot write '{args.output}': directory '{folder}' does not exist")
    model = load_model(args.params, machines=MACHINES)
    machine = fsd.machine_of(model)
    if machine.drawing is None:
        raise CliError(f"machine '{machine.name}' has no drawing to animate")
    if (args.input is None) == (args.motion is None):
        raise CliError('give the output of solve (a file) or --motion NAME, one of the two')
    solved = (read_solved(args.input, machine) if args.motion is None
              else solve_motion(model, args.motion))
    if encoder is None:
        at = 0.5 * (solved.t[0] + solved.t[-1]) if args.at is None else args.at
        row = int(np.argmin(np.abs(solved.t - at)))
        before = np.flatnonzero(~unsolved(solved)[:row])
        # an unsolved row shows the last solved pose before it, as in the movie
        rows = np.array([int(before[-1]), row] if before.size else [row])
    else:
        rows = frame_rows(solved.t, args.fps, args.every)
    drawn = frames(model, solved, rows)
    stem = os.path.splitext(os.path.basename(solved.path))[0]
    title = args.title if args.title is not None else f'{stem}: the mechanism'
    scene = Scene(model, drawn, title)
    if encoder is None:
        scene.draw(drawn[-1])
        with atomic_output(args.output) as f:
            scene.fig.savefig(f, format='png', dpi=args.dpi)
        return 0
    render(scene, drawn, args.output, encoder, args.fps, args.dpi)
    return 0


def render(scene: Scene, frames: Sequence[Frame], output: str, encoder: str, fps: float,
           dpi: int, progress: TextIO | None = None) -> None:
    """Encode every frame into ``output`` atomically, progress on ``progress``.
    The scene is drawn whole once; each frame redraws only what moves on a copy
    of that background (:meth:`Scene.picture`: a whole figure's axes, ticks and
    texts cost ~0.5 s a frame); a GIF is written by Pillow with one palette for
    every frame (:func:`write_gif`), another format by matplotlib's writer.
    """
    progress = sys.stderr if progress is None else progress
    report = Progress(len(frames), output, progress)
    scene.start(dpi)

    def pictures() -> Iterator[np.ndarray]:
        for k, frame in enumerate(frames):
            yield scene.picture(frame)
            report.done(k + 1)

    suffix = os.path.splitext(output)[1].lower()
    with tempfile.TemporaryDirectory(prefix='fsd-animate-') as tmp:
        movie = os.path.join(tmp, 'movie' + suffix)
        if encoder == 'pillow':
            write_gif(movie, pictures(), fps, palette_of(scene, frames))
        else:
            write_movie(movie, pictures(), encoder, fps, dpi, scene.fig.get_size_inches())
        with atomic_output(output) as f, open(movie, 'rb') as src:
            shutil.copyfileobj(src, f)


#: Frames whose colours make a GIF's palette (as many more as a frame kind needs).
PALETTE_FRAMES = 6


def palette_of(scene: Scene, frames: Sequence[Frame]):
    """A 256-colour palette (a Pillow image) of the colours of a few frames:
    some spread over the motion and the first of each kind (status, solved or not).
    """
    from PIL import Image

    kinds = {(f.solved, f.status): f for f in reversed(frames)}
    spread = [frames[int(i)] for i in np.linspace(0, len(frames) - 1, PALETTE_FRAMES)]
    # every second pixel is enough to see each colour, at a quarter of the cost
    mosaic = np.concatenate([scene.picture(f)[::2, ::2, :3] for f in
                             spread + list(kinds.values())])
    return Image.fromarray(mosaic).quantize(256)


def write_gif(path: str, pictures: Iterator[np.ndarray], fps: float, palette) -> None:
    """A looping GIF of ``pictures`` (RGBA arrays) at ``fps``, each mapped to
    ``palette`` (no dither: flat colours stay flat; an adaptive palette per
    frame, Pillow's default, costs ~70 ms a frame).
    """
    from PIL import Image

    images = [Image.fromarray(np.ascontiguousarray(rgba[..., :3])).quantize(
        palette=palette, dither=Image.Dither.NONE) for rgba in pictures]
    images[0].save(path, save_all=True, append_images=images[1:],
                   duration=int(1000 / fps), loop=0)


def write_movie(path: str, pictures: Iterator[np.ndarray], encoder: str, fps: float, dpi: int,
                size: tuple[float, float]) -> None:
    """``pictures`` encoded by matplotlib's movie writer ``encoder``, shown by a
    figure of ``size`` inches at ``dpi`` that holds nothing but them.
    """
    from matplotlib import animation
    from matplotlib.figure import Figure

    writer = animation.writers[encoder](fps=fps)
    sheet = Figure(figsize=size, dpi=dpi)
    shown = None
    with writer.saving(sheet, path, dpi):
        for rgba in pictures:
            if shown is None:
                shown = sheet.figimage(rgba)
            else:
                shown.set_data(rgba)
            writer.grab_frame()


class Scene:
    """The figure and its artists, made once; :meth:`draw` moves them to a frame."""

    def __init__(self, model, frames: Sequence[Frame], title: str) -> None:
        from matplotlib.figure import Figure

        machine = fsd.machine_of(model)
        self.drawing = d = machine.drawing(model)
        self.colours = [LEG_PALETTE[k % len(LEG_PALETTE)] for k in range(len(d.legs))]
        self.fig = Figure(figsize=FIGSIZE, dpi=DEFAULT_DPI)
        every = np.array([p for f in frames for p in f.points.values()])
        # the base joints' level: the first point of each leg
        ground = min(frames[0].points[d.segments[parts[0]][0]][2] for parts in d.legs)
        lo, hi = every.min(axis=0) - 0.15, every.max(axis=0) + 0.15
        z = (min(lo[2], ground - 0.3), hi[2] + 0.2)   # room for the names below
        widths = [hi[v.axis] - lo[v.axis] if v.axis is not None
                  else 1.6 * max(hi[0] - lo[0], hi[1] - lo[1]) for v in d.views]
        three_d = any(v.axis is None for v in d.views)   # wider gaps: room for its labels
        grid = self.fig.add_gridspec(1, len(widths) + 1,
                                     width_ratios=widths + [0.32 * sum(widths)],
                                     left=0.065, right=0.985, bottom=0.22, top=0.8,
                                     wspace=0.35 if three_d else 0.2)
        self.views = []
        for k, view in enumerate(d.views):
            if view.axis is None:
                ax = self.fig.add_subplot(grid[0, k], projection='3d')
                ax.set_xlim(lo[0], hi[0])
                ax.set_ylim(lo[1], hi[1])
                ax.set_zlim(*z)
                ax.set_box_aspect((hi[0] - lo[0], hi[1] - lo[1], z[1] - z[0]), zoom=1.2)
                ax.set_xlabel('X, m')
                ax.set_ylabel('Y, m')
                ax.set_zlabel('Z, m')
                ax.set_title(view.title, fontsize='medium')
            else:
                ax = self.fig.add_subplot(grid[0, k])
                ax.set_xlim(lo[view.axis], hi[view.axis])
                ax.set_ylim(*z)
                ax.set_aspect('equal', adjustable='box')
                ax.set_title(view.title, fontsize='medium')
                ax.set_xlabel(view.label)
                ax.axhline(ground, color='0.3', linewidth=1.0)
                ax.axhspan(z[0], ground, facecolor='0.92', zorder=0)
                ax.grid(True, alpha=0.3)
            self.views.append((view.axis, ax, self._artists(ax, view.axis)))
        next(ax for axis, ax, _ in self.views if axis is not None).set_ylabel('Z, m (up)')
        self._label_legs(frames[0], ground)
        self.ax_force = self.fig.add_subplot(grid[0, len(widths)])
        self._force_axes(machine.actuator_limits(model).max_force, frames)
        self._legend()
        self.fig.suptitle(title, x=0.065, y=0.97, ha='left', fontsize='large')
        self.status = self.fig.text(0.065, 0.875, '', ha='left', fontsize='large',
                                    fontweight='bold')

    def _artists(self, ax, axis: int | None) -> dict:
        from matplotlib.patches import Polygon
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        d = self.drawing
        plates = {}
        for name, corners in d.plates.items():
            if axis is None:
                plates[name] = ax.add_collection3d(Poly3DCollection([np.zeros((len(corners), 3))],
                                                                    zorder=2))
            else:
                plates[name] = ax.add_patch(Polygon(np.zeros((len(corners), 2)), closed=True,
                                                    zorder=2))
        empty = ([], [], []) if axis is None else ([], [])
        lines = {}
        for name, style in ((n, d.styles[n]) for n in d.segments):
            lines[name], = ax.plot(*empty, linestyle=style.linestyle, linewidth=style.width,
                                   solid_capstyle='round', zorder=3)
        joints, = ax.plot(*empty, linestyle='none', marker='o', markersize=4, color='0.15',
                          zorder=4)
        return {'plates': plates, 'lines': lines, 'joints': joints}

    def _legend(self) -> None:
        from matplotlib.legend_handler import HandlerTuple
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        d = self.drawing
        legs = [Line2D([], [], color=c, linewidth=3.0, linestyle=d.styles[parts[0]].linestyle,
                       label=f'leg {n}') for n, c, parts in zip(d.leg_names, self.colours, d.legs)]
        # more than three legs: one entry, its colours side by side, so that the legend
        # stays one line
        handles = legs if len(legs) <= 3 else [tuple(legs)]
        handles += [Line2D([], [], color=d.styles[part].colour or LEGEND_GREY,
                           linewidth=d.styles[part].width, linestyle=d.styles[part].linestyle,
                           label=label) for label, part in d.legend]
        handles += [Patch(facecolor=d.plate_colours[name], edgecolor='0.35', label=name)
                    for name in d.plates]
        handles.append(Line2D([], [], linestyle='none', marker='o', markersize=4, color='0.15',
                              label='joints'))
        labels = [f'legs {d.leg_names[0]}-{d.leg_names[-1]}' if isinstance(h, tuple)
                  else h.get_label() for h in handles]
        self.fig.legend(handles, labels, loc='lower center', ncol=len(handles),
                        frameon=False, bbox_to_anchor=(0.5, 0.0),
                        handler_map={tuple: HandlerTuple(ndivide=None, pad=0.0)})

    def _label_legs(self, frame: Frame, ground: float) -> None:
        """Names of the legs at their base joints (fixed), below the ground; legs
        whose base joints coincide in a projection share one label.
        """
        d = self.drawing
        bases = [frame.points[d.segments[parts[0]][0]] for parts in d.legs]
        for axis, ax, _ in self.views:
            groups: dict[float, list[int]] = {}
            for k, base in enumerate(bases):
                key = k if axis is None else round(base[axis], 9)
                groups.setdefault(key, []).append(k)
            for legs in groups.values():
                text, base = ', '.join(d.leg_names[k] for k in legs), bases[legs[0]]
                style = dict(ha='center', va='top', color=self.colours[legs[0]],
                             fontweight='bold')
                if axis is None:
                    ax.text(base[0], base[1], base[2], text, **style)
                else:
                    ax.annotate(text, (base[axis], ground), xytext=(0, -5),
                                textcoords='offset points', **style)

    def _force_axes(self, limit: float, frames: Sequence[Frame]) -> None:
        ax = self.ax_force
        n = len(self.drawing.legs)
        forces = np.array([f.force for f in frames if f.force is not None]).reshape(-1)
        lo = min(0.0, float(forces.min())) if forces.size else 0.0
        hi = max(0.0, float(forces.max())) if forces.size else 1.0
        pad = 0.2 * (hi - lo) or 1.0
        ax.set_ylim(lo - (pad if lo < 0 else 0.0), hi + pad)
        self.bars = ax.bar(self.drawing.leg_names, [0.0] * n, color=self.colours, width=0.6)
        # more than three bars: values in whole newtons, smaller, so that they fit
        self.value_format = '{:.1f} N' if n <= 3 else '{:.0f}'
        self.values = [ax.text(i, 0.0, '', ha='center', va='bottom',
                               fontsize='small' if n <= 3 else 'x-small') for i in range(n)]
        ax.axhline(0.0, color='0.3', linewidth=0.8)
        for sign in (1.0, -1.0):
            if lo <= sign * limit <= hi + pad:
                ax.axhline(sign * limit, color='red', linestyle='--', linewidth=1.0)
        ax.set_title('actuator forces', fontsize='medium')
        ax.set_ylabel('force f, N (+ pushes apart)')
        ax.grid(True, axis='y', alpha=0.3)
        self.void_text = ax.text((n - 1) / 2, 0.5 * (lo + hi), '', ha='center', va='center',
                                 color='0.35', fontsize='medium', fontweight='bold')

    def moving(self) -> list:
        """The artists :meth:`draw` changes."""
        out = []
        for _, _, parts in self.views:
            out += [*parts['plates'].values(), *parts['lines'].values(), parts['joints']]
        return out + [*self.bars, *self.values, self.void_text, self.status]

    def start(self, dpi: int) -> None:
        """Draw what does not move, at ``dpi``, as the background of :meth:`picture`."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import Collection

        self.fig.set_dpi(dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        moving = self.moving()
        self.canvas.draw()          # every artist once: the 3-D views' depth order
        # in each axes the moving artists and what is drawn above them, in drawing order
        self.layers = []
        for ax in self.fig.axes:
            mine = [a for a in moving if a.axes is ax]
            if not mine:
                continue
            floor = min(a.get_zorder() for a in mine)
            added = {id(a) for a in (*ax.lines, *ax.patches, *ax.texts, *ax.collections)}
            layer = [a for a in ax.get_children() if any(a is m for m in mine)
                     or (id(a) in added and a.get_zorder() >= floor)]
            # a 3-D view orders its polygons by depth, each frame (Axes3D.draw)
            depth = [a for a in layer if isinstance(a, Collection)
                     and hasattr(a, 'do_3d_projection')]
            self.layers.append((layer, depth, min((a.get_zorder() for a in depth), default=0)))
        self.top = [a for a in moving if a.axes is None]
        for artist in [a for layer, _, _ in self.layers for a in layer] + self.top:
            artist.set_animated(True)
        self.canvas.draw()
        self.background = self.canvas.copy_from_bbox(self.fig.bbox)

    def picture(self, frame: Frame) -> np.ndarray:
        """The pixels (rows, columns, RGBA) of ``frame`` (after :meth:`start`)."""
        self.draw(frame)
        self.canvas.restore_region(self.background)
        for layer, depth, lowest in self.layers:
            for k, artist in enumerate(sorted(depth, key=lambda a: a.do_3d_projection(),
                                              reverse=True)):
                artist.set_zorder(lowest + k)
            for artist in sorted(layer, key=lambda a: a.get_zorder()):
                self.fig.draw_artist(artist)
        for artist in self.top:
            self.fig.draw_artist(artist)
        return np.array(self.canvas.buffer_rgba())

    def draw(self, frame: Frame) -> None:
        """Move every artist to ``frame``."""
        d, p = self.drawing, frame.points
        for axis, _, parts in self.views:
            for name, line in parts['lines'].items():
                a, b = d.segments[name]
                if axis is None:
                    line.set_data_3d(*([p[a][i], p[b][i]] for i in range(3)))
                else:
                    line.set_data([p[a][axis], p[b][axis]], [p[a][2], p[b][2]])
                leg, colour = d.leg_of(name), d.styles[name].colour
                colour = self.colours[leg] if colour is None else colour
                line.set_color(colour if frame.solved else VOID_COLOUR)
                line.set_alpha(1.0 if frame.solved else 0.6)
            for name, plate in parts['plates'].items():
                corners = [p[n] for n in d.plates[name]]
                if axis is None:
                    plate.set_verts([corners])
                else:
                    plate.set_xy([(c[axis], c[2]) for c in corners])
                plate.set_facecolor(d.plate_colours[name] if frame.solved else '0.85')
                plate.set_edgecolor('0.35' if frame.solved else VOID_COLOUR)
                plate.set_alpha(0.85 if frame.solved else 0.5)
            joints = [p[n] for n in d.joints]
            if axis is None:
                parts['joints'].set_data_3d(*([j[i] for j in joints] for i in range(3)))
            else:
                parts['joints'].set_data([j[axis] for j in joints], [j[2] for j in joints])
        force = frame.force if frame.solved else (0.0,) * len(self.bars)
        for bar, value, f in zip(self.bars, self.values, force):
            bar.set_height(f)
            value.set_position((bar.get_x() + bar.get_width() / 2, max(f, 0.0)))
            value.set_text(self.value_format.format(f) if frame.solved else '')
        self.void_text.set_text('' if frame.solved else f'no solution\n({frame.status})')
        text = f't = {frame.t:.3f} s    status: {frame.status}'
        if not frame.solved:
            text += f' - {frame.note}'
        self.status.set_text(text)
        self.status.set_color(STATUS_COLOURS.get(frame.status, 'firebrick')
                              if frame.solved else 'firebrick')
