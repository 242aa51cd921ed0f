"""``flight-sim-dynamics animate``: the mechanism following the output of
``solve`` (side and front views, forces as bars, each frame's status) as .gif,
.mp4 or a .png still. A frame's pose: the file's ``surge,heave,roll``, else
forward kinematics of its leg lengths; its points are the solver's (eq. 5-8).
A row without a solution repeats the last pose drawn, grey, without forces.
"""
from __future__ import annotations

import argparse
import math
import os
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass
from typing import Sequence, TextIO

import numpy as np

import flight_sim_dynamics as fsd

from ..core.vectors import backend
from ..machines.api import poses_along
from ..machines.staicu.kinematics import UnreachablePoseError, inverse_geometry
from ..machines.staicu.mechanism import JOINTS, PLATE_OUTLINE, SEGMENTS, Point3, mechanism_points
from .csv_io import atomic_output, read_table
from .main import LENGTH_COLUMNS, CliError, load_model
from .plotting import ACTUATORS, LEG_COLOURS

POSE_COLUMNS = ('surge', 'heave', 'roll')
FORCE_COLUMNS = ('force_a', 'force_b', 'force_c')
#: Columns the animation needs (others are ignored).
REQUIRED = ('t',) + LENGTH_COLUMNS + FORCE_COLUMNS
#: Statuses whose rows hold no solution (every number 0).
VOID = (str(fsd.Status.UNREACHABLE), str(fsd.Status.INVALID_INPUT))

_SCALAR = backend(False)


@dataclass(frozen=True)
class Solved:
    """The columns of a solved trajectory the animation reads."""

    path: str
    t: np.ndarray            # (N,) s
    lengths: np.ndarray      # (N, 3) m, L_A, L_B, L_C
    force: np.ndarray        # (N, 3) N, f_A, f_B, f_C
    status: list[str]        # one word per row ('ok' when the file has none)
    pose: np.ndarray | None  # (N, 3) surge, heave, roll if the file has them


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
    force: tuple[float, float, float] | None
    note: str = ''


def read_solved(path: str) -> Solved:
    """Read the output of ``solve`` (CSV, '-' for standard input, or .npz)."""
    table = read_table(path, required=REQUIRED, optional=POSE_COLUMNS)
    words = table.text.get('status', ['ok'] * len(table))
    pose = None
    if all(n in table.names for n in POSE_COLUMNS):
        pose = np.column_stack([table[n] for n in POSE_COLUMNS])
    return Solved(path=table.path, t=table['t'].copy(),
                  lengths=np.column_stack([table[n] for n in LENGTH_COLUMNS]),
                  force=np.column_stack([table[n] for n in FORCE_COLUMNS]),
                  status=list(words), pose=pose)


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


def frames(model: fsd.Model, solved: Solved, rows: np.ndarray) -> list[Frame]:
    """The frames of ``rows`` (module docstring: poses, unsolved rows)."""
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
    last = mechanism_points(model, inverse_geometry(model, (0.0, 0.0, 0.0), _SCALAR))
    shown = 'the central configuration'
    out = []
    for k, i in enumerate(rows):
        points = None
        if not void[k] and poses[k] is not None:
            q = tuple(float(v) for v in poses[k])
            try:
                points = mechanism_points(model, inverse_geometry(model, q, _SCALAR))
            except UnreachablePoseError as exc:      # a pose column of the file
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
PROGRESS_SECONDS = 5.0

PART_COLOURS = {'rod': '#3f59cc', 'crank_d': '#1a9999', 'crank_e': '#1a9999'}
PART_WIDTH = {'leg_a': 3.0, 'leg_b': 3.0, 'leg_c': 3.0, 'rod': 3.5, 'crank_d': 2.2,
              'crank_e': 2.2}
PLATE_COLOUR = '#9aa6bf'
VOID_COLOUR = '0.6'
STATUS_COLOURS = {'ok': 'darkgreen', 'limit': 'darkorange', 'near_singular': 'darkmagenta'}
#: The two views: title, horizontal axis (index into X, Y, Z and its label).
VIEWS = (('side view (from the right)', 0, 'X, m (forward)'),
         ('front view', 1, 'Y, m (the machine\'s left)'))


