"""The motion-cueing planner on a machine: the washout (:mod:`.washout`) in the
machine's coordinates, then the limiter (:mod:`.limiter`), one output sample
per :meth:`Planner.step`; :func:`run` the same loop over a whole vehicle log,
resampled to the output rate by linear interpolation (design, "Time").

The machine's coordinates are some of the six setpoint components (surge, sway,
heave, roll, pitch, yaw; REP-103, the dynamics node's setpoint convention,
which is also the ``q`` the machines' solvers take: a machine with a frame of
its own converts inside its solver); the channels a machine lacks are dropped
(:attr:`Planner.dropped`).
"""
from __future__ import annotations

import multiprocessing
from dataclasses import dataclass
from itertools import repeat
from typing import Any, Callable, Iterator, NamedTuple

import numpy as np

from ..machines.api import machine_of
from .limiter import InverseDynamicsLimiter, make_limiter
from ..config.cueing import G, CueingParams
from .preview import gain_profile, scaled
from .washout import CHANNELS, Washout, forecast_matrix

#: The washout's free response is given to the limiter's look-ahead every this
#: many steps (it changes slowly; the limiter's gain moves every step).
AHEAD_EVERY = 3
#: Samples per block of :func:`run` (its two stages take turns a block at a time).
BLOCK = 4096

#: :attr:`CueSample.status` values
OK = 'ok'
INPUT_HELD = 'input_held'        # a non-finite input sample: the last finite one was used


