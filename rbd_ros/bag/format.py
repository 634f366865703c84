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


class _Loader(yaml.SafeLoader):
    """A safe YAML loader that refuses anchors and aliases (an alias bomb expands to GBs)."""

    def compose_node(self, parent, index):
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, 'anchor', None) is not None:
            raise yaml.YAMLError(
                f'anchor/alias {event.anchor!r} at line {event.start_mark.line + 1}: YAML '
                'anchors and aliases are not accepted in a recording')
        return super().compose_node(parent, index)


def load_yaml(text: Union[str, bytes], what: str) -> Any:
    """
    Parse YAML ``text`` read from a recording: no anchors/aliases, at most MAX_YAML_BYTES.

    :param what: names the source in the error (e.g. ``'bag.mcap: the rbd_ros record'``).
    :raises RecordingError: oversize, an anchor or alias, or invalid YAML (one line).
    """
    if isinstance(text, bytes):
        text = text.decode('utf-8', 'replace')
    if len(text) > MAX_YAML_BYTES:
        raise RecordingError(
            f'{what}: {len(text)} bytes of YAML, more than the {MAX_YAML_BYTES} bytes accepted')
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        detail = ' '.join(str(exc).split())
        raise RecordingError(f'{what}: not valid YAML ({detail})') from None
