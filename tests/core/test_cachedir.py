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
The one cache-folder rule (:mod:`rbd_ros.core.cachedir`) and its three users.

Real folders under a temporary ``XDG_CACHE_HOME``; each refusal is checked by what a user
sees (the reason, and that nothing is created below a refused folder), and each user (numba's
cache, the SDF cache, replay's mesh copies) is checked to follow the same rule.
"""

import os
from pathlib import Path
import stat

import pytest
from rbd_ros.core import cachedir, jitcache
from rbd_ros.core.contact import mesh_shapes


def _mode(path):
    return stat.S_IMODE(os.stat(path).st_mode)


def test_the_folder_follows_xdg_and_ignores_a_relative_value(tmp_path):
    assert cachedir.base_dir({'XDG_CACHE_HOME': str(tmp_path)}) == str(tmp_path / 'rbd_ros')
    home = os.path.join(os.path.expanduser('~'), '.cache', 'rbd_ros')
    assert cachedir.base_dir({'XDG_CACHE_HOME': 'relative/cache'}) == home
    assert cachedir.base_dir({}) == home


def test_a_new_cache_folder_is_private(tmp_path):
    folder, problem = cachedir.private_dir('things', {'XDG_CACHE_HOME': str(tmp_path)})
    assert problem is None
    assert folder == str(tmp_path / 'rbd_ros' / 'things')
    assert _mode(tmp_path / 'rbd_ros') == 0o700 and _mode(folder) == 0o700


def test_a_folder_of_ours_readable_by_others_is_tightened(tmp_path):
    (tmp_path / 'rbd_ros').mkdir(mode=0o755)
    os.chmod(tmp_path / 'rbd_ros', 0o755)
    folder, problem = cachedir.private_dir('things', {'XDG_CACHE_HOME': str(tmp_path)})
    assert problem is None
    assert _mode(tmp_path / 'rbd_ros') == 0o700


@pytest.mark.parametrize('mode', [0o775, 0o757])
def test_a_folder_others_can_write_is_refused_and_nothing_is_made_below(tmp_path, mode):
    base = tmp_path / 'rbd_ros'
    base.mkdir()
    os.chmod(base, mode)
    folder, problem = cachedir.private_dir('things', {'XDG_CACHE_HOME': str(tmp_path)})
    assert problem == (f'cache directory {base}: writable by group or others '
                       f'(mode {mode:04o})'), problem
    assert not os.path.exists(folder)
    assert _mode(base) == mode  # refused, not repaired: something may be in it already


def test_a_folder_of_another_user_is_refused(tmp_path):
    if os.getuid() == 0:  # root can give a folder away
        folder, owner = tmp_path / 'theirs', 4242
        folder.mkdir(mode=0o700)
        os.chown(folder, owner, -1)
    else:  # any other user sees root's folders
        folder, owner = Path('/'), 0
    refused = cachedir.make_private((str(folder),))
    assert refused == (str(folder), f'owned by uid {owner}, not by this user (uid {os.getuid()})')


def test_a_file_where_the_folder_should_be_is_refused(tmp_path):
    (tmp_path / 'rbd_ros').write_text('not a folder')
    _, problem = cachedir.private_dir('things', {'XDG_CACHE_HOME': str(tmp_path)})
    assert problem.startswith(f'cache directory {tmp_path / "rbd_ros"}: '), problem


def test_numba_and_the_sdf_cache_sit_in_the_same_folder_by_the_same_rule(tmp_path, monkeypatch):
    environ = {'XDG_CACHE_HOME': str(tmp_path)}
    assert jitcache.default_dir(environ) == os.path.join(cachedir.base_dir(environ), 'numba')
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path))
    assert str(mesh_shapes.sdf_cache_dir()) == os.path.join(cachedir.base_dir(), 'sdf')
    assert jitcache.unsafe_reason is cachedir.unsafe_reason
