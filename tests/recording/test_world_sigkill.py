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
A world's recording cut off by SIGKILL (issue 30, item 4): its finalised prefix replays and plots.

The node runs ``msg_config/stack.yaml`` (three stacked boxes and a striker sent at them) as a
user starts it, recording; once 1.5 s of sim time are in the file it is killed with SIGKILL
(no handler runs: no summary, no ``metadata.yaml``, no ``rbd_ros.run`` record). ``replay``
must match the prefix bit for bit and ``plot`` draw it, both saying it was not finalised, as
for a single body (``test_node_recording.py``).
"""

from pathlib import Path
import signal

from conftest import REPO, wait_until
import numpy as np
from rbd_ros.bag import plot, replay
from rbd_ros.bag.reader import open_bag
from rbd_ros.bag.replay import config_from_bag

S = 1_000_000_000
STACK = REPO / 'msg_config' / 'stack.yaml'
STRIKER_V = 3.0  # m/s along +x: it slides ~0.6 m and hits the stack within the first 0.3 s
G = 9.81  # m/s², the stack's gravity


def _recorded_until(path, t_ns):
    """Return True once the live recording at ``path`` holds a message at or after t_ns."""
    if not Path(path).is_dir() or not list(Path(path).glob('*.mcap')):
        return False
    try:
        bag = open_bag(str(path))
    except Exception:  # noqa: B902 - the file may not even have its header yet
        return False
    return bag.end_ns is not None and bag.end_ns >= t_ns


def test_a_sigkilled_world_replays_and_plots_its_prefix(start_node, tmp_path, capsys):
    bag_path = tmp_path / 'killed_world'
    proc = start_node({'record_path': str(bag_path), 'real_time_factor': 1.0,
                       'duration_s': 60.0,
                       'bodies.striker.initial_linear_velocity': [STRIKER_V, 0.0, 0.0]},
                      params_file=STACK)
    wait_until(lambda: _recorded_until(bag_path, 3 * S // 2), 300.0, what='1.5 s recorded')
    proc.stop(signal.SIGKILL)
    assert not (bag_path / 'metadata.yaml').exists()
    bag = open_bag(str(bag_path))
    assert not bag.finalised and bag.run_metadata is None
    assert bag.end_ns >= 3 * S // 2  # chunks are flushed as they close (< 1 s of sim each)

    assert replay.main([str(bag_path), '--no-progress']) == 0
    out, err = capsys.readouterr()
    assert 'not finalised' in err
    assert out.strip().endswith('MATCH')
    assert '/striker/pose' in out and '/top/pose' in out  # every body's samples compared

    png = tmp_path / 'killed_world.png'
    assert plot.main([str(bag_path), '-o', str(png)]) == 0
    out, err = capsys.readouterr()
    assert 'not finalised' in err and png.stat().st_size > 0
    fig, data = plot.draw_world(open_bag(str(bag_path)))
    assert fig._suptitle.get_text().endswith('[not finalised]')
    # The prefix: every sample up to the cut, 100 Hz from t = 0.
    assert data['t_s'][0] == 0.0 and data['t_s'][-1] >= 1.5
    np.testing.assert_allclose(np.diff(data['t_s']), 0.01, rtol=0, atol=1e-12)  # ns -> s
    # The striker hit the stack: the bottom box, at rest at x = 0 until then, moved along +x.
    assert data['position_w']['bottom'][-1, 0] > 1e-3
    # Friction and inelastic contact only take energy: kinetic + potential never rises above
    # its start by more than the allowed overlap (1 mm) times the world's weight, m g 1e-3.
    config = config_from_bag(open_bag(str(bag_path)))
    masses = {body.name: body.model.mass_kg for body in config.bodies}
    energy = sum(data['kinetic_j'][n] + masses[n] * G * data['position_w'][n][:, 2]
                 for n in data['names'])
    allowed = sum(masses.values()) * G * 1e-3
    print(f'energy: start {energy[0]:.4f} J, highest rise {np.max(energy - energy[0]):.2e} J '
          f'(allowed {allowed:.3f} J), end {energy[-1]:.4f} J')
    assert np.max(energy - energy[0]) <= allowed
    assert energy[-1] < energy[0]
