"""``flight-sim-dynamics animate`` (issue 15, "See the mechanism"): a solved
trajectory rendered as a GIF with the expected frames; the points every frame
is drawn from are the solver's joint positions of the trajectory's poses (to
1e-9, recovered from the leg lengths of solve's output); rows without a
solution are drawn as such; bad input is one error line, exit status 2, no
output file."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import animate
from flight_sim_dynamics.cli import csv_io
from flight_sim_dynamics.cli.main import main
from flight_sim_dynamics.machines.staicu.mechanism import JOINTS, SEGMENTS
from flight_sim_dynamics.machines.staicu.trajectories import paper_example, sample_times

MODEL = fsd.load_model()
POSE = ('surge', 'heave', 'roll')


def expected_points(q) -> dict[str, np.ndarray]:
    """The solver's joint positions of pose ``q`` (paper axes, origin A1),
    moved to the REP-103 simulator base (origin at G's central position,
    Y = -z0, Z = y0): written here independently of machines/staicu/mechanism.py."""
    sol = fsd.solve(MODEL, q, [0.0] * 3, [0.0] * 3)
    assert sol.status is fsd.Status.OK
    geom, g = MODEL.geometry, sol.geometric
    origin = np.array([geom.d2 + geom.d3 + geom.d4, geom.h_G, 0.0])
    paper = {'A1': geom.A1, 'A3': g.A3, 'B1': geom.B1, 'B4': g.B4, 'C1': geom.C1,
             'C4': g.C4, 'D1': geom.D1, 'D2': g.D2, 'E1': geom.E1, 'E2': g.E2, 'G': g.G}
    out = {}
    for name, p in paper.items():
        x, y, z = np.asarray(p, dtype=float) - origin
        out[name] = np.array([x, -z, y])
    return out


def write_trajectory(path: Path, rate: float, unreachable: slice | None = None) -> np.ndarray:
    """The paper's general motion (eq. 6) as a trajectory CSV; the rows of
    ``unreachable`` lifted 3 m (no such pose). Returns the poses."""
    t = sample_times(rate)
    q, qd, qdd = paper_example('general', t)
    if unreachable is not None:
        q = q.copy()
        q[unreachable, 1] = 3.0
    csv_io.write_csv(path, csv_io.TRAJECTORY_COLUMNS, np.column_stack([t, q, qd, qdd]))
    return q


def solve(tmp_path: Path, rate: float = 20.0, output: str = 'out.csv',
          unreachable: slice | None = None) -> tuple[Path, np.ndarray]:
    q = write_trajectory(tmp_path / 'traj.csv', rate, unreachable)
    assert main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / output)]) == 0
    return tmp_path / output, q


def test_renders_a_gif_with_the_expected_frames(tmp_path, capsys):
    out, _ = solve(tmp_path)                       # 61 rows, t = 0 .. 3 s
    capsys.readouterr()
    gif = tmp_path / 'motion.gif'
    assert main(['animate', str(out), '-o', str(gif), '--every', '10', '--dpi', '20']) == 0
    with Image.open(gif) as image:
        assert image.format == 'GIF'
        assert image.n_frames == 7                 # rows 0, 10, ..., 60
        assert image.size == (round(animate.FIGSIZE[0] * 20), round(animate.FIGSIZE[1] * 20))
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1].startswith(f'animate: {gif}: 7/7 frames (100%')


def test_default_stride_plays_in_about_real_time():
    t = sample_times(100.0)                        # 301 rows over 3 s
    rows = animate.frame_rows(t, 25.0, None)
    assert np.array_equal(rows, np.arange(0, 301, 4))
    assert np.array_equal(animate.frame_rows(t, 25.0, 7), np.arange(0, 301, 7))
    assert np.array_equal(animate.frame_rows(t[:1], 25.0, None), [0])


@pytest.mark.parametrize('output', ['out.csv', 'out.npz'])
def test_frames_are_the_solver_joint_positions(tmp_path, output):
    """No pose in solve's output: each frame's pose comes from the leg lengths
    (forward kinematics); the points drawn are then the solver's positions of
    the trajectory's own pose, and the legs are as long as the file says."""
    out, q = solve(tmp_path, output=output)
    solved = animate.read_solved(str(out))
    assert solved.pose is None and solved.status == ['ok'] * 61
    rows = animate.frame_rows(solved.t, 25.0, 3)
    frames = animate.frames(MODEL, solved, rows)
    assert [f.row for f in frames] == list(range(0, 61, 3))
    for frame in frames:
        assert frame.solved and frame.status == 'ok'
        want = expected_points(q[frame.row])
        for name in JOINTS + ('G',):
            np.testing.assert_allclose(frame.points[name], want[name], rtol=0, atol=1e-9,
                                       err_msg=f'{name} at row {frame.row}')
        for leg, ns in enumerate(fsd.LEG_NAMES):
            a, b = SEGMENTS[ns]
            length = np.linalg.norm(np.subtract(frame.points[b], frame.points[a]))
            assert abs(length - solved.lengths[frame.row, leg]) < 1e-9
        assert frame.force == tuple(solved.force[frame.row])


