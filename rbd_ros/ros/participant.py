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
The node's DDS participant: Fast DDS told not to match the node's own endpoints with each other.

Fast DDS matches every reader a participant creates against every writer it already has (and
each writer against its readers), about 2 µs a pair on this machine, so a world with its own
topics per body (four publishers and two subscriptions a body) paid ``8 N x 2 N`` pairs: 64 s
of its start-up at 2,000 bodies, growing as N². The node never subscribes to what it
publishes, so its participant sets Fast DDS's ``fastdds.ignore_local_endpoints``: creating an
endpoint no longer looks at the others (2,000 subscriptions after 4,000 publishers: 7.7 → 0.66
ms each). Other participants (RViz, ``ros2 topic``, another node in this process's other
contexts) match the node's endpoints as before.

The property is given through a default participant profile, the way Fast DDS takes one: an
XML file named by ``FASTRTPS_DEFAULT_PROFILES_FILE`` while the node is built (rmw_fastrtps
creates the participant with a context's first node, not in ``rclpy.init``), then removed.
Fast DDS reads profiles once a process, at its first participant, so the node's is the first.
A user's own profile (that variable or ``FASTDDS_DEFAULT_PROFILES_FILE`` set) or another RMW
(``RMW_IMPLEMENTATION``) is left alone: the node works the same, its start-up as before.
"""

import contextlib
import os
import tempfile

#: The environment variables naming a Fast DDS profiles file (2.x reads the first).
PROFILE_VARIABLES = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')
#: The RMW implementations that are Fast DDS (the default when RMW_IMPLEMENTATION is unset).
FAST_DDS_RMWS = ('rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp')
#: The profile: the default participant, with local endpoints not matched.
PROFILE_XML = """<?xml version="1.0" encoding="UTF-8" ?>
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <participant profile_name="rbd_ros_node" is_default_profile="true">
    <rtps>
      <propertiesPolicy>
        <properties>
          <property>
            <name>fastdds.ignore_local_endpoints</name>
            <value>true</value>
          </property>
        </properties>
      </propertiesPolicy>
    </rtps>
  </participant>
</profiles>
"""


def applies(environ=None):
    """Return True if the node's participant gets :data:`PROFILE_XML` (see the module)."""
    environ = os.environ if environ is None else environ
    rmw = environ.get('RMW_IMPLEMENTATION') or FAST_DDS_RMWS[0]
    return rmw in FAST_DDS_RMWS and not any(environ.get(name) for name in PROFILE_VARIABLES)


@contextlib.contextmanager
def node_profile():
    """Within this block, a participant created gets the node's profile (if it applies)."""
    if not applies():
        yield False
        return
    with tempfile.TemporaryDirectory(prefix='rbd_ros_dds_') as folder:
        path = os.path.join(folder, 'participant.xml')
        with open(path, 'w') as f:
            f.write(PROFILE_XML)
        os.environ[PROFILE_VARIABLES[0]] = path
        try:
            yield True
        finally:
            del os.environ[PROFILE_VARIABLES[0]]
