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
Reading recordings back: :func:`open_bag` and :class:`Bag` (finalised or not, untrusted).

Everything read back from a bag is treated as untrusted: YAML texts are parsed by
:func:`rbd_ros.bag.format.load_yaml`, and the files ``metadata.yaml`` names must lie inside the
bag directory. A run killed with SIGKILL leaves a file whose completed chunks stay readable:
:func:`open_bag` reads it and says it was not finalised.
"""

import dataclasses
import glob
import os
import struct
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional, Tuple, Union

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import (Attachment, Channel, Footer, Header, Message, Metadata, Schema,
                          Statistics)
from mcap.stream_reader import StreamReader
from rbd_ros.bag.format import (CONFIG_METADATA_NAME, load_yaml, MAX_YAML_BYTES, MCAP_MAGIC,
                                os_error_text, RUN_METADATA_NAME)
from rbd_ros.core.errors import RecordingError


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
    :func:`rbd_ros.sim.param_renames.recorded_parameters`; None for a bag without our
    configuration),
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
                                    f'{self.mcap_path}: the rbd_ros configuration record',
                                    configuration=True) or {}
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
        raise RecordingError(f'{meta_path}: cannot be read ({os_error_text(exc)})') from None
    meta = load_yaml(text, meta_path)
    if not isinstance(meta, dict) or not isinstance(
            meta.get('rosbag2_bagfile_information'), dict):
        raise RecordingError(f'{meta_path}: not a rosbag2 metadata file')
    return meta


def split_runs(messages: Iterable[RawMessage]) -> List[List[RawMessage]]:
    """
    Return ``messages`` (file order) cut into the runs between ``~/reset`` calls.

    The node writes in sim time order and a reset sends sim time back to 0, so a message
    earlier than the one before it starts a new run (replay steps each from the initial state,
    plot draws the last); so does a second message of one topic at t = 0 (a reset within the
    first publish period: an output's t = 0 sample again, or an input taking effect at 0
    again, each written once a run otherwise).
    """
    runs = [[]]
    for raw, new_run in _run_starts(messages):
        if new_run:
            runs.append([])
        runs[-1].append(raw)
    return runs


def _run_starts(messages: Iterable[RawMessage]) -> Iterator[Tuple[RawMessage, bool]]:
    """Yield each message and whether it starts a run after a reset (its time went back)."""
    latest, at_zero = -1, set()
    for raw in messages:
        t = raw.log_time_ns
        new_run = t < latest or (t == 0 and raw.topic in at_zero)
        if new_run:
            at_zero = set()
        if t == 0:
            at_zero.add(raw.topic)
        latest = t
        yield raw, new_run


def run_starts(messages: Iterable[RawMessage]) -> List[int]:
    """Return the index of the first message of each run after a reset (see split_runs)."""
    return [index for index, (_, new_run) in enumerate(_run_starts(messages)) if new_run]


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
        raise RecordingError(f'{mcap_path}: cannot be read ({os_error_text(exc)})') from None
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
