# Copyright 2026 The rbd_ros authors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
The ``plot`` executable draws what is in the committed reference bags.

Two independent checks per bag: the PNG that ``plot`` writes is read back with matplotlib and
each of its eight panels must show curves (coloured pixels) or the text saying why not; and the
curves ``plot`` drew (:func:`rbd_ros.bag.plot.draw`) must be the recorded values, decoded here with
``mcap`` + ``mcap_ros2`` (not with rbd_ros's own reader) and transformed with numpy.
"""

from pathlib import Path

from matplotlib import image, pyplot
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import numpy as np
import pytest
from rbd_ros.bag.plot import (draw, draw_robots, draw_world, load_series, load_world, main,
                              render, SAVE_DPI)
from rbd_ros.bag.recording import open_bag
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.params import recorded_parameters
from sim_recorder import rewrite_bag
import yaml

REPO = Path(__file__).resolve().parents[2]
# Single-body bags: the 8-panel figure (a world bag gets the world figure, tested below).
BAGS = sorted(p for p in (REPO / 'bags').iterdir() if (p / 'metadata.yaml').is_file()
              and not recorded_parameters(open_bag(str(p)).config).get('body_names')
              and not recorded_parameters(open_bag(str(p)).config).get('robot_names'))
# Decoded doubles go through the same IEEE operations (or a differently ordered equivalent), so
# the drawn values equal the recorded ones exactly where nothing is computed, and to a few ulp
# where a rotation or a norm is: 1e-12 relative (|values| ≲ 10) is far below any real mistake.
RTOL = 1e-12


def test_there_are_reference_bags():
    assert len(BAGS) >= 3, BAGS


def _decode(bag_dir, mesh_dir):
    """
    Return ``(config, {topic: [(log_time_ns, message), ...]})`` read with mcap_ros2.

    A mesh the node attached is written to ``mesh_dir`` and the config points at it: the
    recorded ``mesh_path`` is where the mesh was on the recording machine.
    """
    (mcap_path,) = bag_dir.glob('*.mcap')
    with open(mcap_path, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        record = next(m for m in reader.iter_metadata() if m.name == 'rbd_ros')
        config = yaml.safe_load(record.metadata['config_yaml'])
        for attachment in reader.iter_attachments():
            if attachment.name == config.get('mesh_path'):
                copy = mesh_dir / Path(attachment.name).name
                copy.write_bytes(attachment.data)
                config['mesh_path'] = str(copy)
        messages = {}
        for _, channel, raw, msg in reader.iter_decoded_messages():
            if channel.topic != '/diagnostics':
                messages.setdefault(channel.topic, []).append((raw.log_time, msg))
    return config, {topic: sorted(rows, key=lambda row: row[0])
                    for topic, rows in messages.items()}


def _matrix(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _rotation_vector(q):
    q = -q if q[0] < 0.0 else q
    sine = np.linalg.norm(q[1:])
    return np.zeros(3) if sine == 0.0 else 2.0 * np.arctan2(sine, q[0]) * q[1:] / sine


def _held_value(x, y, t):
    """Evaluate a drawn zero-order-hold line (pairs of vertices per held value) at ``t``."""
    for k in range(0, len(x) - 1, 2):
        assert y[k] == y[k + 1]
        if x[k] <= t < x[k + 1]:
            return y[k]
    raise AssertionError(f'the held line does not cover t = {t} s')


def _expected(bag_dir, mesh_dir):
    """Return the panels' expected curves, from the independently decoded bag."""
    config, messages = _decode(bag_dir, mesh_dir)
    (odom,) = [rows for topic, rows in messages.items() if topic.endswith('odom')]
    t = np.array([stamp for stamp, _ in odom]) / 1e9
    p = np.array([[m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z]
                  for _, m in odom])
    o = [m.pose.pose.orientation for _, m in odom]
    q = np.array([[a.w, a.x, a.y, a.z] for a in o])
    v_b = np.array([[m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z]
                    for _, m in odom])
    w_b = np.array([[m.twist.twist.angular.x, m.twist.twist.angular.y,
                     m.twist.twist.angular.z] for _, m in odom])
    v_w = np.array([_matrix(qk / np.linalg.norm(qk)) @ vk for qk, vk in zip(q, v_b)])
    model = NodeConfig.from_parameters(recorded_parameters(config)).model
    kinetic = 0.5 * model.mass_kg * np.sum(v_b * v_b, axis=1) + 0.5 * np.einsum(
        'ni,ij,nj->n', w_b, model.inertia_b, w_b)
    panels = [
        {a: (t, p[:, k]) for k, a in enumerate('xyz')},
        {a: (t, np.array([_rotation_vector(qk)[k] for qk in q])) for k, a in enumerate('xyz')},
        {a: (t, v_w[:, k]) for k, a in enumerate('xyz')},
        {a: (t, w_b[:, k]) for k, a in enumerate('xyz')},
        None, None,   # wrenches: checked as held values below
        {'kinetic': (t, kinetic)},
        {'|L|': (t, np.linalg.norm(w_b @ model.inertia_b.T, axis=1))},
    ]
    if np.any(model.gravity_w != 0.0):
        panels[6]['kinetic + potential'] = (t, kinetic - model.mass_kg * p @ model.gravity_w)
    wrenches = {topic: rows for topic, rows in messages.items()  # applied: not contact_wrench
                if rows and hasattr(rows[0][1], 'wrench')
                and not topic.endswith('/contact_wrench')}
    return panels, wrenches, float(config.get('wrench_timeout_s', 0.0)), t[-1]


@pytest.fixture(scope='module', params=BAGS, ids=[b.name for b in BAGS])
def drawn(request, tmp_path_factory):
    """Plot a bag with the executable; return (bag, PNG pixels, panels drawn)."""
    bag = request.param
    out = tmp_path_factory.mktemp('plot') / f'{bag.name}.png'
    assert main([str(bag), '-o', str(out)]) == 0
    figure, panels = draw(str(bag))
    size_in = figure.get_size_inches()
    pyplot.close(figure)
    pixels = image.imread(str(out))          # a PNG matplotlib can read back, RGBA floats
    assert pixels.shape[:2] == (round(size_in[1] * SAVE_DPI), round(size_in[0] * SAVE_DPI))
    return bag, pixels, panels


def test_plot_writes_one_line_and_a_readable_figure(tmp_path, capsys):
    out = tmp_path / 'box.png'
    assert main([str(BAGS[0]), '-o', str(out)]) == 0
    assert capsys.readouterr().out.strip() == f'plot: wrote {out}'
    height, width = image.imread(str(out)).shape[:2]
    # 13 x 12 in at 90 dpi: 1170 x 1080 px; a readable 8-panel figure needs > 800 px each way.
    assert width > 800 and height > 800


def test_every_panel_shows_curves_or_says_why_not(drawn):
    _, pixels, panels = drawn
    assert len(panels) == 8
    height, width = pixels.shape[:2]
    for panel in panels:
        x0, y0, x1, y1 = panel['box']
        # The axes' inside, 3 px in from the frame (spines and ticks are black).
        area = pixels[round((1 - y1) * height) + 3:round((1 - y0) * height) - 3,
                      round(x0 * width) + 3:round(x1 * width) - 3, :3]
        # Curves are tab10 colours (channel spread ≥ 0.3 even antialiased at half coverage);
        # grid, text and frame are grey (spread 0).
        coloured = int(np.count_nonzero(area.max(axis=2) - area.min(axis=2) > 0.15))
        dark = int(np.count_nonzero(area.max(axis=2) < 0.4))
        if panel['lines']:
            # One curve across the panel is ≳ 500 px; a legend's handles alone are ≲ 150.
            assert coloured > 400, (panel['title'], coloured)
        else:
            assert panel['note'] and coloured == 0 and dark > 30, (panel['title'], dark)


def test_the_curves_are_the_recorded_values(drawn, tmp_path):
    bag, _, panels = drawn
    expected, wrenches, timeout_s, t_end = _expected(bag, tmp_path)
    for panel, want in zip(panels, expected):
        if want is None:
            continue
        assert set(panel['lines']) == set(want), panel['title']
        for label, (t, values) in want.items():
            x, y = panel['lines'][label]
            assert np.array_equal(x, t), (panel['title'], label)
            assert np.allclose(y, values, rtol=RTOL, atol=RTOL), (panel['title'], label)
    for panel, field in ((panels[4], 'force'), (panels[5], 'torque')):
        labels = {f'{topic} {a}' for topic in wrenches for a in 'xyz'}
        assert set(panel['lines']) == labels, panel['title']
        assert (panel['note'] is None) == bool(wrenches)
        for topic, rows in wrenches.items():
            times = [stamp / 1e9 for stamp, _ in rows] + [t_end]
            for k, (_, msg) in enumerate(rows):
                value = getattr(msg.wrench, field)
                end = times[k + 1]
                if timeout_s > 0:
                    end = min(end, times[k] + timeout_s)
                for a in 'xyz':
                    x, y = panel['lines'][f'{topic} {a}']
                    # Held from the step it took effect at until replaced or timed out.
                    for t in (times[k], 0.5 * (times[k] + end)):
                        if t < t_end:
                            assert _held_value(x, y, t) == getattr(value, a), (topic, k, t)
                    if end < times[k + 1]:
                        assert _held_value(x, y, end) == 0.0, (topic, k, 'after timeout')


def test_series_are_consistent_with_the_recording():
    bag = open_bag(str(BAGS[0]))
    data = load_series(bag)
    samples = bag.topics['/odom'].message_count
    assert data['t_s'].shape == (samples,)
    assert np.all(np.isfinite(data['position_w']))
    assert np.all(np.isfinite(data['velocity_w'])) and np.all(np.isfinite(data['omega_b']))
    # Unit quaternions out of odom, to round-off (|q|^2 - 1 ~ 1e-16 per normalisation).
    assert np.allclose(np.linalg.norm(data['orientation_wb'], axis=1), 1.0, atol=1e-12)
    assert data['model'] is not None


def test_plot_bad_input_one_line(tmp_path, capsys):
    noise = tmp_path / 'noise.mcap'
    noise.write_bytes(b'not an mcap file at all')
    assert main([str(noise), '-o', str(tmp_path / 'x.png')]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and 'not an MCAP file' in err
    assert not (tmp_path / 'x.png').exists()


def _cut_before_first_chunk(src, dst):
    """
    Copy bag ``src`` to ``dst`` cut 100 bytes into its first MCAP chunk (opcode 0x06).

    What SIGKILL leaves of a run killed before its first chunk closed: the header, schemas,
    channels and configuration record (written at start, outside the chunks), no sample.
    """
    data = next(src.glob('*.mcap')).read_bytes()
    pos = 8  # after the magic: records are opcode (1 byte), length (uint64 LE), content
    while data[pos] != 0x06:
        pos += 9 + int.from_bytes(data[pos + 1:pos + 9], 'little')
    dst.mkdir()
    (dst / 'cut_0.mcap').write_bytes(data[:pos + 100])
    return dst


@pytest.mark.parametrize('name', ['box_pushed', 'floor_world_push', 'robot_pendulum'])
def test_a_bag_without_samples_is_refused_in_one_line_not_drawn_empty(name, tmp_path, capsys):
    # One bag per drawing (a body, a world, a robot): each wrote a PNG of empty axes, exit 0.
    bag = _cut_before_first_chunk(REPO / 'bags' / name, tmp_path / name)
    out = tmp_path / 'x.png'
    assert main([str(bag), '-o', str(out)]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if 'error' in line]
    assert len(errors) == 1 and 'no recorded samples to plot on' in errors[0], errors
    assert not out.exists()


def _reset_copy(name, tmp_path, until_ns):
    """Return bag ``name`` followed by its own first ``until_ns`` again: a ~/reset, as written."""
    bag = open_bag(str(REPO / 'bags' / name))
    again = [(raw.topic, raw.data, raw.log_time_ns) for raw in bag.messages()
             if raw.log_time_ns <= until_ns]
    return rewrite_bag(str(REPO / 'bags' / name), str(tmp_path / name), extra=again)


def test_a_plot_after_a_reset_draws_the_last_run_and_says_so(tmp_path):
    # Samples keyed by sim time: the second run's 0.5 s were drawn in place of the first's,
    # then the first run's rest after them, as one run.
    until = 500_000_000
    world = open_bag(_reset_copy('floor_world_push', tmp_path, until))
    data = load_world(world)
    assert data['t_s'][-1] == until / 1e9 and len(data['t_s']) == 51  # 0.5 s at 100 Hz
    body = open_bag(_reset_copy('box_pushed', tmp_path, until))
    series = load_series(body)
    assert series['t_s'][-1] == until / 1e9
    fig, _ = draw(body)
    try:
        assert fig._suptitle.get_text().endswith('[the last of 2 runs: ~/reset]')
    finally:
        pyplot.close(fig)


def test_a_world_plot_shows_every_body_from_the_recorded_samples(tmp_path):
    bag = open_bag(str(Path(__file__).resolve().parents[2] / 'bags' / 'floor_world_push'))
    data = load_world(bag)
    assert data['names'] == ['pushed', 'slider', 'ball']
    assert len(data['t_s']) == 301
    # The ball launched at 1 m/s without spin ends rolling: v = 5/7 v0, ω = v / r, so its
    # kinetic energy is (1/2 m + 1/5 m) v² = 0.7 · (5/7)² J (round-off of the recorded twist).
    assert data['kinetic_j']['ball'][-1] == pytest.approx(0.7 * (5.0 / 7.0) ** 2, rel=1e-9)
    assert data['position_w']['slider'][-1, 0] == pytest.approx(0.40775, abs=1e-4)
    assert data['in_contact'][-1] == 3  # all three rest on the floor
    out = render(bag, str(tmp_path / 'world.png'))
    assert Path(out).stat().st_size > 10_000


def test_plot_animates_a_world_bag_from_its_recorded_poses(tmp_path, capsys):
    from PIL import Image
    bag = Path(__file__).resolve().parents[2] / 'bags' / 'floor_world_push'
    gif = tmp_path / 'world.gif'
    assert main([str(bag), '-o', str(tmp_path / 'world.png'), '--animate', str(gif)]) == 0
    # 301 samples at 100 Hz, every 5th for 20 frames per sim second: 61 frames.
    assert capsys.readouterr().out.strip().endswith(f'{gif} (61 frames)')
    with Image.open(gif) as image:
        assert image.n_frames == 61 and image.size == (640, 480)
        first = np.asarray(image.convert('RGB')).copy()
        image.seek(20)  # t = 1 s: the pushed box has moved
        assert not np.array_equal(first, np.asarray(image.convert('RGB')))


def _joint_messages(bag_dir, prefix):
    """
    Return ``({log time: joint_states}, {log time: joint_wrenches})`` of ``<prefix>joint_*``.

    The recorded values, decoded with mcap_ros2 (not rbd_ros's reader).
    """
    states, forces = {}, {}
    with open(next(bag_dir.glob('*.mcap')), 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, msg in reader.iter_decoded_messages():
            if channel.topic == prefix + 'joint_states':
                states[message.log_time] = msg
            elif channel.topic == prefix + 'joint_wrenches':
                forces[message.log_time] = msg
    return states, forces


def test_a_robot_plot_draws_every_joint_from_the_recorded_samples(tmp_path, capsys):
    from sim_recorder import record_scripted_run
    bag = tmp_path / 'arm'
    record_scripted_run(bag, {
        'robot_names': ['arm'], 'robots.arm.urdf_path': str(REPO / 'msg_config' / 'urdf' /
                                                            'arm3.urdf'),
        'robots.arm.initial_joint_positions': [0.4, -0.7, 1.1], 'gravity': [0.0, 0.0, -9.81],
        'publish_rate_hz': 100.0}, [], 500_000_000)
    out = tmp_path / 'arm.png'
    assert main([str(bag), '-o', str(out)]) == 0
    assert capsys.readouterr().out.strip() == f'plot: wrote {out}'
    assert image.imread(str(out)).shape[0] > 600
    states, forces = _joint_messages(bag, '/arm/')
    assert len(states) == len(forces) == 51
    figure, panels = draw_robots(open_bag(str(bag)))
    pyplot.close(figure)
    titles = [p['title'].split(' ')[1] for p in panels[:3]]
    assert titles == ['positions', 'velocities', 'efforts']
    times = sorted(states)
    t = np.array(times) / 1e9
    joints = ['shoulder', 'elbow', 'wrist']
    for panel, field in zip(panels, ('position', 'velocity', 'effort')):
        assert set(panel['lines']) == {f'arm/{j}' for j in joints}, panel['title']
        for k, joint in enumerate(joints):
            x, y = panel['lines'][f'arm/{joint}']
            assert np.array_equal(x, t)
            want = [getattr(states[s], field)[states[s].name.index(joint)] for s in times]
            assert np.array_equal(y, want), (panel['title'], joint)
    # The arm swings: positions and velocities change; no motor: efforts are 0.
    assert np.ptp(panels[0]['lines']['arm/elbow'][1]) > 0.1
    assert not np.any(panels[2]['lines']['arm/elbow'][1])
    # Force magnitudes of every joint: the fixed one inside the world carries what the
    # shoulder does, the one to the tool0 frame nothing.
    every = ['mount_joint', *joints, 'tool_joint']
    assert set(panels[3]['lines']) == {f'arm/{j}' for j in every}
    assert not np.any(panels[3]['lines']['arm/tool_joint'][1][1:])
    for joint in ['mount_joint', *joints]:
        x, y = panels[3]['lines'][f'arm/{joint}']
        assert np.array_equal(x, np.array(sorted(forces)) / 1e9)
        want = []
        for s in sorted(forces):
            w = forces[s].wrench[forces[s].joint_names.index(joint)].force
            want.append(np.linalg.norm([w.x, w.y, w.z]))
        assert np.allclose(y, want, rtol=RTOL, atol=0, equal_nan=True), joint
        assert np.isnan(y[0]) and np.all(y[1:] > 1.0)  # t = 0: not yet computed


def test_the_robot_reference_bag_plots_its_swing(tmp_path):
    bag = open_bag(str(REPO / 'bags' / 'robot_pendulum'))
    figure, panels = draw_robots(bag)
    pyplot.close(figure)
    t, angle = panels[0]['lines']['pendulum/pivot']
    # Let go at 0.5 rad (msg_config/robot_pendulum.yaml), read back from the placed link to
    # 1e-12 (doc/robots.md: placement and readout agree to that; 1 ulp here).
    assert len(t) == 451 and abs(angle[0] - 0.5) <= 1e-12
    assert angle.min() < -0.49                 # and swung through to the other side
    assert set(panels[3]['lines']) == {'pendulum/pivot'}
    out = render(bag, str(tmp_path / 'pendulum.png'))
    assert Path(out).stat().st_size > 10_000


def test_a_world_plot_draws_its_joints_as_a_robots(tmp_path, capsys):
    # The door bag (a world with joint_names): the world's four panels, then its joints'
    # positions, velocities, efforts and force magnitudes as a robot's, each curve the recorded
    # values (decoded here with mcap_ros2), labelled by joint name.
    bag_dir = REPO / 'bags' / 'door_world'
    states, forces = _joint_messages(bag_dir, '/')
    assert len(states) == len(forces) == 301
    figure, data = draw_world(open_bag(str(bag_dir)))
    pyplot.close(figure)
    panels = data['panels']
    assert len(panels) == 8 and data['names'] == ['door']
    assert [p['title'].split(' (')[0] for p in panels[4:7]] == [
        'joint positions', 'joint velocities', 'joint efforts']
    assert [p['note'] for p in panels] == [None] * 8
    t = np.array(sorted(states)) / 1e9
    for panel, field in zip(panels[4:7], ('position', 'velocity', 'effort')):
        (x, y), = panel['lines'].values()
        assert list(panel['lines']) == ['hinge'] and np.array_equal(x, t)
        assert np.array_equal(y, [getattr(states[s], field)[0] for s in sorted(states)])
    assert panels[4]['lines']['hinge'][1][-1] == pytest.approx(-np.pi / 2, abs=1e-12)  # shut
    x, y = panels[7]['lines']['hinge']
    want = [np.linalg.norm([w.x, w.y, w.z]) for w in
            (forces[s].wrench[0].force for s in sorted(forces))]
    assert np.array_equal(x, np.array(sorted(forces)) / 1e9)
    assert np.allclose(y, want, rtol=RTOL, atol=0, equal_nan=True)
    # it carries the door's weight, m g = 196.2 N (on the post, whose friction takes 0.3 N of
    # it, a little less)
    assert np.isnan(y[0]) and np.all(y[1:] > 195.0)
    out = tmp_path / 'door.png'
    assert main([str(bag_dir), '-o', str(out)]) == 0
    assert capsys.readouterr().out.strip() == f'plot: wrote {out}'
    assert image.imread(str(out)).shape[0] > 1000  # eight panels: twice the world's height