def configure(p: argparse.ArgumentParser) -> None:
    """The options of ``animate``."""
    p.add_argument('input', metavar='OUT_CSV_OR_NPZ',
                   help="output of solve, CSV ('-' for standard input) or .npz; needs "
                        + ','.join(REQUIRED) + ' (and reads status); the pose of each '
                        'frame comes from its leg lengths (forward kinematics) unless the '
                        'file has surge,heave,roll')
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
                   help='the parameter file solve used (default: the packaged parameters)')


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
    model = load_model(args.params)
    solved = read_solved(args.input)
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
    """Encode every frame into ``output`` atomically, progress on ``progress``."""
    from matplotlib import animation

    progress = sys.stderr if progress is None else progress
    writer = animation.writers[encoder](fps=fps)
    suffix = os.path.splitext(output)[1].lower()
    report = Progress(len(frames), output, progress)
    with tempfile.TemporaryDirectory(prefix='fsd-animate-') as tmp:
        movie = os.path.join(tmp, 'movie' + suffix)
        with writer.saving(scene.fig, movie, dpi):
            for k, frame in enumerate(frames):
                scene.draw(frame)
                writer.grab_frame()
                report.done(k + 1)
        with atomic_output(output) as f, open(movie, 'rb') as src:
            shutil.copyfileobj(src, f)


