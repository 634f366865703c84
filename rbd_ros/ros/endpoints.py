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
``qos_overrides.<topic>.<kind>.<policy>``; a bad value is one line naming it. Every topic and
service name is resolved before any endpoint is created (:func:`check_names`), so a name past
rcl's limit is one line naming the parameter that made it, not an rcl traceback.
"""

import re

from rbd_ros.core import ConfigError
from rbd_ros.msgs import outputs
from rbd_ros.sim import params as sim_params
from rbd_ros.sim.drag import CLICKED_POINT
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.exceptions import (NameValidationException, ParameterException,
                              ParameterUninitializedException)
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
#: The node's own services (``~/reset``, ...), relative to its name.
SERVICES = ('~/reset', '~/pause', '~/step')
#: rcl's longest resolved topic or service name, characters: RMW_TOPIC_MAX_NAME_LENGTH, 255
#: minus 8 for the prefix DDS adds (``rt/``, ``rq/``, ``rr/`` and the request/reply suffixes).
TOPIC_NAME_MAX_CHARS = 255 - 8


# The type of each qos_overrides policy the node takes, and the values of the string ones.
_POLICY_TYPES = {'history': str, 'depth': int, 'reliability': str, 'durability': str}
_POLICY_VALUES = {'history': ('keep_last', 'keep_all', 'system_default'),
                  'reliability': ('reliable', 'best_effort', 'system_default'),
                  'durability': ('volatile', 'transient_local', 'system_default')}


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
    _check_policy_types(prefix, overrides)
    depth = overrides.get(prefix + 'depth')
    if isinstance(depth, int) and depth < 0:
        raise ConfigError(f'parameter {prefix}depth = {depth}: must be >= 0')
    try:
        return create(*args, **kwargs)
    except (RuntimeError, ParameterException, AssertionError, AttributeError) as exc:
        # rclpy's RCLError among them; an assert or attribute error: a value of no type (an
        # empty YAML mapping) that rclpy declared without reading it as we do, so check what
        # it declared.
        _check_policy_types(prefix, {prefix + policy: _declared(node, prefix + policy)
                                     for policy in _POLICY_TYPES
                                     if node.has_parameter(prefix + policy)})
        given = {name[len(prefix):]: value for name, value in overrides.items()
                 if name.startswith(prefix)}
        raise ConfigError(f'parameters {prefix}* = {given}: {rcl_text(exc)}') from None


def _declared(node, name):
    """Return the value of the declared parameter ``name``; None if it has none."""
    try:
        return node.get_parameter(name).value
    except ParameterUninitializedException:
        return None


def _check_policy_types(prefix, values):
    """Refuse a ``<prefix><policy>`` value of the wrong type (or none), naming it."""
    for policy, want in _POLICY_TYPES.items():
        if prefix + policy not in values:
            continue
        value = values[prefix + policy]
        if isinstance(value, bool) or not isinstance(value, want):
            given = (' has no value (an empty {} or [] in a params file sets none)'
                     if value in (None, [], {}, ()) else
                     f' = {sim_params.fmt(value)}: a {type(value).__name__}')
            rule = ('an integer >= 0 (messages kept)' if want is int else
                    f'a string: {" | ".join(_POLICY_VALUES[policy])}')
            raise ConfigError(f'parameter {prefix}{policy}{given}; it must be {rule}')


def publisher(node, overrides, msg_type, topic, qos, light=False):
    """
    Create a publisher; ``qos`` a profile dict (a profile of its own) or a depth.

    :param light: a per-body endpoint of a world (:func:`light_options`).
    """
    # A profile of its own for each publisher: rclpy writes the overrides into it.
    qos = QoSProfile(**qos) if isinstance(qos, dict) else qos
    options, events = light_options(node, overrides, topic, 'publisher', light)
    return qos_checked(node, overrides, topic, 'publisher', node.create_publisher, msg_type,
                       topic, qos, qos_overriding_options=options,
                       event_callbacks=PublisherEventCallbacks(use_default_callbacks=False)
                       if events else None)


def subscription(node, overrides, msg_type, topic, callback, light=False):
    """Create a subscription of depth 10 that takes ``qos_overrides`` (``light``: see below)."""
    options, events = light_options(node, overrides, topic, 'subscription', light)
    return qos_checked(node, overrides, topic, 'subscription', node.create_subscription,
                       msg_type, topic, callback, 10, qos_overriding_options=options,
                       event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False)
                       if events else None)


def light_options(node, overrides, topic, kind, light):
    """
    Return ``(qos overriding options, events off)`` of an endpoint.

    rclpy gives every endpoint a waitable of QoS event handlers (incompatible QoS and type
    warnings), which every executor wake-up adds to its wait set (400 of them: 6 ms a
    wake-up), and declares four read-only ``qos_overrides.<topic>.<kind>.*`` parameters.
    A ``light`` endpoint (each body's of a world: thousands) has no event handlers and
    declares its ``qos_overrides`` parameters only when one of them is overridden (its
    overrides apply either way: they are read when the parameters are declared).

    :param overrides: the ``qos_overrides.*`` ones at least (the node passes only those: this
        looks at each).
    """
    if not light:
        return QOS_OVERRIDES, False
    prefix = f'qos_overrides.{node.resolve_topic_name(topic)}.{kind}.'
    return (QOS_OVERRIDES if any(name.startswith(prefix) for name in overrides) else None,
            True)


def output_topics(config):
    """Every topic an output of ``config`` may use (contact_wrench even without contact)."""
    kinds = outputs.SampleBuilder(config, tf=False).kinds
    return ([outputs.topic_of(kind) for kind in kinds]
            + [f'{b.prefix}contact_wrench' for b in config.bodies] + list(OTHER_OUTPUT_TOPICS))


def shown_name(name):
    """Return ``repr(name)``, or of its last 40 characters after '...' when longer than 60."""
    return repr(name) if len(name) <= 60 else repr('...' + name[-40:])


def _too_long(node, name, service=False):
    """Return None if ``name`` resolves, else ``'<name> resolves past ...'`` (one clause)."""
    try:
        (node.resolve_service_name if service else node.resolve_topic_name)(name)
        return None
    except (RuntimeError, NameValidationException) as exc:  # rclpy raises RCLError
        text = rcl_text(exc)
    namespace = node.get_namespace().rstrip('/')
    full = name if name.startswith('/') else f'{namespace}/{name}'.replace(
        '~', f'{namespace}/{node.get_name()}', 1)
    if 'length should not exceed' in text:
        return (f'makes the {"service" if service else "topic"} {shown_name(full)} '
                f"{len(full)} characters long, past rcl's limit of {TOPIC_NAME_MAX_CHARS}")
    return f'makes {sim_params.fmt(full)} not a valid topic name ({text})'


def check_names(node, config):
    """
    Resolve every topic and service name the node will create, before it creates any.

    A name past :data:`TOPIC_NAME_MAX_CHARS` or invalid is refused naming what made it: the
    node's namespace (the topics of every node), ``body_names`` (a body's topics),
    ``robot_names`` or ``command_group_names`` (a robot's or a group's topics), or the
    ``wrench_inputs`` topic parameter. Frame ids and parameter names have no length limit in
    rcl (``bodies.<name>.*`` parameters of any length declare).

    :raises ConfigError: one line naming the parameter, its value (cut) and the limit.
    """
    namespace = node.get_namespace()
    for name in OUTPUT_TOPICS + ('drag', '/clicked_point') + SERVICES:
        why = _too_long(node, name, service=name in SERVICES)
        if why:
            raise ConfigError(f'namespace {sim_params.fmt(namespace)} ({len(namespace)} '
                              f'characters): {why}')
    names = config.parameters.get('body_names') or []
    for body in config.bodies:
        for kind in outputs.BODY_KINDS + ('drag',):
            why = body.prefix and _too_long(node, body.prefix + kind)
            if why:
                raise ConfigError(f'parameter body_names = {sim_params.fmt(list(names))}: '
                                  f'body {names.index(body.name)} {why}')
    for names_param, what, items, kinds in (
            ('robot_names', 'robot', config.robots,
             ('joint_states', 'odom', 'joint_wrenches', 'robot_description',
              'joint_command')),
            ('command_group_names', 'command group', config.command_groups,
             ('commands', 'joint_trajectory'))):
        names = config.parameters.get(names_param) or []
        for item in items:
            why = next(filter(None, (_too_long(node, f'{item.name}/{kind}') for kind in kinds)),
                       None)
            if why:
                raise ConfigError(f'parameter {names_param} = {sim_params.fmt(list(names))}: '
                                  f'{what} {names.index(item.name)} {why}')
    for spec in config.wrench_inputs:
        why = _too_long(node, spec.topic)
        if why:
            body, _, name = spec.name.rpartition('/')
            field = f'bodies.{body}.wrench_inputs.{name}' if body else f'wrench_inputs.{name}'
            raise ConfigError(f'parameter {field}.topic = {sim_params.fmt(spec.topic)}: {why}')


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
