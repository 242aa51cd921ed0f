"""``flight-sim-dynamics animate`` of a hexapod (--params naming it): the
frames' points are the platform joints of the trajectory's poses (recovered
from the leg lengths by forward kinematics, or read from the pose columns),
the six legs end at the base joints, rows without a solution are drawn as
such, and the GIF and the still render."""
from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli import animate, csv_io
from flight_sim_dynamics.cli.main import main
from flight_sim_dynamics.machines.stewart.kinematics import leg_positions, rotation

PARAMS = 'config/stewart_6dof.yaml'
MODEL = fsd.load_model(PARAMS)
MACHINE = fsd.machine_of(MODEL)


def motion(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every coordinate a sine of its own amplitude (m, rad), 0.5 Hz."""
    w, amp = math.pi, np.array([0.1, 0.08, 0.08, 0.12, 0.1, 0.25])
    s, c = np.sin(w * t)[:, None], np.cos(w * t)[:, None]
    return amp * s, amp * w * c, -amp * w * w * s


def write_solved(path: Path, void: slice | None = None, pose: bool = False) -> np.ndarray:
    """solve's output columns of the motion at 10 Hz over 2 s (the rows of
    ``void`` with a NaN pose: invalid_input); returns the poses."""
    t = np.arange(21) / 10.0
    q, qd, qdd = motion(t)
    asked = q.copy()
    if void is not None:
        asked[void, 0] = math.nan
    sol = fsd.solve_batch(MODEL, asked, qd, qdd)
    names = ['t'] + [f'{field}_{i}' for field in ('length', 'force') for i in range(1, 7)]
    columns = [t, sol.length, sol.force]
    if pose:
        names += list(MACHINE.coordinates)
        columns.append(q)
    csv_io.write_csv(path, tuple(names), np.column_stack(columns),
                     text=('status', [str(s) for s in sol.status]))
    return q


def joints_of(q: np.ndarray) -> np.ndarray:
    """P_i = p + R p_i of pose q (the package's kinematics: test_drawing checks
    them against stewart.md's definitions)."""
    q = np.atleast_2d(q)
    return leg_positions(MODEL, MODEL.home + q[:, :3], rotation(q)).P[0]


@pytest.mark.parametrize('pose', [False, True], ids=['forward kinematics', 'pose columns'])
def test_frames_are_the_platform_joints_of_the_poses(tmp_path, pose):
    q = write_solved(tmp_path / 'out.csv', pose=pose)
    solved = animate.read_solved(str(tmp_path / 'out.csv'), MACHINE)
    assert (solved.pose is not None) is pose
    frames = animate.frames(MODEL, solved, np.arange(0, 21, 2))
    for frame in frames:
        assert frame.solved and frame.status == 'ok'
        want = joints_of(q[frame.row])
        for i in range(6):
            np.testing.assert_allclose(frame.points[f'P{i + 1}'], want[i], rtol=0, atol=1e-9)
            np.testing.assert_array_equal(frame.points[f'B{i + 1}'], MODEL.base_joints[i])
            length = np.linalg.norm(np.subtract(frame.points[f'P{i + 1}'],
                                                frame.points[f'B{i + 1}']))
            assert abs(length - solved.lengths[frame.row, i]) < 1e-9
        assert frame.force == tuple(solved.force[frame.row])


def test_rows_without_a_solution_are_drawn_as_such(tmp_path):
    write_solved(tmp_path / 'out.csv', void=slice(5, 8))
    solved = animate.read_solved(str(tmp_path / 'out.csv'), MACHINE)
    frames = animate.frames(MODEL, solved, np.arange(21))
    for frame in frames:
        void = 5 <= frame.row < 8
        assert frame.solved is not void
        if void:
            assert frame.status == 'invalid_input' and frame.force is None
            assert frame.points == frames[4].points
    first = animate.frames(MODEL, solved, np.arange(5, 10))
    assert not first[0].solved and 'grey: home' in first[0].note
    np.testing.assert_allclose(first[0].points['P1'], MODEL.home + MODEL.platform_joints[0],
                               atol=1e-12)


def test_renders_a_gif_and_a_still(tmp_path, capsys):
    write_solved(tmp_path / 'out.csv', void=slice(5, 8))
    gif, png = tmp_path / 'm.gif', tmp_path / 'still.png'
    assert main(['animate', str(tmp_path / 'out.csv'), '--params', PARAMS, '-o', str(gif),
                 '--every', '5', '--dpi', '20']) == 0
    with Image.open(gif) as image:
        assert image.n_frames == 5               # rows 0, 5, 10, 15, 20
        assert image.size == (round(animate.FIGSIZE[0] * 20), round(animate.FIGSIZE[1] * 20))
    assert main(['animate', str(tmp_path / 'out.csv'), '--params', PARAMS, '-o', str(png),
                 '--at', '0.6', '--dpi', '20']) == 0
    assert png.read_bytes().startswith(b'\x89PNG\r\n\x1a\n')


def test_a_3dof_file_read_as_a_hexapod_names_its_machine_and_the_columns(tmp_path, capsys):
    assert main(['example', 'vertical', '--rate', '10', '-o', str(tmp_path / 'traj.csv')]) == 0
    assert main(['solve', str(tmp_path / 'traj.csv'), '-o', str(tmp_path / 'out.csv')]) == 0
    capsys.readouterr()
    assert main(['animate', str(tmp_path / 'out.csv'), '--params', PARAMS, '-o',
                 str(tmp_path / 'm.png')]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'length_1' in err[0] and MACHINE.title in err[0]
    assert fsd.machine_of(fsd.load_model()).title in err[0]
    assert not (tmp_path / 'm.png').exists()


def test_a_built_in_motion_is_solved_and_drawn(tmp_path, capsys):
    solved = animate.solve_motion(MODEL, 'violent')
    t, q, qd, qdd = MACHINE.motions['violent'].sampled(animate.MOTION_RATE)
    np.testing.assert_array_equal(solved.t, t)
    np.testing.assert_array_equal(solved.pose, q)
    np.testing.assert_array_equal(solved.force, fsd.solve_batch(MODEL, q, qd, qdd).force)
    frame = animate.frames(MODEL, solved, [40])[0]
    np.testing.assert_allclose([frame.points[f'P{i}'] for i in range(1, 7)], joints_of(q[40]),
                               atol=1e-12)
    png = tmp_path / 'violent.png'
    assert main(['animate', '--motion', 'violent', '--params', PARAMS, '-o', str(png),
                 '--dpi', '20']) == 0
    assert png.read_bytes().startswith(b'\x89PNG')


@pytest.mark.parametrize('argv, expect', [
    (['--motion', 'vertical'], "'stewart'"),            # a 3-DOF motion
    (['out.csv', '--motion', 'violent'], 'one of the two'),
    ([], 'one of the two')])
def test_motion_errors_are_one_line(tmp_path, capsys, argv, expect):
    write_solved(tmp_path / 'out.csv')
    argv = [str(tmp_path / a) if a.endswith('.csv') else a for a in argv]
    assert main(['animate', *argv, '--params', PARAMS, '-o', str(tmp_path / 'm.png')]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expect in err[0]
    assert not (tmp_path / 'm.png').exists()


def _scene(model, motion: str, rows: slice) -> tuple[animate.Scene, list[animate.Frame]]:
    solved = animate.solve_motion(model, motion)
    drawn = animate.frames(model, solved, np.arange(len(solved.t))[rows])
    return animate.Scene(model, drawn, 'test'), drawn


@pytest.mark.parametrize('model, motion', [(MODEL, 'violent'), (fsd.load_model(), 'vertical')],
                         ids=['hexapod', '3-DOF'])
def test_a_movie_draws_the_whole_figure_once_not_per_frame(tmp_path, model, motion):
    """Issue 29: each frame was a whole redraw (0.6 s of axes, ticks and texts): a
    10 s hexapod GIF took 2.5 min. The figure is drawn whole a bounded number of
    times, whatever the number of frames (8 here: a whole draw per frame would be 8)."""
    scene, drawn = _scene(model, motion, slice(0, 16, 2))
    whole = []
    draw = scene.fig.draw
    scene.fig.draw = lambda renderer: (whole.append(1), draw(renderer))[1]
    animate.render(scene, drawn, str(tmp_path / 'm.gif'), 'pillow', 25.0, 20, io.StringIO())
    assert len(drawn) == 8 and len(whole) <= 2
    with Image.open(tmp_path / 'm.gif') as image:
        assert image.n_frames == len(drawn)


@pytest.mark.parametrize('model, motion', [(MODEL, 'violent'), (fsd.load_model(), 'vertical')],
                         ids=['hexapod', '3-DOF'])
def test_each_movie_frame_is_the_picture_of_a_whole_draw(model, motion):
    """The frames drawn on the background are the frames a whole draw makes (the
    3-D view's depth order, the bars under their limit lines, grey unsolved frames)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    scene, drawn = _scene(model, motion, slice(0, None, 50))
    scene.start(40)
    reference, _ = _scene(model, motion, slice(0, None, 50))     # drawn whole, frame by frame
    reference.fig.set_dpi(40)
    canvas = FigureCanvasAgg(reference.fig)
    for frame in drawn:
        picture = scene.picture(frame).astype(int)
        reference.draw(frame)
        canvas.draw()
        whole = np.asarray(canvas.buffer_rgba()).astype(int)
        assert picture.shape == whole.shape
        differ = np.abs(picture - whole).max(axis=2) > 60
        assert differ.mean() < 0.002, (frame.row, differ.sum())


def test_a_movie_writer_encodes_the_pictures_as_they_are(tmp_path):
    """Formats other than GIF (.mp4: ffmpeg) go through matplotlib's writer, fed
    the pictures by a figure that holds only them: checked with its pillow writer."""
    rng = np.random.default_rng(3)
    size = (2.0, 1.0)
    pictures = [np.dstack([np.full((40, 80), v, np.uint8) for v in rng.integers(0, 256, 3)]
                          + [np.full((40, 80), 255, np.uint8)]) for _ in range(4)]
    animate.write_movie(str(tmp_path / 'm.gif'), iter(pictures), 'pillow', 10.0, 40, size)
    with Image.open(tmp_path / 'm.gif') as image:
        assert image.n_frames == 4 and image.size == (80, 40)
        for k, picture in enumerate(pictures):
            image.seek(k)
            got = np.asarray(image.convert('RGB')).astype(int)
            assert np.abs(got - picture[..., :3]).max() <= 8
