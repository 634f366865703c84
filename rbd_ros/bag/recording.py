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
Recording to MCAP in the rosbag2 (Jazzy) bag layout (reading back: :mod:`rbd_ros.bag.reader`).

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

The format's constants and the YAML and QoS helpers are :mod:`rbd_ros.bag.format`'s; this
module also gives them, and the reader's :func:`open_bag` and :class:`Bag`, under the names it
has always had (``rbd_ros.bag.recording.open_bag`` is a documented path).

Message log times are sim time in integer nanoseconds.  A chunk is closed and flushed to the
operating system before it covers more than ``chunk_duration_ns`` of sim time (1 s by default)
or ``chunk_bytes`` of data, so a run killed with SIGKILL leaves a file whose completed chunks
stay readable (:func:`rbd_ros.bag.reader.open_bag` reads such a file and says it was not
finalised).
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
import importlib.metadata
from operator import itemgetter
import os
import re
import stat
import time
from typing import Any, Dict, Iterable, Mapping, Optional, Tuple, Union

from mcap.data_stream import RecordBuilder
from mcap.records import Channel, Schema
from mcap.writer import CompressionType, Writer
import numpy as np
from rbd_ros import __version__
from rbd_ros.bag import blocks
# The shared constants and the reader, here too under the names this module has always had
# (rbd_ros.bag.recording.open_bag, ...): the documented paths.
from rbd_ros.bag.format import (  # noqa: F401
    CONFIG_FORMAT, CONFIG_METADATA_NAME, DEFAULT_QOS, dump_yaml, INT64_MAX, load_yaml,
    MAX_YAML_BYTES, MCAP_MAGIC, normalize_qos, os_error_text, ROSBAG2_METADATA_VERSION,
    RUN_METADATA_NAME)
from rbd_ros.bag.reader import Bag, open_bag, RawMessage, TopicInfo  # noqa: F401
from rbd_ros.core.errors import RbdError, RecordingError
from rbd_ros.msgs import schemas
from rbd_ros.sim.params import PARAMETERS_BY_NAME, to_ns
import yaml

_COMPRESSION = {
    'none': CompressionType.NONE,
    '': CompressionType.NONE,
    'zstd': CompressionType.ZSTD,
    'lz4': CompressionType.LZ4,
}


