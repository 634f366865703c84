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
The bag format's constants and the helpers writer and reader share: QoS profiles and YAML.

The record names and versions rbd_ros writes (``rbd_ros``, ``rbd_ros.run``, rosbag2 metadata
version 9), the QoS profile rosbag2 v9 stores for each topic, and YAML written as rosbag2
writes it and read back as untrusted text (no anchors or aliases, at most
:data:`MAX_YAML_BYTES`). :mod:`rbd_ros.bag.recording` writes bags, :mod:`rbd_ros.bag.reader`
reads them.
"""

from typing import Any, Dict, Mapping, Optional, Union

from rbd_ros.core.errors import RecordingError
from rbd_ros.sim.params import MAX_ARRAY_ITEMS, MAX_BODIES
import yaml


#: Name of the MCAP metadata record holding the node configuration.
CONFIG_METADATA_NAME = 'rbd_ros'
#: Version of the content of the ``rbd_ros`` metadata record.
CONFIG_FORMAT = 'rbd_ros.recording/1'
#: Name of the MCAP metadata record written at close: how the run ended, what it applied.
RUN_METADATA_NAME = 'rbd_ros.run'
#: rosbag2 metadata version written (Jazzy).
ROSBAG2_METADATA_VERSION = 9
#: rosbag2 writes this ``starting_time`` (int64 max ns) in the record it makes at open.
INT64_MAX = (1 << 63) - 1
#: Largest YAML text read from a bag (config record, rosbag2 record, metadata.yaml, QoS), bytes:
#: a world of ``config.MAX_BODIES`` bodies writes a metadata.yaml of ~1 kB a topic, five topics a
#: body (~25 MB); without anchors or aliases, parsing is linear in the size.
MAX_YAML_BYTES = 32 << 20

MCAP_MAGIC = b'\x89MCAP0\r\n'

# rosbag2 writes an infinite duration as the largest int64 nanoseconds split into sec/nsec.
_INFINITE_DURATION = {'sec': 9223372036, 'nsec': 854775807}
_QOS_KEYS = ('history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan',
             'liveliness', 'liveliness_lease_duration', 'avoid_ros_namespace_conventions')
# What an rclpy publisher with a depth-10 profile offers (rclpy's qos_profile_default).
DEFAULT_QOS = {
    'history': 'keep_last',
    'depth': 10,
    'reliability': 'reliable',
    'durability': 'volatile',
    'deadline': dict(_INFINITE_DURATION),
    'lifespan': dict(_INFINITE_DURATION),
    'liveliness': 'system_default',
    'liveliness_lease_duration': dict(_INFINITE_DURATION),
    'avoid_ros_namespace_conventions': False,
}


def os_error_text(exc):
    """Return an OS error as one line: its text and the file it names."""
    text = exc.strerror or str(exc)
    if exc.filename:
        text = f'{text}: {exc.filename!r}'
    return text


def normalize_qos(qos: Optional[Mapping[str, Any]]) -> Dict[str, Any]:
    """
    Return a complete rosbag2 v9 QoS profile dict (string enums) from a partial one.

    Missing keys take the values of :data:`DEFAULT_QOS`; durations may be given as
    ``{'sec': s, 'nsec': ns}`` or as integer nanoseconds.
    """
    out = dict(DEFAULT_QOS)
    for key, value in (qos or {}).items():
        if key not in _QOS_KEYS:
            raise RecordingError(
                f'qos key {key!r} is not a rosbag2 v9 QoS policy (expected one of {_QOS_KEYS})')
        if key in ('deadline', 'lifespan', 'liveliness_lease_duration'):
            if isinstance(value, int):
                value = {'sec': value // 1_000_000_000, 'nsec': value % 1_000_000_000}
            value = {'sec': int(value['sec']), 'nsec': int(value['nsec'])}
        elif key == 'depth':
            value = int(value)
        elif key == 'avoid_ros_namespace_conventions':
            value = bool(value)
        else:
            value = str(value).lower()
        out[key] = value
    return {key: out[key] for key in _QOS_KEYS}


class _Dumper(getattr(yaml, 'CSafeDumper', yaml.SafeDumper)):
    """A YAML dumper that never writes anchors or aliases (rosbag2 writes none)."""

    def ignore_aliases(self, data):
        return True


# rosbag2 (yaml-cpp) writes an empty custom_data as '~'; write null the same way.
_Dumper.add_representer(
    type(None), lambda dumper, _: dumper.represent_scalar('tag:yaml.org,2002:null', '~'))


def dump_yaml(data):
    """Return ``data`` as YAML text the way rosbag2 writes it (no aliases, ``~`` for null)."""
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=False)


#: Most items a YAML list or map read from a bag may hold: 50 x MAX_BODIES (5000), more than
#: the largest world writes (its configuration map: ~20 keys a body; its metadata.yaml: six
#: topics a body and any extra wrench inputs). Checked while the text is parsed, before anything
#: is built from it. The lists of the configuration record are held to the node's own bound on
#: an array parameter, :data:`rbd_ros.sim.params.MAX_ARRAY_ITEMS` (10 x MAX_BODIES): a
#: configuration of 10^5 or 10^6 body names is refused after its first 50 000 (~0.05 s).
MAX_YAML_ITEMS = 50 * MAX_BODIES

# libyaml's parser (C) where PyYAML has it: a 10 MB text parses in ~3 s, ~20 times faster
# than the pure-Python parser.
_SafeLoader = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
_STARTS = (yaml.SequenceStartEvent, yaml.MappingStartEvent)
_ENDS = (yaml.SequenceEndEvent, yaml.MappingEndEvent)
# (most items, the name an error gives it)
_ITEMS_LIMIT = (MAX_YAML_ITEMS, 'rbd_ros.bag.format.MAX_YAML_ITEMS')
_ARRAY_LIMIT = (MAX_ARRAY_ITEMS, 'rbd_ros.sim.params.MAX_ARRAY_ITEMS')


def _check_events(text, what, list_limit):
    """
    Refuse anchors, aliases, maps of more than MAX_YAML_ITEMS items and over-long lists.

    ``list_limit``: ``(most items a list may hold, the name the error gives that limit)``.

    Reads the parser's events only (nothing is built), so an alias bomb or a huge list costs
    the events read up to the first one refused.
    """
    loader = _SafeLoader(text)
    stack = []  # per open collection: [is a map, events inside, its key, last key read]
    try:
        while loader.check_event():
            event = loader.get_event()
            if isinstance(event, yaml.AliasEvent) or getattr(event, 'anchor', None) is not None:
                raise RecordingError(
                    f'{what}: not valid YAML (anchor/alias {event.anchor!r} at line '
                    f'{event.start_mark.line + 1}: YAML anchors and aliases are not accepted in '
                    'a recording)')
            if isinstance(event, _ENDS):
                stack.pop()
                continue
            if not isinstance(event, (yaml.ScalarEvent,) + _STARTS):
                continue
            if stack:
                top = stack[-1]
                top[1] += 1
                if top[1] > (2 * MAX_YAML_ITEMS if top[0] else list_limit[0]):  # key, value
                    kind, (limit, name) = ('map', _ITEMS_LIMIT) if top[0] else ('list', list_limit)
                    named = '' if top[2] is None else f' {top[2]!r}'
                    raise RecordingError(
                        f'{what}: the {kind}{named} has more than {limit} items (at line '
                        f'{event.start_mark.line + 1}), more than a recording holds ({name})')
                if top[0] and top[1] % 2 and isinstance(event, yaml.ScalarEvent):
                    top[3] = event.value[:80]
            if isinstance(event, _STARTS):
                key = stack[-1][3] if stack and stack[-1][0] else None
                stack.append([isinstance(event, yaml.MappingStartEvent), 0, key, None])
    finally:
        loader.dispose()


def load_yaml(text: Union[str, bytes], what: str, *, configuration: bool = False) -> Any:
    """
    Parse YAML ``text`` read from a recording: no anchors/aliases, at most MAX_YAML_BYTES.

    Maps and lists hold at most :data:`MAX_YAML_ITEMS` items each, the lists of a
    ``configuration`` (the rbd_ros record's parameters) at most
    :data:`rbd_ros.sim.params.MAX_ARRAY_ITEMS`; the text is parsed by libyaml when PyYAML has it.

    :param what: names the source in the error (e.g. ``'bag.mcap: the rbd_ros record'``).
    :raises RecordingError: oversize, an anchor or alias, or invalid YAML (one line).
    """
    if isinstance(text, bytes):
        text = text.decode('utf-8', 'replace')
    if len(text) > MAX_YAML_BYTES:
        raise RecordingError(
            f'{what}: {len(text)} bytes of YAML, more than the {MAX_YAML_BYTES} bytes accepted')
    try:
        _check_events(text, what, _ARRAY_LIMIT if configuration else _ITEMS_LIMIT)
        return yaml.load(text, Loader=_SafeLoader)  # noqa: S506 - a safe loader
    except yaml.YAMLError as exc:
        detail = ' '.join(str(exc).split())
        raise RecordingError(f'{what}: not valid YAML ({detail})') from None
