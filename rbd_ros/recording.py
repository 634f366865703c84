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
profile ``ros2``; one ``ros2msg`` schema per type (:mod:`rbd_ros.schemas`); ``cdr`` channels
whose metadata holds ``offered_qos_profiles`` (v9 YAML, string enums) and ``topic_type_hash``;
chunks with message indexes; a summary with chunk indexes and a statistics record; and a
``rosbag2`` metadata record with ``serialized_metadata`` (written at open and at close, the last
one wins).  The node's full configuration is stored as the MCAP metadata record ``rbd_ros``, so
the recording alone is enough to replay it.

Message log times are sim time in integer nanoseconds.  A chunk is closed and flushed to the
operating system before it covers more than ``chunk_duration_ns`` of sim time (1 s by default)
or ``chunk_bytes`` of data, so a run killed with SIGKILL leaves a file whose completed chunks
stay readable (:func:`open_bag` reads such a file and says it was not finalised).

This module does not import rclpy: the node serialises messages with
``rclpy.serialization.serialize_message`` and hands the CDR bytes to :meth:`BagWriter.write`.
"""

import dataclasses
import glob
import os
import shutil
import struct
import sys
import time

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Footer, Header, Message, Metadata, Schema, Statistics
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer
from rbd_ros import __version__
from rbd_ros import schemas
from rbd_ros.core.errors import RbdError, RecordingError
import yaml

#: Name of the MCAP metadata record holding the node configuration.
CONFIG_METADATA_NAME = 'rbd_ros'
#: Version of the content of the ``rbd_ros`` metadata record.
CONFIG_FORMAT = 'rbd_ros.recording/1'
#: rosbag2 metadata version written (Jazzy).
ROSBAG2_METADATA_VERSION = 9

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


def normalize_qos(qos):
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


class _Dumper(yaml.SafeDumper):
    """A YAML dumper that never writes anchors or aliases (rosbag2 writes none)."""

    def ignore_aliases(self, data):
        return True


# rosbag2 (yaml-cpp) writes an empty custom_data as '~'; write null the same way.
_Dumper.add_representer(
    type(None), lambda dumper, _: dumper.represent_scalar('tag:yaml.org,2002:null', '~'))


def _dump_yaml(data):
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=False)


def _qos_yaml(profiles):
    return _dump_yaml(profiles)


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
    :param overwrite: replace an existing bag directory (only one that looks like a bag: holding
        ``metadata.yaml`` or ``*.mcap`` files and nothing else); otherwise an existing path is a
        :class:`RecordingError`.
    :param compression: chunk compression, ``'zstd'`` (default), ``'lz4'`` or ``'none'``.
    :param chunk_duration_ns: a chunk is closed before it would cover this much sim time.
    :param chunk_bytes: a chunk is closed once it holds this many bytes of message data.
    :param fsync: also ``os.fsync`` after each chunk (survives power loss, costs time).
    :param extra_metadata: more ``str -> str`` entries for the ``rbd_ros`` record.
    :raises RecordingError: the path exists, cannot be created or written.
    """

    def __init__(self, path, config=None, *, overwrite=False, compression='zstd',
                 chunk_duration_ns=1_000_000_000, chunk_bytes=1 << 20, fsync=False,
                 extra_metadata=None):
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
        self._prepare_directory(overwrite)
        try:
            self._stream = open(self.mcap_path, 'xb')
            self._mcap = Writer(
                self._stream, chunk_size=1 << 62, compression=_COMPRESSION[compression])
            # The mcap Writer ends a chunk only when it reaches chunk_size; we end chunks on
            # sim time and size ourselves through its (private) chunk finaliser.
            self._finalize_chunk = self._mcap._Writer__finalize_chunk
            self._mcap.start(profile='ros2', library=f'rbd_ros-{__version__}')
            self._mcap.add_metadata(CONFIG_METADATA_NAME, self._config_record(extra_metadata))
            self._mcap.add_metadata('rosbag2', {'serialized_metadata': self._metadata_yaml()})
            self._stream.flush()
        except OSError as exc:
            self._fail(exc)

    # ------------------------------------------------------------------ setup
    def _prepare_directory(self, overwrite):
        if os.path.lexists(self.path):
            if not overwrite:
                raise RecordingError(
                    f'record_path {self.path!r} already exists; refusing to overwrite a bag '
                    "(choose a new name, put '{stamp}' in it, or allow overwriting)")
            if not os.path.isdir(self.path):
                raise RecordingError(
                    f'record_path {self.path!r} exists and is not a bag directory; '
                    'not overwriting it')
            entries = os.listdir(self.path)
            if any(not (e == 'metadata.yaml' or e.endswith('.mcap')) for e in entries):
                raise RecordingError(
                    f'record_path {self.path!r} exists and holds files that are not part of a '
                    'bag; not overwriting it')
            shutil.rmtree(self.path)
        try:
            os.makedirs(self.path)
        except OSError as exc:
            raise RecordingError(
                f'record_path {self.path!r}: cannot create the bag directory '
                f'({_os_error_text(exc)})') from None

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
    def closed(self):
        """Return whether :meth:`close` has been called."""
        return self._closed

    @property
    def failed(self):
        """Return the :class:`RecordingError` that stopped the recording, or None."""
        return self._failed

    def add_topic(self, topic, type_name, qos=None):
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
        try:
            definition = schemas.message_definition(type_name)
        except ValueError as exc:
            raise RecordingError(str(exc)) from None
        type_hash = schemas.type_hash(type_name)
        profile = normalize_qos(qos)
        try:
            schema_id = self._schema_ids.get(type_name)
            if schema_id is None:
                schema_id = self._mcap.register_schema(type_name, 'ros2msg', definition)
                self._schema_ids[type_name] = schema_id
            channel_id = self._mcap.register_channel(
                topic, 'cdr', schema_id,
                {'offered_qos_profiles': _qos_yaml([profile]), 'topic_type_hash': type_hash})
        except OSError as exc:
            self._fail(exc)
        self._topics[topic] = _Topic(topic, type_name, profile, type_hash, channel_id)

    def write(self, topic, data, log_time_ns, publish_time_ns=None):
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

    def flush(self):
        """End the current chunk and hand it to the operating system."""
        self._check_open()
        if self._chunk_messages:
            self._end_chunk()

    def close(self):
        """
        Finalise the bag; idempotent.

        Writes the last chunk, the ``rosbag2`` record, the summary (statistics, indexes), the
        footer, then ``metadata.yaml``.  After a failure it only releases the file.
        """
        if self._closed:
            return
        self._closed = True
        if self._failed is not None:
            self._release()
            return
        try:
            if self._chunk_messages:
                self._end_chunk(flush=False)
            self._mcap.add_metadata('rosbag2', {'serialized_metadata': self._metadata_yaml()})
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

    def _end_chunk(self, flush=True):
        try:
            self._finalize_chunk()
            if flush:
                self._stream.flush()
                if self._fsync:
                    os.fsync(self._stream.fileno())
        except OSError as exc:
            self._fail(exc)
        self._chunk_messages = 0
        self._chunk_bytes = 0

    def metadata(self):
        """Return the rosbag2 ``BagMetadata`` (v9) of what has been written, as a dict."""
        start = self._start_ns or 0
        duration = self._end_ns - start if self._message_count else 0
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
        return {'rosbag2_bagfile_information': {
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
        }}

    def _metadata_yaml(self):
        return _dump_yaml(self.metadata())


