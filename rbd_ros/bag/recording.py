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
Recording to MCAP in the rosbag2 (Jazzy) bag layout, and reading recordings back.

:class:`BagWriter` writes a rosbag2 bag directory ``<bag>/metadata.yaml`` (metadata version 9)
plus ``<bag>/<bag>_0.mcap`` with what rosbag2's MCAP storage plugin writes for Jazzy: header
profile ``ros2``; one ``ros2msg`` schema per type (:mod:`rbd_ros.msgs.schemas`); ``cdr`` channels
whose metadata holds ``offered_qos_profiles`` (v9 YAML, string enums) and ``topic_type_hash``;
chunks with message indexes; a summary with chunk indexes and a statistics record; and a
``rosbag2`` metadata record whose ``serialized_metadata`` is the bare BagMetadata map (root key
``version``: rosbag2_storage_mcap decodes it from the root; only ``metadata.yaml`` wraps it in
``rosbag2_bagfile_information``), written at open (``starting_time`` int64 max) and at close
(the last one wins).  The node's full configuration is stored as the MCAP metadata record
``rbd_ros``, so the recording alone is enough to replay it; at close the node adds
``rbd_ros.run`` (how the run ended, the digest of the wrenches it applied).

Everything read back from a bag is treated as untrusted: YAML texts are parsed without
anchors/aliases and up to :data:`MAX_YAML_BYTES` (:func:`load_yaml`), and the files
``metadata.yaml`` names must lie inside the bag directory.

Message log times are sim time in integer nanoseconds.  A chunk is closed and flushed to the
operating system before it covers more than ``chunk_duration_ns`` of sim time (1 s by default)
or ``chunk_bytes`` of data, so a run killed with SIGKILL leaves a file whose completed chunks
stay readable (:func:`open_bag` reads such a file and says it was not finalised).
The mcap ``Writer`` is used through its public API only: it would end a chunk only on reaching
``chunk_size``, so chunks are ended on sim time and size with its ``flush()``.

Every failure is a :class:`RecordingError` naming the file, the value or the OS error (a
type that cannot be recorded: :class:`rbd_ros.msgs.schemas.SchemaError`, one of them).  It is an
:class:`OSError` too, as most are file failures (path exists, cannot be created, disk full,
truncated or unreadable file).