# mcap's writer internals that write_many uses (here, so a test can take them away).
_mcap_internals = blocks.mcap_internals


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
        self._internals = None  # mcap internals for write_many (blocks.mcap_internals)
        self._chunk_ends = None
        self._layouts = {}  # write_many's topics -> their blocks.Layout
        self._chunk_entries = None  # write_many's message-index entries in the open chunk
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
            self._internals = _mcap_internals(self._mcap)
            # Chunks compressed and written on a thread (blocks.ChunkEnds), else by mcap.
            self._chunk_ends = blocks.ChunkEnds.of(self._mcap, self._stream, self._internals,
                                                   fsync)
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
                    f'({os_error_text(exc)})') from None
        try:
            os.makedirs(self.path, exist_ok=overwrite)
        except OSError as exc:
            raise RecordingError(
                f'record_path {self.path!r}: cannot create the bag directory '
                f'({os_error_text(exc)})') from None

    def _is_our_file_name(self, entry):
        return (entry in ('metadata.yaml', '.metadata.yaml.tmp')
                or re.fullmatch(re.escape(self.name) + r'_\d+\.mcap', entry) is not None)

    def _config_record(self, extra):
        try:  # the config's own rule for seconds -> ns (a config that breaks it records '')
            timestep_ns = str(to_ns(PARAMETERS_BY_NAME['timestep_s'],
                                    float(self._config['timestep_s'])))
        except (KeyError, TypeError, ValueError, RbdError):
            timestep_ns = ''
        record = {
            'format': CONFIG_FORMAT,
            'package_version': __version__,
            'config_yaml': yaml.safe_dump(self._config, sort_keys=True),
            'integrator': str(self._config.get('integrator', '')),
            'timestep_ns': timestep_ns,
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
            self._drain()
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
            channel_metadata = {'offered_qos_profiles': dump_yaml([profile]),
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
        entry = self._topic(topic)
        self._chunk_for(log_time_ns)
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

    def write_many(self, messages: Iterable[Tuple[str, bytes]], log_time_ns: int) -> None:
        """
        Append ``[(topic, CDR bytes)]``, in order, all at ``log_time_ns`` (a sample).

        The same file, byte for byte, as :meth:`write` of each in turn (a test compares
        them), at a few numpy operations a sample where the mcap writer's ``add_message``
        takes ~15 µs a message (a world of 100 bodies records ~400 messages a sample):
        :mod:`rbd_ros.bag.blocks`. An mcap whose writer does not have the internals it uses
        (:func:`rbd_ros.bag.blocks.mcap_internals`) gets :meth:`write` of each.
        """
        if self._failed is not None or self._closed:
            self._check_open()
        internals = self._internals
        if internals is None:
            for topic, data in messages:
                self.write(topic, data, log_time_ns)
            return
        messages = messages if isinstance(messages, list) else list(messages)
        topics = tuple(map(itemgetter(0), messages))
        layout = self._layouts.get(topics)
        if layout is None:  # every topic checked before anything is written
            layout = self._layouts[topics] = blocks.Layout([self._topic(t) for t in topics])
        datas = list(map(itemgetter(1), messages))
        lengths = np.fromiter(map(len, datas), dtype=np.int64, count=len(datas))
        start = 0
        while start < len(datas):
            self._chunk_for(log_time_ns)
            # As many as write() would put in this chunk: up to the first message before
            # which the chunk holds chunk_bytes (write() ends the chunk there).
            before = np.cumsum(lengths[start:]) - lengths[start:]
            end = start + max(1, int(np.searchsorted(
                before, self._chunk_bytes_max - self._chunk_bytes, side='left')))
            if self._chunk_entries is None:
                self._chunk_entries = blocks.ChunkEntries()
            blocks.add_block(internals, self._chunk_entries, layout, start, end,
                             datas[start:end], lengths[start:end], log_time_ns)
            n = end - start
            self._chunk_bytes += int(before[n - 1] + lengths[end - 1])
            self._chunk_messages += n
            self._message_count += n
            if self._start_ns is None:
                self._start_ns = log_time_ns
            if log_time_ns > self._end_ns:
                self._end_ns = log_time_ns
            start = end

    def _settle(self):
        """Add the counts of write_many's blocks to the statistics and the topics."""
        if self._internals is not None:
            for layout in self._layouts.values():
                layout.settle(self._internals[1])

    def _topic(self, topic):
        entry = self._topics.get(topic)
        if entry is None:
            raise RecordingError(f'topic {topic!r} was not added with add_topic() before write()')
        return entry

    def _chunk_for(self, log_time_ns):
        """End the open chunk if a message at ``log_time_ns`` may not go in it; note a start."""
        if self._chunk_ends is not None and self._chunk_ends.error is not None:
            self._fail(self._chunk_ends.error)  # a chunk's write failed on its thread
        if self._chunk_messages and (
                log_time_ns - self._chunk_start_ns >= self._chunk_ns
                or self._chunk_bytes >= self._chunk_bytes_max):
            self._end_chunk()
        if not self._chunk_messages:
            self._chunk_start_ns = log_time_ns

    def flush(self) -> None:
        """
        End the current chunk and hand everything written so far to the operating system.

        :raises RecordingError: the write failed (disk full, file size limit, ...).
        """
        self._check_open()
        if self._chunk_messages:
            self._end_chunk()
        try:
            self._drain()
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
            self._drain()
            if run_metadata is not None:
                self._mcap.add_metadata(
                    RUN_METADATA_NAME, {str(k): str(v) for k, v in run_metadata.items()})
            self._mcap.add_metadata('rosbag2', self._rosbag2_record())
            self._mcap.finish()
            self._stream.flush()
            os.fsync(self._stream.fileno())
            if self._chunk_ends is not None:
                self._chunk_ends.close()
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
            f'recording to {self.mcap_path!r} failed: {os_error_text(exc)}')
        raise self._failed from None

    def _drain(self):
        """Wait for the chunks on their thread (the file's writes in order); raise their error."""
        if self._chunk_ends is not None:
            self._chunk_ends.drain()

    def _release(self):
        if self._chunk_ends is not None:  # before the file closes under its thread
            self._chunk_ends.close()
        if self._stream is not None:
            try:
                self._stream.close()
            except OSError:
                pass

    def _end_chunk(self, fsync=True):
        """Write the open chunk with its message indexes and hand it to the OS (mcap's flush)."""
        self._defs_in_chunk_only = []  # the chunk carries them
        self._chunk_entries = None
        try:
            if self._chunk_ends is not None:  # compressed and written on their thread
                self._chunk_ends.end()
                if self._chunk_ends.error is not None:
                    raise self._chunk_ends.error
            else:
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
        self._settle()
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
        return {'serialized_metadata': dump_yaml(self.metadata())}

    def _metadata_yaml(self):
        """Return the text of ``metadata.yaml``: the BagMetadata under its wrapper key."""
        return dump_yaml({'rosbag2_bagfile_information': self.metadata()})