# ====================================================================== reading
@dataclasses.dataclass(frozen=True)
class TopicInfo:
    """One recorded topic: name, type, offered QoS profiles, RIHS01 hash, message count."""

    name: str
    type_name: str
    qos: list
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
    (the node parameters, or None for a bag without our configuration), ``rbd_metadata`` (the
    ``rbd_ros`` record), ``rosbag2_metadata`` (last ``rosbag2`` record, parsed),
    ``metadata_yaml`` (parsed ``metadata.yaml`` or None), ``statistics`` (the MCAP Statistics
    record or None), ``message_count``, ``start_ns``, ``end_ns``.
    """

    def __init__(self, path, mcap_path, metadata_yaml):
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
        self.statistics = None
        self.has_footer = False
        self.truncated = False
        self.message_count = 0
        self.start_ns = None
        self.end_ns = None
        self._schemas = {}
        self._channels = {}

    @property
    def finalised(self):
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

    def messages(self, topics=None):
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

    def decoded_messages(self, topics=None):
        """Yield ``(RawMessage, decoded)`` decoded with the stored schemas (no rclpy)."""
        decoders = {}
        for raw in self.messages(topics):
            decoder = decoders.get(raw.topic)
            if decoder is None:
                decoder = decoders[raw.topic] = self.decoder(raw.topic)
            yield raw, decoder(raw.data)

    def decoder(self, topic):
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
        for channel in self._channels.values():
            schema = self._schemas.get(channel.schema_id)
            qos = []
            text = channel.metadata.get('offered_qos_profiles', '')
            if text:
                try:
                    qos = yaml.safe_load(text) or []
                except yaml.YAMLError:
                    qos = []
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
            try:
                self.config = yaml.safe_load(record.metadata.get('config_yaml', '')) or {}
            except yaml.YAMLError as exc:
                raise RecordingError(
                    f'{self.mcap_path}: the rbd_ros configuration record is not valid YAML '
                    f'({exc})') from None
        elif record.name == 'rosbag2':
            try:
                self.rosbag2_metadata = yaml.safe_load(
                    record.metadata.get('serialized_metadata', ''))
            except yaml.YAMLError:
                self.rosbag2_metadata = None


def _find_mcap(path):
    """Return ``(mcap_path, metadata_yaml_dict_or_None)`` for a bag directory or file."""
    if not os.path.lexists(path):
        raise RecordingError(f'bag {path!r} does not exist')
    if os.path.isdir(path):
        meta_path = os.path.join(path, 'metadata.yaml')
        meta = _load_metadata_yaml(meta_path) if os.path.isfile(meta_path) else None
        if meta is not None:
            info = meta.get('rosbag2_bagfile_information', {}) or {}
            storage = info.get('storage_identifier', 'mcap')
            if storage != 'mcap':
                raise RecordingError(
                    f'bag {path!r} uses storage {storage!r}; only mcap bags can be read')
            files = info.get('relative_file_paths') or []
            if files:
                return os.path.join(path, files[0]), meta
        candidates = sorted(glob.glob(os.path.join(path, '*.mcap')))
        if not candidates:
            raise RecordingError(f'bag directory {path!r} holds no .mcap file')
        return candidates[0], meta
    parent = os.path.dirname(os.path.abspath(path))
    meta_path = os.path.join(parent, 'metadata.yaml')
    meta = None
    if os.path.isfile(meta_path):
        meta = _load_metadata_yaml(meta_path)
        info = (meta or {}).get('rosbag2_bagfile_information', {}) or {}
        if os.path.basename(path) not in (info.get('relative_file_paths') or []):
            meta = None
    return path, meta


def _load_metadata_yaml(meta_path):
    try:
        with open(meta_path, encoding='utf-8') as f:
            meta = yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as exc:
        raise RecordingError(f'{meta_path}: cannot be read as YAML ({exc})') from None
    if not isinstance(meta, dict) or 'rosbag2_bagfile_information' not in meta:
        raise RecordingError(f'{meta_path}: not a rosbag2 metadata file')
    return meta


def run_on_bag(prog, bag_path, verb, action):
    """
    Run ``action()`` for a command-line tool; every failure becomes one stderr line.

    :returns: ``(status, result)``: 0 and ``action()``'s result, 2 on any error (``prog: error:
        ...``; a corrupt file can fail anywhere in the decoders, so anything is caught), 130 on
        Ctrl-C.
    """
    try:
        return 0, action()
    except KeyboardInterrupt:
        print(f'{prog}: interrupted', file=sys.stderr)
        return 130, None
    except (RbdError, OSError) as exc:
        print(f'{prog}: error: {exc}', file=sys.stderr)
        return 2, None
    except Exception as exc:  # the one-line promise covers every decoder failure
        print(f'{prog}: error: {bag_path}: cannot be {verb} ({type(exc).__name__}: {exc})',
              file=sys.stderr)
        return 2, None


def open_bag(path):
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


def summary_of(mcap_path):
    """Return the MCAP summary read through the footer (None if there is none)."""
    with open(mcap_path, 'rb') as f:
        return make_reader(f).get_summary()
