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
The node's participant does not match its own endpoints (rbd_ros.ros.participant).

That is what made a world with per-body topics start in time quadratic in its bodies (Fast DDS
matched every reader against every writer of the participant); the start-up figures are
``tests/benchmarks/bench_world_start.py``'s. Here, through real Fast DDS in a process of its
own (``own_endpoints.py``): with the profile a node does not hear its own publisher while
another participant does; without it, it does; a user's own profile is left alone.
"""

import os
import pathlib
import subprocess
import sys
import xml.etree.ElementTree as ElementTree

import pytest
from rbd_ros.ros import participant

SCRIPT = pathlib.Path(__file__).with_name('own_endpoints.py')


def _heard(mode):
    out = subprocess.run([sys.executable, str(SCRIPT), mode], capture_output=True, text=True,
                         timeout=120, env=dict(os.environ))
    assert out.returncode == 0, out.stderr
    words = out.stdout.split()
    return int(words[1]), int(words[3])


def test_with_the_profile_a_node_does_not_match_its_own_endpoints():
    own, other = _heard('profile')
    assert own == 0 and other >= 5, (own, other)


def test_without_it_fast_dds_matches_them():
    # The control: the same script with a plain participant hears itself, so 'own 0' above is
    # the profile's doing, not a publisher that never matched.
    own, other = _heard('plain')
    assert own >= 5 and other >= 5, (own, other)


@pytest.mark.parametrize('environ, applies', [
    ({}, True),
    ({'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp'}, True),
    ({'RMW_IMPLEMENTATION': 'rmw_fastrtps_dynamic_cpp'}, True),
    ({'RMW_IMPLEMENTATION': ''}, True),
    ({'RMW_IMPLEMENTATION': 'rmw_cyclonedds_cpp'}, False),
    ({'FASTRTPS_DEFAULT_PROFILES_FILE': '/etc/mine.xml'}, False),
    ({'FASTDDS_DEFAULT_PROFILES_FILE': '/etc/mine.xml'}, False),
])
def test_it_applies_to_fast_dds_without_a_profile_of_the_users(environ, applies):
    assert participant.applies(environ) is applies


def test_the_profile_is_set_while_the_node_is_built_then_removed(monkeypatch):
    for name in participant.PROFILE_VARIABLES + ('RMW_IMPLEMENTATION',):
        monkeypatch.delenv(name, raising=False)
    with participant.node_profile() as applied:
        assert applied
        path = os.environ['FASTRTPS_DEFAULT_PROFILES_FILE']
        root = ElementTree.parse(path).getroot()
        ns = {'p': 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'}
        (profile,) = root.findall('p:participant', ns)
        assert profile.get('is_default_profile') == 'true'
        props = {p.findtext('p:name', namespaces=ns): p.findtext('p:value', namespaces=ns)
                 for p in profile.iterfind('.//p:property', ns)}
        assert props == {'fastdds.ignore_local_endpoints': 'true'}
    assert 'FASTRTPS_DEFAULT_PROFILES_FILE' not in os.environ
    assert not os.path.exists(path)
    # A user's profile: left as it is.
    monkeypatch.setenv('FASTRTPS_DEFAULT_PROFILES_FILE', '/etc/mine.xml')
    with participant.node_profile() as applied:
        assert not applied
        assert os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'] == '/etc/mine.xml'
    assert os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'] == '/etc/mine.xml'
