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
The node's endpoints: the QoS of each topic, ``qos_overrides`` checked, input topics checked.

pose, twist and odom: reliable, transient local, keep last 1: a subscriber that arrives while
the node is paused (``ros2 topic echo pose --once``) gets the latest sample. The other topics:
depth 10, reliable, volatile (rclpy's default). Every endpoint takes
``qos_overrides.<topic>.<kind>.<policy>``; a bad value is one line naming it.
"""

import re

from rbd_ros.core import ConfigError
from rbd_ros.msgs import outputs
from rbd_ros.sim import params as sim_params
from rbd_ros.sim.drag import CLICKED_POINT
from rclpy.exceptions import NameValidationException, ParameterException
from rclpy.qos import DurabilityPolicy, QoSPolicyKind, QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import QoSOverridingOptions

STATE_QOS = {'depth': 1, 'reliability': ReliabilityPolicy.RELIABLE,
             'durability': DurabilityPolicy.TRANSIENT_LOCAL}
QOS_OVERRIDES = QoSOverridingOptions(policy_kinds=(
    QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY,
    QoSPolicyKind.DURABILITY))
#: The topics the node publishes besides each body's sample topics (pose, twist, odom, poses).
OTHER_OUTPUT_TOPICS = ('markers', 'static_markers', '/clock', '/diagnostics', '/tf')
#: Every output topic of a single-body node (a world's are under each body's prefix).
OUTPUT_TOPICS = ('pose', 'twist', 'odom', 'contact_wrench') + OTHER_OUTPUT_TOPICS


def rcl_text(exc):
    """Return an rcl error message without its source locations (``, at file.c:123``)."""
    text = re.sub(r', at [^,]*:\d+', '', str(exc)).strip()
    return re.sub(r'^failed to (initialize rcl|resolve name): ', '', text)


def qos_checked(node, overrides, topic, kind, create, *args, **kwargs):
    """
    Create an endpoint with ``create(*args, **kwargs)``.

    :param overrides: the node's parameter overrides (name -> value).
    :param kind: 'publisher' or 'subscription'.
    :raises ConfigError: a bad ``qos_overrides.<topic>.<kind>.*`` value, named.
    """
    prefix = f'qos_overrides.{node.resolve_topic_name(topic)}.{kind}.'
    depth = overrides.get(prefix + 'depth')
    if isinstance(depth, int) and depth < 0:
        raise ConfigError(f'parameter {prefix}depth = {depth}: must be >= 0')
    try:
        return create(*args, **kwargs)
    except (RuntimeError, ParameterException) as exc:  # rclpy's RCLError among them
        given = {name[len(prefix):]: value for name, value in overrides.items()
                 if name.startswith(prefix)}
        raise ConfigError(f'parameters {prefix}* = {given}: {rcl_text(exc)}') from None


def publisher(node, overrides, msg_type, topic, qos):
    """Create a publisher; ``qos`` a profile dict (a profile of its own) or a depth."""
    # A profile of its own for each publisher: rclpy writes the overrides into it.
    qos = QoSProfile(**qos) if isinstance(qos, dict) else qos
    return qos_checked(node, overrides, topic, 'publisher', node.create_publisher, msg_type,
                       topic, qos, qos_overriding_options=QOS_OVERRIDES)


def subscription(node, overrides, msg_type, topic, callback):
    """Create a subscription of depth 10 that takes ``qos_overrides``."""
    return qos_checked(node, overrides, topic, 'subscription', node.create_subscription,
                       msg_type, topic, callback, 10, qos_overriding_options=QOS_OVERRIDES)


def output_topics(config):
    """Every topic an output of ``config`` may use (contact_wrench even without contact)."""
    kinds = outputs.SampleBuilder(config, tf=False).kinds
    return ([outputs.topic_of(kind) for kind in kinds]
            + [f'{b.prefix}contact_wrench' for b in config.bodies] + list(OTHER_OUTPUT_TOPICS))


def check_input_topics(node, config):
    """Refuse an invalid input topic or one that resolves to an output or another input."""
    taken = {node.resolve_topic_name(topic) for topic in output_topics(config)}
    names = [f'{b.prefix}drag' for b in config.bodies]
    drags = {node.resolve_topic_name(name): name for name in names}
    drags['/clicked_point'] = CLICKED_POINT
    seen = {}
    for spec in config.wrench_inputs:
        body, _, name = spec.name.rpartition('/')
        field = f'bodies.{body}.wrench_inputs.{name}' if body else f'wrench_inputs.{name}'
        what = f'topic {spec.topic!r} of the main wrench input' if name == \
            sim_params.MAIN_INPUT else f'parameter {field}.topic = {spec.topic!r}'
        try:
            resolved = node.resolve_topic_name(spec.topic)
        except (RuntimeError, NameValidationException) as exc:  # rclpy raises RCLError
            raise ConfigError(f'{what}: not a valid topic name ({rcl_text(exc)})') from None
        if resolved in taken:
            raise ConfigError(f'{what}: resolves to {resolved}, an output of this node')
        if resolved in drags:
            raise ConfigError(f'{what}: resolves to {resolved}, the drag input '
                              f'{drags[resolved]!r} (PointStamped, not WrenchStamped)')
        if resolved in seen:
            raise ConfigError(f'{what}: resolves to {resolved}, the topic of wrench input '
                              f'{seen[resolved]!r} (it would count every wrench twice)')
        seen[resolved] = spec.name
