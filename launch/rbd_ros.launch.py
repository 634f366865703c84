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
Start rigid_body_node, and RViz on request: ``ros2 launch rbd_ros rbd_ros.launch.py``.

Arguments (``name:=value``):

- ``params_file``: the node's parameter file (default: the installed msg_config/default.yaml).
- ``namespace``: namespace of the node and of RViz (default: none); relative topics follow it.
- ``record_path``: record the run to this MCAP path (default: '' = the params file's value).
- ``use_sim_time``: ``true`` or ``false`` (default ``false``), given to the node and RViz.
- ``rviz``: ``true`` also starts rviz2 with the installed rviz/rbd_ros.rviz (default ``false``).
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PACKAGE = 'rbd_ros'


def _flag(context, name):
    """Return launch argument ``name`` as a bool; anything but true/false is a one-line error."""
    value = LaunchConfiguration(name).perform(context)
    if value.strip().lower() not in ('true', 'false'):
        raise ValueError(f'launch argument {name}: {value!r} is not true or false')
    return value.strip().lower() == 'true'


def _actions(context):
    """Return the node (and RViz) for the values the arguments have in ``context``."""
    share = get_package_share_directory(PACKAGE)
    namespace = LaunchConfiguration('namespace').perform(context)
    use_sim_time = _flag(context, 'use_sim_time')
    overrides = {'use_sim_time': use_sim_time}
    # record_path is a node parameter ('' = off); an empty argument leaves the params file's.
    record_path = LaunchConfiguration('record_path').perform(context)
    if record_path:
        overrides['record_path'] = record_path
    actions = [Node(package=PACKAGE, executable='rigid_body_node', namespace=namespace,
                    parameters=[LaunchConfiguration('params_file').perform(context), overrides],
                    output='screen')]
    if _flag(context, 'rviz'):
        actions.append(Node(package='rviz2', executable='rviz2', namespace=namespace,
                            arguments=['-d', os.path.join(share, 'rviz', 'rbd_ros.rviz')],
                            parameters=[{'use_sim_time': use_sim_time}], output='screen'))
    return actions


def generate_launch_description():
    """Declare the arguments; the node and RViz are made once their values are known."""
    share = get_package_share_directory(PACKAGE)
    return LaunchDescription([
        DeclareLaunchArgument(
            'params_file', default_value=os.path.join(share, 'msg_config', 'default.yaml'),
            description='Parameter file of rigid_body_node (YAML, /** or rigid_body_node key).'),
        DeclareLaunchArgument('namespace', default_value='',
                              description='Namespace of the node and of RViz.'),
        DeclareLaunchArgument(
            'record_path', default_value='',
            description="Record the run to this MCAP path; '' keeps the params file's value."),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='use_sim_time of the node and RViz (true or false).'),
        DeclareLaunchArgument('rviz', default_value='false',
                              description='true: also start rviz2 with rviz/rbd_ros.rviz.'),
        OpaqueFunction(function=_actions),
    ])