class CueSample(NamedTuple):
    """One output sample: ``q``, ``qd``, ``qdd`` in the machine's coordinates
    (``machine_of(model).coordinates``); ``given_up`` in [0, 1] how much of the
    washout's cue the limiter gave up (0: nothing); ``limit`` the limit that
    made it ('' when none); ``status`` :data:`OK` or :data:`INPUT_HELD`.
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    given_up: float = 0.0
    limit: str = ''
    status: str = OK


class Planner:
    """Washout and limiter of ``params`` for ``model`` (any machine), one sample
    of period ``1 / params.rate`` per :meth:`step`; ``look_ahead`` False: the
    limiter's look-ahead (L7) off (:func:`run`'s preview replaces it).
    """

    def __init__(self, model: Any, params: CueingParams, look_ahead: bool = True) -> None:
        self.model, self.params = model, params
        self.machine = machine_of(model)
        coordinates = self.machine.coordinates
        unknown = [c for c in coordinates if c not in CHANNELS]
        if unknown:
            raise ValueError(f'motion cueing drives the coordinates {", ".join(CHANNELS)}; '
                             f'{self.machine.name} has {", ".join(unknown)}')
        #: positions in the washout's six channels of the machine's coordinates
        self.index = np.array([CHANNELS.index(c) for c in coordinates])
        #: the channels the machine lacks: not cued (reported)
        self.dropped: tuple[str, ...] = tuple(c for c in CHANNELS if c not in coordinates)
        # the washout's 18 numbers (q, qd, qdd) the machine takes, in its order
        self._take = (None if coordinates == CHANNELS else
                      [row * 6 + i for row in range(3) for i in self.index.tolist()])
        self._dof = len(coordinates)
        self.washout = Washout(params)
        self.limiter = make_limiter(model, params)
        # the limiter's look-ahead (limiter.py, L7): the washout's free response
        self._horizons: tuple[float, ...] = (getattr(self.limiter, 'horizons', ())
                                             if look_ahead else ())
        self._forecast = (forecast_matrix(params, self._horizons) if self._horizons
                          else None)
        self._index = self.index.tolist()
        self._count = -1             # steps since the start (the look-ahead's period)
        self.held = 0                 # non-finite input samples replaced by the last finite one
        # the limiter's steps on lists of floats (InverseDynamicsLimiter.step_lists)
        governed = isinstance(self.limiter, InverseDynamicsLimiter)
        self._step_lists = self.limiter.step_lists if governed else None
        self._fits_rows = self.limiter.fits_rows if governed else None
        self._last = np.array([0.0, 0.0, G, 0.0, 0.0, 0.0])

    def reset(self) -> None:
        """At rest, at home; the next sample is the new rest reference."""
        self.washout.reset()
        self.limiter.reset()
        self.held = 0
        self._count = -1
        self._last[:] = (0.0, 0.0, G, 0.0, 0.0, 0.0)

    def step(self, f: np.ndarray, omega: np.ndarray) -> CueSample:
        """One output sample of the vehicle's specific force ``f`` (3,) m/s² and
        angular velocity ``omega`` (3,) rad/s at this output time. A non-finite
        input is replaced by the last finite one (status :data:`INPUT_HELD`; the
        vehicle at rest if none came yet: the platform stays home).
        """
        q, qd, qdd, given_up, limit, status = self.step_values(f, omega)
        if self._step_lists is not None:
            q, qd, qdd = np.array(q), np.array(qd), np.array(qdd)
        return CueSample(q, qd, qdd, given_up, limit, status)

    def step_values(self, f: np.ndarray, omega: np.ndarray) -> tuple:
        """:meth:`step` as (q, qd, qdd, given_up, limit, status), q, qd, qdd lists
        of floats with the inverse-dynamics limiter (its state: not to be
        changed), arrays without: :meth:`wish`, then :meth:`limit`.
        """
        wish, ahead, status = self.wish(f, omega)
        return (*self.limit(wish, ahead), status)

    def wish(self, f: np.ndarray, omega: np.ndarray) -> tuple[list[float], Any, str]:
        """The first stage of a step: the washout's sample for the input (f, omega)
        (held, and counted, when not finite) in the machine's coordinates (q, qd,
        qdd one list), its free response for the limiter's look-ahead (poses, or
        None: not this step), and the step's status. It does not depend on the
        limiter, so a whole log's wishes can be made ahead (:func:`run`).
        """
        washout = self.washout
        status = OK
        if washout.load(f, omega):
            self._last[:] = washout.input
        else:
            washout.input[:] = self._last
            status = INPUT_HELD
            self.held += 1
        values = washout.advance()
        take = self._take
        wish = values if take is None else [values[i] for i in take]
        self._count += 1
        if self._forecast is None or self._count % AHEAD_EVERY:
            return wish, None, status
        ahead = washout.ahead(self._forecast, self._horizons)
        if take is not None:
            index = self._index
            ahead = [[pose[i] for i in index] for pose in ahead]
        return wish, ahead, status

    def judge(self, wanted: np.ndarray) -> list[bool] | None:
        """Whether the limiter passes each of the washout's wishes (rows of
        ``wanted``, :meth:`wish`'s lists side by side) on as it is once caught
        up with it (:meth:`.InverseDynamicsLimiter.fits_rows`: a function of
        the wish alone; None: no such limiter). The limiter judges a wish
        itself when needed; :func:`run` judges a block's ahead.
        """
        if self._fits_rows is None:
            return None
        dof = self._dof
        return self._fits_rows(wanted[:, :dof], wanted[:, dof:2 * dof],
                               wanted[:, 2 * dof:]).tolist()

    def limit(self, wish: list[float], ahead: Any, fits: bool | None = None) -> tuple:
        """The second stage of a step: the limiter's sample for the washout's
        ``wish`` and ``ahead`` (:meth:`wish`; ``fits``: :meth:`judge` of it, or
        None): (q, qd, qdd, given_up, limit).
        """
        dof = self._dof
        step = self._step_lists
        if step is not None:
            return step(wish[:dof], wish[dof:2 * dof], wish[2 * dof:], ahead, fits)
        out = np.array(wish)
        lim = (self.limiter.step(out[:dof], out[dof:2 * dof], out[2 * dof:]) if ahead is None
               else self.limiter.step(out[:dof], out[dof:2 * dof], out[2 * dof:], ahead))
        return lim.q, lim.qd, lim.qdd, lim.given_up, lim.limit


class SampleError(ValueError):
    """A bad input sample: ``index`` (0-based) is the sample at fault."""

    def __init__(self, index: int, message: str) -> None:
        super().__init__(f'sample {index}: {message}')
        self.index, self.reason = index, message


@dataclass(frozen=True)
class CueRun:
    """A whole log through the planner (:func:`run`): output times ``t`` (N,),
    ``q``, ``qd``, ``qdd`` (N, machine coordinates), ``given_up`` (N,),
    ``limit`` (N,) strings; the washout's wish in the machine's coordinates
    ``desired_q``, ``desired_qd``, ``desired_qdd`` (N, coordinates; with
    ``limiter: none`` the output's own arrays); the vehicle's input on the output grid
    ``f``, ``omega`` (N, 3); ``coordinates``; ``dropped`` channels;
    ``repeated`` input times dropped; ``held`` non-finite samples held.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    given_up: np.ndarray
    limit: np.ndarray
    desired_q: np.ndarray
    desired_qd: np.ndarray
    desired_qdd: np.ndarray
    f: np.ndarray
    omega: np.ndarray
    coordinates: tuple[str, ...]
    dropped: tuple[str, ...]
    repeated: int
    held: int


def resample(t: np.ndarray, values: np.ndarray, rate: float
             ) -> tuple[np.ndarray, np.ndarray, int]:
    """``values`` (N, k) at times ``t`` (N,) on the grid ``t[0] + n / rate`` up
    to the last time, by linear interpolation; repeated times dropped (the first
    of each kept) and counted. :class:`SampleError` (a ValueError) naming the
    sample index (0-based) of a non-finite time or one that goes backwards.
    Returns (grid, values, repeated).
    """
    t = np.asarray(t, dtype=float)
    values = np.asarray(values, dtype=float)
    if t.ndim != 1 or values.ndim != 2 or len(values) != len(t):
        raise ValueError(f'expected times (N,) and values (N, k), got {t.shape} and '
                         f'{values.shape}')
    if len(t) == 0:
        raise ValueError('no samples')
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise SampleError(int(bad[0]), f'time is not finite ({t[bad[0]]!r})')
    dt = np.diff(t)
    back = np.flatnonzero(dt < 0)
    if back.size:
        i = int(back[0]) + 1
        raise SampleError(i, f'time {t[i]!r} goes backwards (the sample before: {t[i - 1]!r})')
    keep = np.concatenate(([True], dt > 0))
    repeated = int(len(t) - keep.sum())
    t, values = t[keep], values[keep]
    n = int(np.floor((t[-1] - t[0]) * rate + 1e-9)) + 1
    grid = t[0] + np.arange(n) / rate
    out = np.empty((n, values.shape[1]))
    for k in range(values.shape[1]):
        out[:, k] = np.interp(grid, t, values[:, k])
    return grid, out, repeated


def run(model: Any, params: CueingParams, t: np.ndarray, f: np.ndarray, omega: np.ndarray,
        progress: Callable[[int, int, str], None] | None = None, *,
        on_block: Callable[[np.ndarray, np.ndarray], None] | None = None,
        parallel: bool = False) -> CueRun:
    """A vehicle log (times ``t`` (N,) s, specific force ``f`` (N, 3), angular
    velocity ``omega`` (N, 3)) through :class:`Planner`, resampled to
    ``params.rate`` (:func:`resample`: ValueError naming the sample of a time
    going backwards), :data:`BLOCK` samples at a time: the block's wishes
    (:meth:`Planner.wish`), then its limited samples (:meth:`Planner.limit`),
    the steps of :meth:`Planner.step` in another order. With ``preview.slope``
    set (inverse-dynamics limiter), the vehicle's motion is first scaled by the
    preview's gain (:func:`_preview`; the look-ahead off), ``given_up`` and
    ``limit`` count it, and ``desired_*`` stay the full-gain washout's; where
    it lowers nothing, its first pass's wishes and judgements are the run's
    (the same numbers: made once).
    Each block's wishes are judged at once (:meth:`Planner.judge`);
    ``parallel``: made and judged in a second process (forked), a block
    ahead of the limiter (the preview's too), the same numbers bit for bit.
    ``on_block(t, samples)``: each block's output times and samples (q, qd,
    qdd side by side) when they are final (to write them out as they come);
    ``progress(done, total, stage)``: called now and then (``stage`` '' for
    the output's samples, ``'preview pass <i>'`` for the preview's passes).
    """
    grid, inputs, repeated = resample(t, np.hstack([np.asarray(f, dtype=float),
                                                    np.asarray(omega, dtype=float)]),
                                      params.rate)
    slope = (params.limiter_settings['preview.slope'] if params.limiter == 'inverse_dynamics'
             else 0.0)
    planner = Planner(model, params, look_ahead=slope == 0.0)
    n, dof = len(grid), len(planner.index)
    out = np.empty((n, 3 * dof))         # q, qd, qdd
    # the washout's wish differs from the output only through the limiter
    wish = None if params.limiter == 'none' else np.empty((n, 3 * dof))
    blocks = [(lo, min(lo + BLOCK, n)) for lo in range(0, n, BLOCK)]
    preview = None
    if slope > 0.0 and n:
        preview = _preview(model, params, planner, inputs, wish, blocks, parallel, progress)
        source, inputs = inputs, scaled(inputs, preview[0])
    given_up = np.empty(n)
    limit = np.empty(n, dtype=object)
    every = max(1, n // 100)
    if preview is not None and (preview[0] == 1.0).all() and len(preview[2]) == len(blocks):
        # nothing lowered: the first pass's wishes are these, bit for bit
        made = ((wish[lo:hi], repeat(None), fits, held)
                for (lo, hi), (fits, held) in zip(blocks, preview[2]))
    else:
        made = (_WishProcess(planner, inputs, blocks) if parallel and n > BLOCK
                else (wishes(planner, inputs[lo:hi]) for lo, hi in blocks))
    step = planner.limit
    held = 0
    try:
        for (lo, hi), (wanted, ahead, fits, held_here) in zip(blocks, made):
            samples = [step(w, a, j) for w, a, j in zip(wanted.tolist(), ahead,
                                                        fits or repeat(None))]
            out[lo:hi] = np.array([s[:3] for s in samples]).reshape(hi - lo, 3 * dof)
            given_up[lo:hi] = [s[3] for s in samples]
            limit[lo:hi] = [s[4] for s in samples]
            if wish is not None and preview is None:
                wish[lo:hi] = wanted
            held += held_here
            if on_block is not None:
                on_block(grid[lo:hi], out[lo:hi])
            if progress is not None and (lo // every != hi // every or lo == 0):
                progress(lo, n, '')
    finally:
        if isinstance(made, _WishProcess):
            made.close()
    if progress is not None:
        progress(n, n, '')
    if preview is not None:
        gain, named, _ = preview
        given_up = 1.0 - gain * (1.0 - given_up)
        limit = np.where(limit == '', named, limit)
        inputs = source
    wish = out if wish is None else wish
    q, qd, qdd = out[:, :dof], out[:, dof:2 * dof], out[:, 2 * dof:]
    return CueRun(grid, q, qd, qdd, given_up, limit, wish[:, :dof], wish[:, dof:2 * dof],
                  wish[:, 2 * dof:], inputs[:, :3].copy(), inputs[:, 3:].copy(),
                  planner.machine.coordinates, planner.dropped, repeated, held)


def _preview(model: Any, params: CueingParams, planner: Planner, inputs: np.ndarray,
             wish: np.ndarray, blocks: list, parallel: bool,
             progress: Callable[[int, int, str], None] | None
             ) -> tuple[np.ndarray, np.ndarray, list]:
    """(L8) The preview's gain on ``inputs`` (n, 6), the limit behind it
    (:func:`.preview.gain_profile`, judged by ``planner``'s limiter) and the
    first pass's judgement and held inputs of each block: each pass the
    washout of a planner of its own from rest, its wishes judged, with
    ``parallel``, in a second process as :func:`run`'s are; ``wish`` (n, the
    q, qd, qdd of the machine's coordinates) filled with the first pass's, the
    full-gain washout.
    """
    n, dof = len(inputs), len(planner.index)
    judge = Planner(model, params, look_ahead=False)
    first = [True]
    first_pass: list[tuple[list | None, int]] = []

    def judged(rows: np.ndarray) -> Iterator[tuple[list, bool | None]]:
        judge.reset()
        keep, first[0] = first[0], False
        made = (_WishProcess(judge, rows, blocks) if parallel and n > BLOCK
                else (wishes(judge, rows[lo:hi]) for lo, hi in blocks))
        try:
            for (lo, hi), (wanted, _, fits, held) in zip(blocks, made):
                if keep:
                    wish[lo:hi] = wanted
                    first_pass.append((fits, held))
                yield from zip(wanted.tolist(), fits or repeat(None))
        finally:
            if isinstance(made, _WishProcess):
                made.close()

    slope, lead = (params.limiter_settings[k] for k in ('preview.slope', 'preview.lead'))
    gain, named = gain_profile(inputs, judged, planner.limiter.fitting_gain, dof, params.rate,
                               slope, lead, None if progress is None else
                               lambda i, k: progress(k, n, f'preview pass {i}'))
    return gain, named, first_pass


def wishes(planner: Planner, inputs: np.ndarray) -> tuple[np.ndarray, list, list | None, int]:
    """:meth:`Planner.wish` of each row of ``inputs`` (n, 6: f, omega):
    (the wishes (n, q, qd, qdd side by side), the look-aheads,
    :meth:`Planner.judge` of the wishes, how many inputs were held).
    """
    before = planner.held
    made = [planner.wish(u[:3], u[3:])[:2] for u in inputs]
    wanted = np.array([m[0] for m in made]).reshape(len(made), 3 * planner._dof)
    return wanted, [m[1] for m in made], planner.judge(wanted), planner.held - before


class _WishProcess:
    """:func:`wishes` of each block, judged, in a forked process (its own copy
    of the planner's washout, which nothing else advances; the limiter's
    judgement of a wish does not depend on its state), sent back block by block;
    the pipe holds the child at most about a block ahead of the limiter.
    """

    def __init__(self, planner: Planner, inputs: np.ndarray, blocks: list) -> None:
        context = multiprocessing.get_context('fork')
        self._receive, send = context.Pipe(duplex=False)
        self._process = context.Process(target=_send_wishes, daemon=True,
                                        args=(planner, inputs, blocks, send))
        self._process.start()
        send.close()
        self._blocks = len(blocks)

    def __iter__(self) -> Iterator[tuple[list, list, list | None, int]]:
        for _ in range(self._blocks):
            try:
                message = self._receive.recv()
            except EOFError:
                raise RuntimeError('the motion-cueing planner\'s washout process ended '
                                   f'(exit code {self._process.exitcode})') from None
            if isinstance(message, BaseException):
                raise message
            yield message

    def close(self) -> None:
        self._receive.close()
        if self._process.is_alive():
            self._process.terminate()
        self._process.join()


def _send_wishes(planner: Planner, inputs: np.ndarray, blocks: list, send: Any) -> None:
    """The child of :class:`_WishProcess`: each block's wishes (an array) down the pipe."""
    try:
        for lo, hi in blocks:
            send.send(wishes(planner, inputs[lo:hi]))
    except BrokenPipeError:
        return                  # the parent stopped reading: nothing to say
    except BaseException as exc:        # said in the parent
        send.send(exc)
    finally:
        send.close()