def test_pose_columns_are_used_when_present(tmp_path):
    out, q = solve(tmp_path, rate=10.0)
    text = out.read_text().splitlines()
    rows = [f'{line},{",".join(repr(float(v)) for v in q[i])}' for i, line in enumerate(text[1:])]
    (tmp_path / 'posed.csv').write_text('\n'.join([text[0] + ',surge,heave,roll'] + rows) + '\n')
    solved = animate.read_solved(str(tmp_path / 'posed.csv'))
    assert np.array_equal(solved.pose, q)
    for frame in animate.frames(MODEL, solved, np.arange(len(q))):
        np.testing.assert_allclose(frame.points['B4'], expected_points(q[frame.row])['B4'],
                                   rtol=0, atol=1e-12)


def test_rows_without_a_solution_are_drawn_as_such(tmp_path, capsys):
    out, _ = solve(tmp_path, unreachable=slice(30, 40))
    solved = animate.read_solved(str(out))
    frames = animate.frames(MODEL, solved, np.arange(len(solved.t)))
    for frame in frames:
        void = 30 <= frame.row < 40
        assert frame.solved is not void
        if void:
            assert frame.status == 'unreachable' and frame.force is None
            assert frame.points == frames[29].points      # the last solved pose, unchanged
            assert 'grey: the last solved pose' in frame.note
    # without a status column, the zeros solve writes mark the same rows
    header, *lines = out.read_text().splitlines()
    assert header.endswith(',status')
    (tmp_path / 'bare.csv').write_text('\n'.join(
        [header.rsplit(',', 1)[0]] + [line.rsplit(',', 1)[0] for line in lines]) + '\n')
    bare = animate.read_solved(str(tmp_path / 'bare.csv'))
    assert np.array_equal(animate.unsolved(bare), animate.unsolved(solved))
    # the first rows unsolved: the central configuration, said so
    first = animate.frames(MODEL, solved, np.arange(30, 45))
    assert not first[0].solved and 'central configuration' in first[0].note
    central = expected_points((0.0, 0.0, 0.0))
    for name in JOINTS:
        np.testing.assert_allclose(first[0].points[name], central[name], rtol=0, atol=1e-12)
    # a still of an unsolved row, and the movie, render
    capsys.readouterr()
    assert main(['animate', str(out), '-o', str(tmp_path / 'void.png'), '--at', '1.7',
                 '--dpi', '20']) == 0
    assert (tmp_path / 'void.png').read_bytes().startswith(b'\x89PNG\r\n\x1a\n')
    assert main(['animate', str(out), '-o', str(tmp_path / 'm.gif'), '--every', '5',
                 '--dpi', '20']) == 0


def test_progress_lines_at_each_tenth():
    stream = io.StringIO()
    report = animate.Progress(25, 'm.gif', stream)
    for k in range(1, 26):
        report.done(k)
    done = [int(line.split()[2].split('/')[0]) for line in stream.getvalue().splitlines()]
    assert {2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 25} <= set(done)
    assert done == sorted(done) and done[-1] == 25


@pytest.mark.parametrize('case', ['missing file', 'missing column', 'bad number',
                                  'unknown extension', 'mp4 without encoder', 'fps', 'every',
                                  'dpi', 'npz without column'])
def test_bad_input_is_one_error_line(tmp_path, capsys, monkeypatch, case):
    out, _ = solve(tmp_path, rate=10.0)
    target = tmp_path / 'motion.gif'
    argv = ['animate', str(out), '-o', str(target), '--dpi', '20']
    expect = {'missing file': 'nothing.csv', 'missing column': "'force_b'",
              'bad number': 'line 3', 'unknown extension': '.gif, .mp4',
              'mp4 without encoder': 'ffmpeg', 'fps': '--fps', 'every': '--every',
              'dpi': '--dpi', 'npz without column': "'force_b'"}[case]
    if case == 'missing file':
        argv[1] = str(tmp_path / 'nothing.csv')
    elif case == 'missing column':
        header, *lines = out.read_text().splitlines()
        out.write_text('\n'.join([header.replace('force_b', 'force_x')] + lines) + '\n')
    elif case == 'bad number':
        lines = out.read_text().splitlines()
        lines[2] = lines[2].replace(',', ',abc', 1)
        out.write_text('\n'.join(lines) + '\n')
    elif case == 'unknown extension':
        target = tmp_path / 'motion.avi'
    elif case == 'mp4 without encoder':
        monkeypatch.setattr(animate, 'encoder_available', lambda name: name != 'ffmpeg')
        target = tmp_path / 'motion.mp4'
    elif case == 'npz without column':
        data = dict(np.load(solve(tmp_path, rate=10.0, output='out.npz')[0]))
        data['names'] = np.array([n for n in data['names'] if n != 'force_b'])
        del data['force_b']
        np.savez(tmp_path / 'cut.npz', **data)
        argv[1] = str(tmp_path / 'cut.npz')
    else:
        argv += {'fps': ['--fps', '0'], 'every': ['--every', '0'], 'dpi': ['--dpi', '5']}[case]
    argv[3] = str(target)
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: ') and expect in err[0], err
    assert not target.exists()
