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

"""The ``plot`` executable renders committed reference bags to valid PNGs."""

from pathlib import Path
import struct

import numpy as np
import pytest
from rbd_ros.plot import load_series, main
from rbd_ros.recording import open_bag

REPO = Path(__file__).resolve().parents[2]
BAGS = sorted(p for p in (REPO / 'bags').iterdir() if (p / 'metadata.yaml').is_file())
PNG_MAGIC = b'\x89PNG\r\n\x1a\n'


def test_there_are_reference_bags():
    assert len(BAGS) >= 3, BAGS


@pytest.mark.parametrize('bag', BAGS, ids=[b.name for b in BAGS])
def test_plot_renders_a_committed_bag(bag, tmp_path, capsys):
    out = tmp_path / f'{bag.name}.png'
    assert main([str(bag), '-o', str(out)]) == 0
    assert f'wrote {out}' in capsys.readouterr().out
    data = out.read_bytes()
    assert data[:8] == PNG_MAGIC
    width, height = struct.unpack('>II', data[16:24])  # IHDR: the first chunk
    # 13 x 12 in at 90 dpi: 1170 x 1080 px; a readable 8-panel figure needs > 800 px each way.
    assert width > 800 and height > 800
    # Eight panels of curves are tens of kB; an empty or blank figure is a few kB.
    assert 30_000 < len(data) < 2_000_000


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