class Progress:
    """``animate: k/n frames`` at each tenth and at least every PROGRESS_SECONDS."""

    def __init__(self, total: int, output: str, stream: TextIO) -> None:
        self.total, self.output, self.stream = total, output, stream
        self.step = max(1, total // 10)
        self.start = self.last = time.monotonic()

    def done(self, k: int) -> None:
        now = time.monotonic()
        if k % self.step and k != self.total and now - self.last < PROGRESS_SECONDS:
            return
        self.last = now
        print(f'animate: {self.output}: {k}/{self.total} frames ({100 * k // self.total}%, '
              f'{now - self.start:.1f} s)', file=self.stream, flush=True)


class Scene:
    """The figure and its artists, made once; :meth:`draw` moves them to a frame."""

    def __init__(self, model: fsd.Model, frames: Sequence[Frame], title: str) -> None:
        from matplotlib.figure import Figure

        self.fig = Figure(figsize=FIGSIZE, dpi=DEFAULT_DPI)
        every = np.array([p for f in frames for p in f.points.values()])
        ground = -model.geometry.h_G          # the base joints' level (y0 = 0)
        lo, hi = every.min(axis=0) - 0.15, every.max(axis=0) + 0.15
        z = (min(lo[2], ground - 0.3), hi[2] + 0.2)   # room for the names below
        widths = [hi[i] - lo[i] for _, i, _ in VIEWS]
        grid = self.fig.add_gridspec(1, 3, width_ratios=widths + [0.32 * sum(widths)],
                                     left=0.065, right=0.985, bottom=0.22, top=0.8, wspace=0.2)
        self.views = []
        for k, (name, axis, label) in enumerate(VIEWS):
            ax = self.fig.add_subplot(grid[0, k])
            ax.set_xlim(lo[axis], hi[axis])
            ax.set_ylim(*z)
            ax.set_aspect('equal', adjustable='box')
            ax.set_title(name, fontsize='medium')
            ax.set_xlabel(label)
            ax.axhline(ground, color='0.3', linewidth=1.0)
            ax.axhspan(z[0], ground, facecolor='0.92', zorder=0)
            ax.grid(True, alpha=0.3)
            self.views.append((axis, ax, self._artists(ax)))
        self.views[0][1].set_ylabel('Z, m (up)')
        self._label_legs(model, frames[0])
        self.ax_force = self.fig.add_subplot(grid[0, 2])
        self._force_axes(model, frames)
        self._legend()
        self.fig.suptitle(title, x=0.065, y=0.97, ha='left', fontsize='large')
        self.status = self.fig.text(0.065, 0.875, '', ha='left', fontsize='large',
                                    fontweight='bold')

    def _artists(self, ax) -> dict:
        from matplotlib.patches import Polygon

        parts = {'plate': ax.add_patch(Polygon(np.zeros((4, 2)), closed=True, zorder=2))}
        for ns in SEGMENTS:
            # leg C dashed over leg B: in the side view they coincide at zero roll
            style = '--' if ns == 'leg_c' else '-'
            parts[ns], = ax.plot([], [], linestyle=style, linewidth=PART_WIDTH[ns],
                                 solid_capstyle='round', zorder=3)
        parts['joints'], = ax.plot([], [], linestyle='none', marker='o', markersize=4,
                                   color='0.15', zorder=4)
        return parts

    def _legend(self) -> None:
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        handles = [Line2D([], [], color=c, linewidth=3.0, linestyle='--' if n == 'C' else '-',
                          label=f'leg {n}') for n, c in zip(ACTUATORS, LEG_COLOURS)]
        handles += [Line2D([], [], color=PART_COLOURS['rod'], linewidth=3.5, label='rod A3G'),
                    Line2D([], [], color=PART_COLOURS['crank_d'], linewidth=2.2,
                           label='cranks D, E'),
                    Patch(facecolor=PLATE_COLOUR, edgecolor='0.35', label='platform'),
                    Line2D([], [], linestyle='none', marker='o', markersize=4, color='0.15',
                           label='joints')]
        self.fig.legend(handles=handles, loc='lower center', ncol=len(handles),
                        frameon=False, bbox_to_anchor=(0.5, 0.0))

    def _label_legs(self, model: fsd.Model, frame: Frame) -> None:
        """Names of the legs at their base joints (fixed), below the ground."""
        for axis, ax, _ in self.views:
            names = {'A': 'A1', 'B': 'B1', 'C': 'C1'} if axis else {'A': 'A1', 'B, C': 'B1'}
            for text, joint in names.items():
                leg = 'ABC'.index(text[0])
                ax.annotate(text, (frame.points[joint][axis], -model.geometry.h_G),
                            xytext=(0, -5), textcoords='offset points', ha='center',
                            va='top', color=LEG_COLOURS[leg], fontweight='bold')

    def _force_axes(self, model: fsd.Model, frames: Sequence[Frame]) -> None:
        ax = self.ax_force
        forces = np.array([f.force for f in frames if f.force is not None]).reshape(-1)
        lo = min(0.0, float(forces.min())) if forces.size else 0.0
        hi = max(0.0, float(forces.max())) if forces.size else 1.0
        pad = 0.2 * (hi - lo) or 1.0
        ax.set_ylim(lo - (pad if lo < 0 else 0.0), hi + pad)
        self.bars = ax.bar(ACTUATORS, [0.0, 0.0, 0.0], color=LEG_COLOURS, width=0.6)
        self.values = [ax.text(i, 0.0, '', ha='center', va='bottom', fontsize='small')
                       for i in range(3)]
        ax.axhline(0.0, color='0.3', linewidth=0.8)
        limit = model.limits.max_force
        for sign in (1.0, -1.0):
            if lo <= sign * limit <= hi + pad:
                ax.axhline(sign * limit, color='red', linestyle='--', linewidth=1.0)
        ax.set_title('actuator forces', fontsize='medium')
        ax.set_ylabel('force f, N (+ pushes apart)')
        ax.grid(True, axis='y', alpha=0.3)
        self.void_text = ax.text(1.0, 0.5 * (lo + hi), '', ha='center', va='center',
                                 color='0.35', fontsize='medium', fontweight='bold')

    def draw(self, frame: Frame) -> None:
        """Move every artist to ``frame``."""
        p = frame.points
        for axis, _, parts in self.views:
            for leg, ns in enumerate(SEGMENTS):
                a, b = SEGMENTS[ns]
                line = parts[ns]
                line.set_data([p[a][axis], p[b][axis]], [p[a][2], p[b][2]])
                colour = LEG_COLOURS[leg] if leg < 3 else PART_COLOURS[ns]
                line.set_color(colour if frame.solved else VOID_COLOUR)
                line.set_alpha(1.0 if frame.solved else 0.6)
            parts['plate'].set_xy([(p[n][axis], p[n][2]) for n in PLATE_OUTLINE])
            parts['plate'].set_facecolor(PLATE_COLOUR if frame.solved else '0.85')
            parts['plate'].set_edgecolor('0.35' if frame.solved else VOID_COLOUR)
            parts['plate'].set_alpha(0.85 if frame.solved else 0.5)
            joints = [p[n] for n in JOINTS]
            parts['joints'].set_data([j[axis] for j in joints], [j[2] for j in joints])
        force = frame.force if frame.solved else (0.0, 0.0, 0.0)
        for bar, value, f in zip(self.bars, self.values, force):
            bar.set_height(f)
            value.set_position((bar.get_x() + bar.get_width() / 2, max(f, 0.0)))
            value.set_text(f'{f:.1f} N' if frame.solved else '')
        self.void_text.set_text('' if frame.solved else f'no solution\n({frame.status})')
        text = f't = {frame.t:.3f} s    status: {frame.status}'
        if not frame.solved:
            text += f' - {frame.note}'
        self.status.set_text(text)
        self.status.set_color(STATUS_COLOURS.get(frame.status, 'firebrick')
                              if frame.solved else 'firebrick')
