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
Decode a bag's ``rosbag2`` MCAP metadata records step by step as rosbag2 (Jazzy) does.

``rosbag2_storage_mcap`` ``MCAPStorage::read_metadata`` iterates every metadata record named
``rosbag2`` (the last one wins), loads its ``serialized_metadata`` with yaml-cpp and converts
the ROOT node with ``convert<BagMetadata>::decode`` (``rosbag2_storage/yaml.hpp``):
``node["version"]`` read at the root, then for version 9 the keys ``storage_identifier``,
``duration.nanoseconds``, ``starting_time.nanoseconds_since_epoch``, ``message_count``,
``topics_with_message_count`` (a sequence of ``topic_metadata`` {``name``, ``type``,
``serialization_format``, ``offered_qos_profiles`` (v9: a sequence of QoS maps with string
enums), ``type_description_hash``} + ``message_count``), ``relative_file_paths``,
``compression_format``, ``compression_mode``, ``files`` ({``path``, ``starting_time``,
``duration``, ``message_count``}), ``custom_data`` (a string map; ``~`` is empty) and
``ros_distro``.  A missing key or a value yaml-cpp cannot convert throws, which is what made
``ros2 bag play`` fail on the old wrapped record.  Unsigned fields (``as<uint64_t>``) reject
negative values.
"""

from mcap.reader import make_reader
import yaml

_QOS_ENUMS = {
    'history': {'system_default', 'keep_last', 'keep_all', 'unknown'},
    'reliability': {'system_default', 'reliable', 'best_effort', 'unknown', 'best_available'},
    'durability': {'system_default', 'transient_local', 'volatile', 'unknown',
                   'best_available'},
    'liveliness': {'system_default', 'automatic', 'manual_by_topic', 'unknown',
                   'best_available'},
}
_QOS_DURATIONS = ('deadline', 'lifespan', 'liveliness_lease_duration')


class Rosbag2DecodeError(Exception):
    """rosbag2 would throw on this record (yaml-cpp InvalidNode / TypedBadConversion)."""


def _get(node, key, where):
    if not isinstance(node, dict) or key not in node:
        raise Rosbag2DecodeError(f'{where}: no key {key!r} (yaml-cpp: invalid node)')
    return node[key]


def _string(node, key, where):
    value = _get(node, key, where)
    if not isinstance(value, str):
        raise Rosbag2DecodeError(f'{where}.{key}: {value!r} is not a string scalar')
    return value


def _uint64(node, key, where):
    value = _get(node, key, where)
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 1 << 64:
        raise Rosbag2DecodeError(f'{where}.{key}: {value!r} is not a uint64')
    return value


def _int(node, key, where):
    value = _get(node, key, where)
    if isinstance(value, bool) or not isinstance(value, int):
        raise Rosbag2DecodeError(f'{where}.{key}: {value!r} is not an int')
    return value


def _qos(node, where):
    out = {}
    for key, allowed in _QOS_ENUMS.items():
        value = _get(node, key, where)
        # rosbag2 v9 writes string names; the decoder also takes v8 integers.
        if isinstance(value, str) and value not in allowed:
            raise Rosbag2DecodeError(f'{where}.{key}: {value!r} is not a policy name')
        if not isinstance(value, (str, int)):
            raise Rosbag2DecodeError(f'{where}.{key}: {value!r} is not a policy')
        out[key] = value
    out['depth'] = _uint64(node, 'depth', where)
    for key in _QOS_DURATIONS:
        duration = _get(node, key, where)
        out[key] = (_uint64(duration, 'sec', f'{where}.{key}'),
                    _uint64(duration, 'nsec', f'{where}.{key}'))
    value = _get(node, 'avoid_ros_namespace_conventions', where)
    if not isinstance(value, bool):
        raise Rosbag2DecodeError(f'{where}.avoid_ros_namespace_conventions: {value!r}')
    out['avoid_ros_namespace_conventions'] = value
    return out


def _file(node, where):
    return {
        'path': _string(node, 'path', where),
        'starting_time': _uint64(_get(node, 'starting_time', where), 'nanoseconds_since_epoch',
                                 f'{where}.starting_time'),
        'duration': _uint64(_get(node, 'duration', where), 'nanoseconds', f'{where}.duration'),
        'message_count': _uint64(node, 'message_count', where),
    }


def decode_bag_metadata(text):
    """Return the decoded BagMetadata of one ``serialized_metadata`` text, or raise."""
    root = yaml.safe_load(text)
    if not isinstance(root, dict):
        raise Rosbag2DecodeError(f'the root node is a {type(root).__name__}, not a map')
    meta = {'version': _int(root, 'version', 'root')}
    version = meta['version']
    if version != 9:
        raise Rosbag2DecodeError(f'version {version}: Jazzy writes 9')
    meta['storage_identifier'] = _string(root, 'storage_identifier', 'root')
    meta['duration'] = _uint64(_get(root, 'duration', 'root'), 'nanoseconds', 'duration')
    meta['starting_time'] = _uint64(_get(root, 'starting_time', 'root'),
                                    'nanoseconds_since_epoch', 'starting_time')
    meta['message_count'] = _uint64(root, 'message_count', 'root')
    topics = _get(root, 'topics_with_message_count', 'root')
    if not isinstance(topics, list):
        raise Rosbag2DecodeError('topics_with_message_count is not a sequence')
    meta['topics'] = []
    for k, entry in enumerate(topics):
        where = f'topics_with_message_count[{k}]'
        tm = _get(entry, 'topic_metadata', where)
        where_tm = where + '.topic_metadata'
        profiles = _get(tm, 'offered_qos_profiles', where_tm)
        if not isinstance(profiles, list):  # v9: a sequence, no longer one YAML string
            raise Rosbag2DecodeError(f'{where_tm}.offered_qos_profiles is not a sequence')
        meta['topics'].append({
            'name': _string(tm, 'name', where_tm),
            'type': _string(tm, 'type', where_tm),
            'serialization_format': _string(tm, 'serialization_format', where_tm),
            'offered_qos_profiles': [_qos(p, f'{where_tm}.offered_qos_profiles[{j}]')
                                     for j, p in enumerate(profiles)],
            'type_description_hash': _string(tm, 'type_description_hash', where_tm),
            'message_count': _uint64(entry, 'message_count', where),
        })
    paths = _get(root, 'relative_file_paths', 'root')
    if not isinstance(paths, list) or not all(isinstance(p, str) for p in paths):
        raise Rosbag2DecodeError('relative_file_paths is not a sequence of strings')
    meta['relative_file_paths'] = paths
    meta['compression_format'] = _string(root, 'compression_format', 'root')
    meta['compression_mode'] = _string(root, 'compression_mode', 'root')
    files = _get(root, 'files', 'root')
    if not isinstance(files, list):
        raise Rosbag2DecodeError('files is not a sequence')
    meta['files'] = [_file(f, f'files[{k}]') for k, f in enumerate(files)]
    custom = _get(root, 'custom_data', 'root')
    if custom is not None and not (isinstance(custom, dict) and all(
            isinstance(k, str) and isinstance(v, str) for k, v in custom.items())):
        raise Rosbag2DecodeError(f'custom_data {custom!r} is not a string map')
    meta['custom_data'] = dict(custom or {})
    meta['ros_distro'] = _string(root, 'ros_distro', 'root')
    return meta


def read_rosbag2_records(mcap_path):
    """Return the decoded BagMetadata of every ``rosbag2`` record, in file order."""
    out = []
    with open(mcap_path, 'rb') as f:
        for record in make_reader(f).iter_metadata():
            if record.name == 'rosbag2':
                out.append(decode_bag_metadata(
                    _get(record.metadata, 'serialized_metadata', 'rosbag2 record')))
    return out


def read_metadata_like_rosbag2(mcap_path):
    """Return what ``MCAPStorage::read_metadata`` takes from the records: the last one wins."""
    records = read_rosbag2_records(mcap_path)
    if not records:
        raise Rosbag2DecodeError(f'{mcap_path}: no rosbag2 record')
    return records[-1]