This module does not import rclpy: the node serialises messages with
``rclpy.serialization.serialize_message`` and hands the CDR bytes to :meth:`BagWriter.write`.
"""

import dataclasses
import glob
import importlib.metadata
import os
import re
import stat
import struct
import time
from typing import (Any, Callable, Dict, Iterable, Iterator, List, Mapping, Optional, Tuple,
                    Union)

from mcap.data_stream import RecordBuilder
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import (Attachment, Channel, Footer, Header, Message, Metadata, Schema,
                          Statistics)
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer
from rbd_ros import __version__
from rbd_ros.core.errors import RecordingError
from rbd_ros.msgs import schemas
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

_COMPRESSION = {
    'none': CompressionType.NONE,
    '': CompressionType.NONE,
    'zstd': CompressionType.ZSTD,
    'lz4': CompressionType.LZ4,
}


def _os_error_text(exc):
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


def _dump_yaml(data):
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


@dataclasses.dataclass
class _Topic:
    name: str
    type_name: str
    qos: dict
    type_hash: str
    channel_id: int
    count: int = 0


class BagWriter:
    """
    Write one rosbag2 bag directory with one MCAP file.

    :param path: the bag directory; ``{stamp}`` in it is replaced by the UTC wall time
        ``YYYY_MM_DD-HH_MM_SS`` (rosbag2's default naming).
    :param config: the node parameters (``NodeConfig.to_parameters()``), stored as YAML in the
        ``rbd_ros`` metadata record.
    :param overwrite: replace an existing bag directory, only one holding nothing but regular
        files ``metadata.yaml`` and ``<name>_<N>.mcap`` (see :meth:`_prepare_directory`);
        otherwise an existing path is a :class:`RecordingError`.
    :param compression: chunk compression, ``'zstd'`` (default), ``'lz4'`` or ``'none'``.
    :param chunk_duration_ns: a chunk is closed before it would cover this much sim time.
    :param chunk_bytes: a chunk is closed once it holds this many bytes of message data.
    :param fsync: also ``os.fsync`` after each chunk (survives power loss, costs time).
    :param extra_metadata: more ``str -> str`` entries for the ``rbd_ros`` record.
    :raises RecordingError: the path exists, cannot be created or written.
    """

    def __init__(self, path: Union[str, os.PathLike], config: Optional[Mapping[str, Any]] = None,
                 *, overwrite: bool = False, compression: str = 'zstd',
                 chunk_duration_ns: int = 1_000_000_000, chunk_bytes: int = 1 << 20,
                 fsync: bool = False, extra_metadata: Optional[Mapping[str, Any]] = None):
        path = os.fspath(path)
        if '{stamp}' in path:
            path = path.replace('{stamp}', time.strftime('%Y_%m_%d-%H_%M_%S', time.gmtime()))
        path = os.path.abspath(path)
        if compression not in _COMPRESSION:
            raise RecordingError(
                f'compression {compression!r} is not one of {sorted(_COMPRESSION)}')
        if chunk_duration_ns <= 0:
            raise RecordingError(f'chunk_duration_ns {chunk_duration_ns} ns must be > 0')
        self.path = path
        self.name = os.path.basename(path)
        self.mcap_name = f'{self.name}_0.mcap'
        self.mcap_path = os.path.join(path, self.mcap_name)
        self._config = dict(config or {})
        self._chunk_ns = int(chunk_duration_ns)
        self._chunk_bytes_max = int(chunk_bytes)
        self._fsync = fsync
        self._topics = {}
        self._schema_ids = {}
        self._closed = False
        self._failed = None
        self._chunk_messages = 0
        self._chunk_bytes = 0
        self._chunk_start_ns = 0
        self._message_count = 0
        self._start_ns = None
        self._end_ns = 0
        self._stream = None
        self._defs_in_chunk_only = []  # Schema/Channel records not yet on disk
        if not callable(getattr(Writer, 'flush', None)):
            raise RecordingError(
                f'mcap {importlib.metadata.version("mcap")}: its Writer has no public flush() '
                'to end a chunk with; rbd_ros needs mcap 1.6.0 or newer')
        self._prepare_directory(overwrite)
        try:
            self._stream = open(self.mcap_path, 'xb')
            # The mcap Writer would end a chunk only on reaching chunk_size; we end chunks on sim
            # time and size ourselves through its public Writer.flush().
            self._mcap = Writer(
                self._stream, chunk_size=1 << 62, compression=_COMPRESSION[compression])
            self._mcap.start(profile='ros2', library=f'rbd_ros-{__version__}')
            self._mcap.add_metadata(CONFIG_METADATA_NAME, self._config_record(extra_metadata))
            self._mcap.add_metadata('rosbag2', self._rosbag2_record())
            self._stream.flush()
        except OSError as exc:
            self._fail(exc)

    # ------------------------------------------------------------------ setup
    def _prepare_directory(self, overwrite):
        """
        Create the bag directory; with ``overwrite``, empty an existing bag of ours first.

        Only what is provably our bag is deleted: regular files directly in the directory named
        ``metadata.yaml``, ``<name>_<N>.mcap`` or our temporary ``.metadata.yaml.tmp``.  A
        directory holding anything else (another file, a subdirectory, a symlink) is refused
        with nothing deleted, and so is a ``record_path`` that is itself a symlink.
        """
        if os.path.islink(self.path):
            raise RecordingError(
                f'record_path {self.path!r} is a symbolic link; give the bag directory itself '
                '(a link is never followed, created through or overwritten)')
        if os.path.lexists(self.path):
            if not overwrite:
                raise RecordingError(
                    f'record_path {self.path!r} already exists; refusing to overwrite a bag '
                    "(choose a new name, put '{stamp}' in it, or allow overwriting)")
            if not os.path.isdir(self.path):
                raise RecordingError(
                    f'record_path {self.path!r} exists and is not a bag directory; '
                    'not overwriting it')
            ours = []
            try:
                entries = sorted(os.listdir(self.path))
                for entry in entries:
                    full = os.path.join(self.path, entry)
                    if not (self._is_our_file_name(entry)
                            and stat.S_ISREG(os.lstat(full).st_mode)):
                        raise RecordingError(
                            f'record_path {self.path!r} exists and holds {entry!r}, which is '
                            'not a file of an rbd_ros bag (only regular files metadata.yaml '
                            f'and {self.name}_<N>.mcap are); not overwriting it')
                    ours.append(full)
                for full in ours:
                    os.unlink(full)
            except OSError as exc:
                raise RecordingError(
                    f'record_path {self.path!r}: cannot replace the existing bag '
                    f'({_os_error_text(exc)})') from None
        try:
            os.makedirs(self.path, exist_ok=overwrite)
        except OSError as exc:
            raise RecordingError(
                f'record_path {self.path!r}: cannot create the bag directory '
                f'({_os_error_text(exc)})') from None

    def _is_our_file_name(self, entry):
        return (entry in ('metadata.yaml', '.metadata.yaml.tmp')
                or re.fullmatch(re.escape(self.name) + r'_\d+\.mcap', entry) is not None)

    def _config_record(self, extra):
        timestep_s = self._config.get('timestep_s')
        record = {
            'format': CONFIG_FORMAT,
            'package_version': __version__,
            'config_yaml': yaml.safe_dump(self._config, sort_keys=True),
            'integrator': str(self._config.get('integrator', '')),
            'timestep_ns': '' if timestep_s is None else str(round(float(timestep_s) * 1e9)),
        }
        for key, value in (extra or {}).items():
            record[str(key)] = str(value)
        return record

    # ------------------------------------------------------------------ API
    @property
    def closed(self) -> bool:
        """Return whether :meth:`close` has been called."""
        return self._closed

    @property
    def failed(self) -> Optional[RecordingError]:
        """Return the :class:`RecordingError` that stopped the recording, or None."""
        return self._failed

    def add_file(self, name: str, data: bytes,
                 media_type: str = 'application/octet-stream') -> None:
        """
        Store a file the run depends on (a mesh) as an MCAP attachment named ``name``.

        Replay uses it instead of whatever is at that path later (see
        :meth:`Bag.attachments`), so a recording of a mesh world replays anywhere.
        """
        self._check_open()
        try:
            self._mcap.add_attachment(0, 0, name, media_type, bytes(data))
            self._stream.flush()
        except OSError as exc:
            self._fail(exc)

    def add_topic(self, topic: str, type_name: str,
                  qos: Optional[Mapping[str, Any]] = None) -> None:
        """
        Declare a topic (absolute name) of type ``pkg/msg/Type`` with the QoS it is offered at.

        Adding the same topic again with the same type is a no-op.
        """
        self._check_open()
        if not topic.startswith('/'):
            raise RecordingError(f'topic {topic!r} must be an absolute name (start with /)')
        existing = self._topics.get(topic)
        if existing is not None:
            if existing.type_name != type_name:
                raise RecordingError(
                    f'topic {topic!r} already recorded with type {existing.type_name!r}, '
                    f'not {type_name!r}')
            return
        definition = schemas.message_definition(type_name)
        type_hash = schemas.type_hash(type_name)
        profile = normalize_qos(qos)
        try:
            schema_id = self._schema_ids.get(type_name)
            if schema_id is None:
                schema_id = self._mcap.register_schema(type_name, 'ros2msg', definition)
                self._schema_ids[type_name] = schema_id
                self._defs_in_chunk_only.append(Schema(
                    id=schema_id, name=type_name, encoding='ros2msg', data=definition))
            channel_metadata = {'offered_qos_profiles': _dump_yaml([profile]),
                                'topic_type_hash': type_hash}
            channel_id = self._mcap.register_channel(topic, 'cdr', schema_id, channel_metadata)
            self._defs_in_chunk_only.append(Channel(
                id=channel_id, topic=topic, message_encoding='cdr', schema_id=schema_id,
                metadata=channel_metadata))
        except OSError as exc:
            self._fail(exc)
        self._topics[topic] = _Topic(topic, type_name, profile, type_hash, channel_id)

    def write(self, topic: str, data: bytes, log_time_ns: int,
              publish_time_ns: Optional[int] = None) -> None:
        """
        Append one CDR-serialised message (with its 4-byte encapsulation header).

        :param log_time_ns: sim time in integer ns (rosbag2 plays back on this).
        :param publish_time_ns: send time; defaults to ``log_time_ns``.
        """
        if self._failed is not None or self._closed:
            self._check_open()
        entry = self._topics.get(topic)
        if entry is None:
            raise RecordingError(f'topic {topic!r} was not added with add_topic() before write()')
        if self._chunk_messages and (
                log_time_ns - self._chunk_start_ns >= self._chunk_ns
                or self._chunk_bytes >= self._chunk_bytes_max):
            self._end_chunk()
        if not self._chunk_messages:
            self._chunk_start_ns = log_time_ns
        self._mcap.add_message(
            entry.channel_id, log_time_ns, data,
            log_time_ns if publish_time_ns is None else publish_time_ns, 0)
        self._chunk_messages += 1
        self._chunk_bytes += len(data)
        entry.count += 1
        self._message_count += 1
        if self._start_ns is None:
            self._start_ns = log_time_ns
        if log_time_ns > self._end_ns:
            self._end_ns = log_time_ns

    def flush(self) -> None:
        """
        End the current chunk and hand everything written so far to the operating system.

        :raises RecordingError: the write failed (disk full, file size limit, ...).
        """
        self._check_open()
        if self._chunk_messages:
            self._end_chunk()
            return
        try:
            if self._defs_in_chunk_only:
                # The mcap writer keeps schemas and channels for the next chunk, written when it
                # holds a message; write them now too, outside any chunk (MCAP allows identical
                # repeats), so that a full disk shows at start rather than at the first chunk.
                builder = RecordBuilder()
                for record in self._defs_in_chunk_only:
                    record.write(builder)
                self._stream.write(builder.end())
                self._defs_in_chunk_only = []
            self._stream.flush()
        except OSError as exc:
            self._fail(exc)

    def close(self, run_metadata: Optional[Mapping[str, Any]] = None) -> None:
        """
        Finalise the bag; idempotent.

        Writes the last chunk, the ``rbd_ros.run`` record (``run_metadata``, str -> str, when
        given), the ``rosbag2`` record, the summary (statistics, indexes), the footer, then
        ``metadata.yaml``.  After a failure it only releases the file.
        """
        if self._closed:
            return
        self._closed = True
        if self._failed is not None:
            self._release()
            return
        try:
            if self._chunk_messages:
                self._end_chunk(fsync=False)
            if run_metadata is not None:
                self._mcap.add_metadata(
                    RUN_METADATA_NAME, {str(k): str(v) for k, v in run_metadata.items()})
            self._mcap.add_metadata('rosbag2', self._rosbag2_record())
            self._mcap.finish()
            self._stream.flush()
            os.fsync(self._stream.fileno())
            self._stream.close()
            tmp = os.path.join(self.path, '.metadata.yaml.tmp')
            with open(tmp, 'w', encoding='utf-8') as f:
                f.write(self._metadata_yaml())
            os.replace(tmp, os.path.join(self.path, 'metadata.yaml'))
        except OSError as exc:
            self._release()
            self._closed = False
            try:
                self._fail(exc)
            finally:
                self._closed = True

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()

    # ------------------------------------------------------------------ internals
    def _check_open(self):
        if self._failed is not None:
            raise self._failed
        if self._closed:
            raise RecordingError(f'bag {self.path!r} is closed')

    def _fail(self, exc):
        self._failed = RecordingError(
            f'recording to {self.mcap_path!r} failed: {_os_error_text(exc)}')
        raise self._failed from None

    def _release(self):
        if self._stream is not None:
            try:
                self._stream.close()
            except OSError:
                pass

    def _end_chunk(self, fsync=True):
        """Write the open chunk with its message indexes and hand it to the OS (mcap's flush)."""
        self._defs_in_chunk_only = []  # the chunk carries them
        try:
            self._mcap.flush()
            if fsync and self._fsync:
                os.fsync(self._stream.fileno())
        except OSError as exc:
            self._fail(exc)
        self._chunk_messages = 0
        self._chunk_bytes = 0

    def metadata(self) -> Dict[str, Any]:
        """
        Return the rosbag2 ``BagMetadata`` (v9) of what has been written, as a bare dict.

        Its root keys are ``version``, ``storage_identifier``, ... as in the ``rosbag2`` MCAP
        record (rosbag2_storage_mcap decodes ``serialized_metadata`` as this bare map);
        ``metadata.yaml`` wraps the same map in ``rosbag2_bagfile_information``.  Before the
        first message ``starting_time`` is int64 max ns, as rosbag2 writes it at open.
        """
        if self._message_count:
            start, duration = self._start_ns, self._end_ns - self._start_ns
        else:
            start, duration = INT64_MAX, 0
        topics = []
        for t in self._topics.values():
            topics.append({
                'topic_metadata': {
                    'name': t.name,
                    'type': t.type_name,
                    'serialization_format': 'cdr',
                    'offered_qos_profiles': [t.qos],
                    'type_description_hash': t.type_hash,
                },
                'message_count': t.count,
            })
        return {
            'version': ROSBAG2_METADATA_VERSION,
            'storage_identifier': 'mcap',
            'duration': {'nanoseconds': duration},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': self._message_count,
            'topics_with_message_count': topics,
            'compression_format': '',
            'compression_mode': '',
            'relative_file_paths': [self.mcap_name],
            'files': [{
                'path': self.mcap_name,
                'starting_time': {'nanoseconds_since_epoch': start},
                'duration': {'nanoseconds': duration},
                'message_count': self._message_count,
            }],
            'custom_data': None,
            'ros_distro': 'jazzy',
        }

    def _rosbag2_record(self):
        """Return the ``rosbag2`` MCAP metadata record: the bare BagMetadata map as YAML."""
        return {'serialized_metadata': _dump_yaml(self.metadata())}

    def _metadata_yaml(self):
        """Return the text of ``metadata.yaml``: the BagMetadata under its wrapper key."""
        return _dump_yaml({'rosbag2_bagfile_information': self.metadata()})


# ====================================================================== reading
@dataclasses.dataclass(frozen=True)
class TopicInfo:
    """One recorded topic: name, type, offered QoS profiles, RIHS01 hash, message count."""

    name: str
    type_name: str
    qos: List[Dict[str, Any]]
    type_hash: str
    message_count: int
    schema_encoding: str
    schema_text: str


@dataclasses.dataclass(frozen=True)
class RawMessage:
    """One recorded message: topic, log and publish time (ns) and its CDR bytes."""

    topic: str
    log_time_ns: int
    publish_time_ns: int
    data: bytes


class Bag:
    """
    A recording opened for reading (see :func:`open_bag`).

    Attributes: ``path`` (as given), ``mcap_path``, ``finalised`` (MCAP summary with statistics
    present and ``metadata.yaml`` present), ``notes`` (why it is not finalised, or what was
    cut off), ``profile``, ``library``, ``topics`` (name -> :class:`TopicInfo`), ``config``
    (the node parameters as recorded, under the names of the day: read them through
    :func:`rbd_ros.sim.config.recorded_parameters`; None for a bag without our configuration),
    ``rbd_metadata`` (the ``rbd_ros`` record), ``run_metadata`` (the ``rbd_ros.run`` record
    written at close: how the run ended and the digest of the wrenches it applied; None if not
    finalised),
    ``rosbag2_metadata`` (last ``rosbag2`` record, parsed),
    ``metadata_yaml`` (parsed ``metadata.yaml`` or None), ``statistics`` (the MCAP Statistics
    record or None), ``message_count``, ``start_ns``, ``end_ns``.
    """

    def __init__(self, path: str, mcap_path: str, metadata_yaml: Optional[Dict[str, Any]]):
        self.path = path
        self.mcap_path = mcap_path
        self.metadata_yaml = metadata_yaml
        self.notes = []
        self.profile = ''
        self.library = ''
        self.topics = {}
        self.config = None
        self.rbd_metadata = None
        self.rosbag2_metadata = None
        self.run_metadata = None
        self.statistics = None
        self.has_footer = False
        self.truncated = False
        self.message_count = 0
        self.start_ns = None
        self.end_ns = None
        self._schemas = {}
        self._channels = {}

    @property
    def finalised(self) -> bool:
        """Return True when the MCAP summary, its statistics and metadata.yaml are all there."""
        return (self.has_footer and self.statistics is not None and not self.truncated
                and self.metadata_yaml is not None)

    def _records(self):
        with open(self.mcap_path, 'rb') as f:
            size = os.fstat(f.fileno()).st_size
            reader = StreamReader(f, validate_crcs=True)
            good_end = 0  # file offset after the last complete record read
            try:
                for record in reader.records:
                    good_end = f.tell()
                    yield record
            except (McapError, EOFError, ValueError, struct.error, KeyError, OSError) as exc:
                if not self.truncated:
                    self.truncated = True
                    if good_end < size:
                        self.notes.append(
                            f'{self.mcap_path}: the last {size - good_end} bytes are an '
                            f'incomplete or unreadable record ({type(exc).__name__}), e.g. '
                            'cut off by SIGKILL; reading the complete records before it')

    def messages(self, topics: Optional[Iterable[str]] = None) -> Iterator[RawMessage]:
        """Yield :class:`RawMessage` in file order (log time order for our recordings)."""
        wanted = None if topics is None else set(topics)
        for record in self._records():
            if isinstance(record, Channel):
                self._channels[record.id] = record
            elif isinstance(record, Message):
                channel = self._channels.get(record.channel_id)
                if channel is None:
                    continue
                if wanted is None or channel.topic in wanted:
                    yield RawMessage(channel.topic, record.log_time, record.publish_time,
                                     record.data)

    def attachments(self) -> Dict[str, bytes]:
        """Return the attached files (name → bytes), e.g. the meshes of the run."""
        out = {}
        for record in self._records():
            if isinstance(record, Attachment):
                out[record.name] = bytes(record.data)
        return out

    def decoded_messages(
            self, topics: Optional[Iterable[str]] = None) -> Iterator[Tuple[RawMessage, Any]]:
        """Yield ``(RawMessage, decoded)`` decoded with the stored schemas (no rclpy)."""
        decoders = {}
        for raw in self.messages(topics):
            decoder = decoders.get(raw.topic)
            if decoder is None:
                decoder = decoders[raw.topic] = self.decoder(raw.topic)
            yield raw, decoder(raw.data)

    def decoder(self, topic: str) -> Callable[[bytes], Any]:
        """Return a function CDR bytes -> message object for ``topic``, from its schema."""
        from mcap_ros2.decoder import DecoderFactory
        info = self.topics[topic]
        schema = Schema(id=1, name=info.type_name, encoding=info.schema_encoding,
                        data=info.schema_text.encode('utf-8'))
        decoder = DecoderFactory().decoder_for('cdr', schema)
        if decoder is None:
            raise RecordingError(
                f'{self.mcap_path}: topic {topic!r} has schema encoding '
                f'{info.schema_encoding!r} that cannot be decoded')
        return decoder

    def _scan(self):
        counts = self._scan_summary()
        if counts is None:
            counts = self._scan_records()
        self._take_channels(counts)

    def _scan_summary(self):
        """
        Read a finalised file through its footer: header, summary and metadata records only.

        The chunks are not read (replay reads them once, in :meth:`messages`): the schemas,
        channels and per-channel counts come from the summary and its statistics record, the
        metadata records through the summary's metadata indexes. Returns the counts by channel
        id, or None when the file has no readable summary with statistics (then every record
        is scanned).
        """
        try:
            with open(self.mcap_path, 'rb') as f:
                reader = make_reader(f)
                header = reader.get_header()
                summary = reader.get_summary()
                if summary is None or summary.statistics is None:
                    return None
                metadata = list(reader.iter_metadata())
        except (McapError, EOFError, ValueError, struct.error, KeyError, OSError):
            return None
        self.profile, self.library = header.profile, header.library
        self._schemas.update(summary.schemas)
        self._channels.update(summary.channels)
        self.statistics = stats = summary.statistics
        self.has_footer = True
        self.message_count = stats.message_count
        if stats.message_count:
            self.start_ns, self.end_ns = stats.message_start_time, stats.message_end_time
        for record in metadata:
            self._take_metadata(record)
        return dict(stats.channel_message_counts)

    def _scan_records(self):
        """Read every record (an unfinalised or summary-less file); return counts by channel."""
        counts = {}
        for record in self._records():
            if isinstance(record, Header):
                self.profile = record.profile
                self.library = record.library
            elif isinstance(record, Schema):
                self._schemas[record.id] = record
            elif isinstance(record, Channel):
                self._channels[record.id] = record
            elif isinstance(record, Message):
                counts[record.channel_id] = counts.get(record.channel_id, 0) + 1
                self.message_count += 1
                t = record.log_time
                self.start_ns = t if self.start_ns is None else min(self.start_ns, t)
                self.end_ns = t if self.end_ns is None else max(self.end_ns, t)
            elif isinstance(record, Metadata):
                self._take_metadata(record)
            elif isinstance(record, Statistics):
                self.statistics = record
            elif isinstance(record, Footer):
                self.has_footer = True
        return counts

    def _take_channels(self, counts):
        for channel in self._channels.values():
            schema = self._schemas.get(channel.schema_id)
            qos = []
            text = channel.metadata.get('offered_qos_profiles', '')
            if text:
                qos = load_yaml(text, f'{self.mcap_path}: offered_qos_profiles of channel '
                                      f'{channel.topic!r}') or []
            self.topics[channel.topic] = TopicInfo(
                name=channel.topic,
                type_name=schema.name if schema else '',
                qos=qos,
                type_hash=channel.metadata.get('topic_type_hash', ''),
                message_count=counts.get(channel.id, 0),
                schema_encoding=schema.encoding if schema else '',
                schema_text=schema.data.decode('utf-8', 'replace') if schema else '')

    def _take_metadata(self, record):
        if record.name == CONFIG_METADATA_NAME:
            self.rbd_metadata = dict(record.metadata)
            self.config = load_yaml(record.metadata.get('config_yaml', ''),
                                    f'{self.mcap_path}: the rbd_ros configuration record') or {}
            if not isinstance(self.config, dict):
                raise RecordingError(
                    f'{self.mcap_path}: the rbd_ros configuration record is not a YAML map '
                    f'(a {type(self.config).__name__})')
        elif record.name == RUN_METADATA_NAME:
            self.run_metadata = dict(record.metadata)
        elif record.name == 'rosbag2':
            self.rosbag2_metadata = load_yaml(record.metadata.get('serialized_metadata', ''),
                                              f'{self.mcap_path}: the rosbag2 metadata record')


def _find_mcap(path):
    """Return ``(mcap_path, metadata_yaml_dict_or_None)`` for a bag directory or file."""
    if not os.path.lexists(path):
        raise RecordingError(f'bag {path!r} does not exist')
    if os.path.isdir(path):
        meta_path = os.path.join(path, 'metadata.yaml')
        meta = _load_metadata_yaml(meta_path) if os.path.isfile(meta_path) else None
        if meta is not None:
            info = meta['rosbag2_bagfile_information']
            storage = info.get('storage_identifier', 'mcap')
            if storage != 'mcap':
                raise RecordingError(
                    f'bag {path!r} uses storage {storage!r}; only mcap bags can be read')
            files = _bag_file_paths(path, meta_path, info)
            if files:
                return files[0], meta
        candidates = sorted(glob.glob(os.path.join(path, '*.mcap')))
        if not candidates:
            raise RecordingError(f'bag directory {path!r} holds no .mcap file')
        return candidates[0], meta
    parent = os.path.dirname(os.path.abspath(path))
    meta_path = os.path.join(parent, 'metadata.yaml')
    meta = None
    if os.path.isfile(meta_path):
        meta = _load_metadata_yaml(meta_path)
        info = meta['rosbag2_bagfile_information']
        names = [os.path.basename(f) for f in _bag_file_paths(parent, meta_path, info)]
        if os.path.basename(path) not in names:
            meta = None
    return path, meta


def _bag_file_paths(bag_dir, meta_path, info):
    """
    Return the storage files ``metadata.yaml`` names, as paths inside ``bag_dir``.

    :raises RecordingError: a path is not a plain relative name inside the bag directory
        (absolute, with ``..``, or resolving outside it through a symlink).
    """
    names = list(info.get('relative_file_paths') or [])
    for entry in info.get('files') or []:
        names.append(entry.get('path') if isinstance(entry, dict) else entry)
    root = os.path.realpath(bag_dir)
    out = []
    for name in names:
        bad = None
        if not isinstance(name, str) or not name:
            bad = 'is not a file name'
        elif os.path.isabs(name) or '..' in name.replace('\\', '/').split('/'):
            bad = 'leaves the bag directory'
        else:
            full = os.path.join(bag_dir, name)
            if os.path.commonpath([root, os.path.realpath(full)]) != root:
                bad = 'resolves outside the bag directory'
        if bad:
            raise RecordingError(
                f'{meta_path}: storage file path {name!r} {bad}; only files inside the bag '
                'directory are read')
        if full not in out:
            out.append(full)
    return out


def _load_metadata_yaml(meta_path):
    try:
        with open(meta_path, encoding='utf-8', errors='replace') as f:
            text = f.read(MAX_YAML_BYTES + 1)
    except OSError as exc:
        raise RecordingError(f'{meta_path}: cannot be read ({_os_error_text(exc)})') from None
    meta = load_yaml(text, meta_path)
    if not isinstance(meta, dict) or not isinstance(
            meta.get('rosbag2_bagfile_information'), dict):
        raise RecordingError(f'{meta_path}: not a rosbag2 metadata file')
    return meta


def open_bag(path: Union[str, os.PathLike]) -> Bag:
    """
    Open a recording (a bag directory or an ``.mcap`` file), finalised or not.

    :raises RecordingError: missing, empty, not MCAP, or unreadable before the first record.
    """
    path = os.fspath(path)
    mcap_path, meta = _find_mcap(path)
    try:
        size = os.path.getsize(mcap_path)
        with open(mcap_path, 'rb') as f:
            magic = f.read(len(MCAP_MAGIC))
    except OSError as exc:
        raise RecordingError(f'{mcap_path}: cannot be read ({_os_error_text(exc)})') from None
    if size == 0:
        raise RecordingError(f'{mcap_path}: file is empty (0 bytes), not an MCAP recording')
    if magic != MCAP_MAGIC:
        raise RecordingError(f'{mcap_path}: not an MCAP file (bad magic bytes)')
    bag = Bag(path, mcap_path, meta)
    bag._scan()
    if not bag.has_footer:
        bag.notes.append(f'{mcap_path}: no summary/footer: the recording was not finalised')
    elif bag.statistics is None:
        bag.notes.append(f'{mcap_path}: the summary has no statistics record')
    if meta is None:
        bag.notes.append(f'{path}: no metadata.yaml next to the MCAP file')
    return bag
