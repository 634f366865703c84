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
The ROS type names of every message rbd_ros publishes, takes or records: the one table.

Plain strings (no message package is imported), so the recording and schema modules can use
them too. :func:`type_name` gives the name of a message class from the same table.
"""

POSE_STAMPED = 'geometry_msgs/msg/PoseStamped'
POSE_ARRAY = 'geometry_msgs/msg/PoseArray'
TWIST_STAMPED = 'geometry_msgs/msg/TwistStamped'
WRENCH_STAMPED = 'geometry_msgs/msg/WrenchStamped'
POINT_STAMPED = 'geometry_msgs/msg/PointStamped'
ODOMETRY = 'nav_msgs/msg/Odometry'
CLOCK = 'rosgraph_msgs/msg/Clock'
TF_MESSAGE = 'tf2_msgs/msg/TFMessage'
DIAGNOSTIC_ARRAY = 'diagnostic_msgs/msg/DiagnosticArray'
MARKER_ARRAY = 'visualization_msgs/msg/MarkerArray'
JOINT_STATE = 'sensor_msgs/msg/JointState'
MULTI_DOF_JOINT_STATE = 'sensor_msgs/msg/MultiDOFJointState'
FLOAT64_MULTI_ARRAY = 'std_msgs/msg/Float64MultiArray'
JOINT_TRAJECTORY = 'trajectory_msgs/msg/JointTrajectory'
STRING = 'std_msgs/msg/String'
#: Every type name above.
TYPE_NAMES = (POSE_STAMPED, POSE_ARRAY, TWIST_STAMPED, WRENCH_STAMPED, POINT_STAMPED, ODOMETRY,
              CLOCK, TF_MESSAGE, DIAGNOSTIC_ARRAY, MARKER_ARRAY, JOINT_STATE,
              MULTI_DOF_JOINT_STATE, FLOAT64_MULTI_ARRAY, JOINT_TRAJECTORY, STRING)
# (package, class name) -> type name: a generated class lives in module <package>.msg._<name>.
_BY_CLASS = {(name.split('/')[0], name.rsplit('/', 1)[1]): name for name in TYPE_NAMES}


def type_name(msg_class):
    """
    Return the type name of a message class of the table (``PoseStamped`` -> its name).

    :raises ValueError: not a message type of the table.
    """
    key = (msg_class.__module__.split('.')[0], msg_class.__name__)
    try:
        return _BY_CLASS[key]
    except KeyError:
        raise ValueError(f'message type {key[0]}/{key[1]}: not one that rbd_ros '
                         f'publishes or records ({", ".join(TYPE_NAMES)})') from None
