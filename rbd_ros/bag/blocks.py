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
A sample's messages into the open MCAP chunk at once (a part of :class:`BagWriter`).

mcap's ``Writer.add_message`` costs ~15 µs a message, all of it Python: a Message record
packed, an entry appended to its channel's message index, its channel's count in the
statistics. A world of 100 bodies records ~400 messages a sample, 100 samples a sim second.
Here a sample (a *block*: messages on known channels, all at one log time) costs a few numpy
operations whatever its size:

- the Message records' headers are a packed numpy array of the block's :class:`Layout`
  (channels fixed; lengths and times written in), joined with the data;
- the block's message-index entries are kept as arrays (:class:`ChunkEntries`) and written
  when the chunk ends, through a :class:`LazyIndex` in the chunk builder's
  ``message_indices`` for each channel (so mcap writes them where and in the order it writes
  its own: the order in which the channels first appear in the chunk);
- the statistics' and the topics' counts are added per layout position when they are read
  (:meth:`Layout.settle`), each channel entered in the statistics at its first message.

A chunk's end (:class:`ChunkEnds`) compresses it, checksums it and writes it, with its
message indexes, on a thread of its own (zstd and zlib release the GIL: ~1.5 ms a MiB of
chunk, a quarter of a world's sample), in order, while the node steps on; what mcap's
``Writer.flush`` does, the same bytes, and the same chunk index in the summary.

The file is the same, byte for byte, as ``Writer.add_message`` of each message in turn and
``Writer.flush`` at each chunk's end (a test compares them). Only mcap 1.6's writer internals
are used (:func:`mcap_internals`); a writer without them gets ``add_message`` of each and
``Writer.flush``.
"""

from concurrent.futures import ThreadPoolExecutor
import os
import struct
import zlib

from mcap import writer as mcap_writer
from mcap._chunk_builder import ChunkBuilder
from mcap.data_stream import RecordBuilder
from mcap.records import Chunk, ChunkIndex, Statistics
import numpy as np

#: A Message record's fixed part: opcode, record length, channel id, sequence, log time,
#: publish time (the data follows), as mcap's ``Message.write`` packs it (no padding).
MESSAGE_HEADER = np.dtype([('opcode', 'u1'), ('length', '<u8'), ('channel', '<u2'),
                           ('sequence', '<u4'), ('log_time', '<u8'), ('publish_time', '<u8')])
_HEADER_BYTES = MESSAGE_HEADER.itemsize  # 31
_MESSAGE_OPCODE = 0x05
_INDEX_HEADER = struct.Struct('<BQHI')  # MessageIndex: opcode, length, channel, entries' bytes
_INDEX_OPCODE = 0x07
_ENTRY = np.dtype([('time', '<u8'), ('offset', '<u8')])


def mcap_internals(writer):
    """
    Return ``(chunk builder, statistics)`` of an mcap ``Writer`` (1.6), or None if it differs.

    :meth:`rbd_ros.bag.recording.BagWriter.write_many` adds records to them as
    ``Writer.add_message`` does.
    """
    chunk = getattr(writer, '_Writer__chunk_builder', None)
    stats = getattr(writer, '_Writer__statistics', None)
    if not isinstance(chunk, ChunkBuilder) or not isinstance(stats, Statistics) or not all(
            hasattr(chunk, name) for name in (
                'record_writer', 'message_indices', 'num_messages', 'message_start_time',
                'message_end_time')):
        return None
    return chunk, stats


def _chunk_internals(writer):
    """
    Return ``(chunk indexes, compression name, compress)`` of an mcap 1.6 ``Writer``, or None.

    None unless it writes as :class:`ChunkEnds` does: message indexes, chunk CRCs, no data
    section CRC, nothing held in its record builder.
    """
    names = ('chunk_indices', 'compression', 'index_types', 'enable_crcs', 'enable_data_crcs',
             'record_builder')
    values = [getattr(writer, f'_Writer__{name}', None) for name in names]
    indices, compression, index_types, crcs, data_crcs, records = values
    compressors = {mcap_writer.CompressionType.NONE: ('', None)}
    if mcap_writer.zstandard is not None:
        compressors[mcap_writer.CompressionType.ZSTD] = ('zstd', mcap_writer.zstandard.compress)
    if mcap_writer.lz4 is not None:
        compressors[mcap_writer.CompressionType.LZ4] = ('lz4', mcap_writer.lz4.frame.compress)
    if not isinstance(indices, list) or compression not in compressors \
            or index_types is None or not index_types & mcap_writer.IndexType.MESSAGE \
            or crcs is not True or data_crcs is not False \
            or not isinstance(records, RecordBuilder):
        return None
    return (indices, *compressors[compression])


class ChunkEnds:
    """
    Ends chunks as mcap's ``Writer.flush`` does, the compression and the writing on a thread.

    :meth:`end` takes the open chunk's records and message indexes from the chunk builder (on
    the caller's thread) and leaves the rest to the thread, one chunk after the other. Who
    writes anything else to the file first calls :meth:`drain`. A write that failed is
    :attr:`error` (raised by :meth:`drain` too); nothing is written after it.

    :param fsync: ``os.fsync`` the file after each chunk.
    """

    #: Chunks handed over and not yet written at most (then :meth:`end` waits for the oldest):
    #: one, so that a SIGKILL loses at most the chunk being written besides the open one (a
    #: chunk covers up to 1 s of sim time, hundreds of ms of wall time; its compression takes
    #: milliseconds, so the wait costs nothing).
    MAX_PENDING = 1

    def __init__(self, writer, stream, internals, fsync=False):
        self._stream, self._internals, self._fsync = stream, internals, fsync
        self._indices, self._compression, self._compress = _chunk_internals(writer)
        self._pool = None
        self._pending = []
        self.error = None

    @classmethod
    def of(cls, writer, stream, internals, fsync=False):
        """Return the chunk ends of ``writer``, or None if it has not the internals they use."""
        if internals is None or _chunk_internals(writer) is None:
            return None
        return cls(writer, stream, internals, fsync)

    def end(self):
        """End the open chunk (nothing without messages): hand it to the thread."""
        chunk, stats = self._internals
        if chunk.num_messages == 0:
            return
        stats.chunk_count += 1
        data = chunk.end()
        index = RecordBuilder()
        offsets = {}
        for channel, entries in chunk.message_indices.items():
            offsets[channel] = index.count
            entries.write(index)
        job = (data, chunk.message_start_time, chunk.message_end_time, index.end(), offsets)
        chunk.reset()
        while len(self._pending) >= self.MAX_PENDING:
            self._pending.pop(0).result()
        if self._pool is None:
            self._pool = ThreadPoolExecutor(1, thread_name_prefix='rbd_ros chunks')
        self._pending.append(self._pool.submit(self._write, *job))

    def _write(self, data, start_ns, end_ns, index, offsets):
        """Write one chunk and its message indexes; note its chunk index (the thread's)."""
        if self.error is not None:
            return
        try:
            compressed = data if self._compress is None else self._compress(data)
            record = RecordBuilder()
            Chunk(compression=self._compression, data=compressed, message_start_time=start_ns,
                  message_end_time=end_ns, uncompressed_crc=zlib.crc32(data),
                  uncompressed_size=len(data)).write(record)
            record = record.end()
            stream = self._stream
            chunk_start = stream.tell()
            stream.write(record)
            index_start = stream.tell()
            stream.write(index)
            self._indices.append(ChunkIndex(
                message_start_time=start_ns, message_end_time=end_ns,
                chunk_start_offset=chunk_start, chunk_length=len(record),
                message_index_offsets={channel: index_start + offset
                                       for channel, offset in offsets.items()},
                message_index_length=len(index), compression=self._compression,
                compressed_size=len(compressed), uncompressed_size=len(data)))
            stream.flush()
            if self._fsync:
                os.fsync(stream.fileno())
        except OSError as exc:
            self.error = exc

    def drain(self):
        """Wait until every chunk handed over is written; raise the OSError of one that was not."""
        while self._pending:
            self._pending.pop(0).result()
        if self.error is not None:
            raise self.error

    def close(self):
        """Drain (errors are :attr:`error`'s) and stop the thread."""
        try:
            while self._pending:
                self._pending.pop(0).result()
        finally:
            if self._pool is not None:
                self._pool.shutdown()
                self._pool = None


class Layout:
    """
    The channels of a block's messages, in order (a sample's topics; a channel may repeat).

    :param entries: per message, the writer's topic entry (``channel_id``, ``count``).
    """

    def __init__(self, entries):
        self.entries = entries
        self.channels = np.array([entry.channel_id for entry in entries], dtype=np.int64)
        self.headers = np.zeros(len(entries), dtype=MESSAGE_HEADER)
        self.headers['opcode'] = _MESSAGE_OPCODE
        self.headers['channel'] = self.channels
        self.counts = np.zeros(len(entries), dtype=np.int64)  # not yet settled
        self._in_stats = np.zeros(len(entries), dtype=bool)

    def enter_stats(self, stats, start, end):
        """Enter the channels of ``[start, end)`` not yet in ``stats``, in order (count 0)."""
        seen = self._in_stats[start:end]
        if seen.all():
            return
        counts = stats.channel_message_counts
        for channel in self.channels[start:end][~seen].tolist():
            counts[channel] += 0  # a defaultdict: the key now, at its first message's place
        seen[:] = True

    def settle(self, stats):
        """Add the counts written since the last settle to ``stats`` and the topics."""
        counts = stats.channel_message_counts
        for i in np.flatnonzero(self.counts).tolist():
            n = int(self.counts[i])
            counts[int(self.channels[i])] += n
            self.entries[i].count += n
        self.counts[:] = 0


class LazyIndex:
    """
    A channel's message index in the chunk builder, its entries written when the chunk ends.

    ``records``: the entries that mcap's ``add_message`` appended (messages written one by
    one); the blocks' are in :class:`ChunkEntries`. Truthy, as mcap's check of an index is.
    """

    def __init__(self, channel_id, chunk, records=None):
        self.channel_id, self._chunk = channel_id, chunk
        self.records = [] if records is None else records

    def write(self, stream):
        """Write this channel's MessageIndex record (entries in the order written)."""
        stream.write(self._chunk.record(self.channel_id, self.records))


class ChunkEntries:
    """The message-index entries of the blocks written to the open chunk."""

    def __init__(self):
        self._channels, self._offsets, self._times = [], [], []
        self._seen = {}  # layout -> positions whose channel has a LazyIndex in this chunk
        self._grouped = None

    def add(self, layout, start, end, offsets, time_ns, indices):
        """
        Note the block ``layout[start:end]`` at ``offsets`` (its records' offsets in the chunk).

        ``indices``: the chunk builder's ``message_indices``; each channel gets its
        :class:`LazyIndex` there at its first message in the chunk.
        """
        seen = self._seen.get(layout)
        if seen is None:
            seen = self._seen[layout] = np.zeros(len(layout.channels), dtype=bool)
        part = seen[start:end]
        if not part.all():
            for channel in layout.channels[start:end][~part].tolist():
                index = indices.get(channel)
                if not isinstance(index, LazyIndex):  # new, or mcap's (its entries kept)
                    indices[channel] = LazyIndex(channel, self,
                                                 None if index is None else index.records)
            part[:] = True
        self._channels.append(layout.channels[start:end])
        self._offsets.append(offsets)
        self._times.append(np.full(end - start, time_ns, dtype=np.uint64))
        self._grouped = None

    def record(self, channel, records):
        """Return the MessageIndex record of ``channel``: the blocks' entries and ``records``."""
        if self._grouped is None:
            self._group()
        entries, spans = self._grouped
        start, count = spans.get(channel, (0, 0))
        body = entries[16 * start:16 * (start + count)]
        if records:  # messages written one by one too: every entry, in offset order
            merged = sorted(np.frombuffer(body, dtype=_ENTRY).tolist() + list(records),
                            key=lambda entry: entry[1])
            count = len(merged)
            body = struct.pack(f'<{2 * count}Q', *(v for entry in merged for v in entry))
        return _INDEX_HEADER.pack(_INDEX_OPCODE, 6 + 16 * count, channel, 16 * count) + body

    def _group(self):
        """Sort every entry by channel (stable: each channel's in offset order)."""
        channels = np.concatenate(self._channels) if self._channels else \
            np.zeros(0, dtype=np.int64)
        order = np.argsort(channels, kind='stable')
        entries = np.empty(len(order), dtype=_ENTRY)
        if len(order):
            entries['time'] = np.concatenate(self._times)[order]
            entries['offset'] = np.concatenate(self._offsets)[order]
        unique, starts, counts = np.unique(channels[order], return_index=True,
                                           return_counts=True)
        self._grouped = (entries.tobytes(), dict(zip(unique.tolist(),
                                                     zip(starts.tolist(), counts.tolist()))))


def add_block(internals, chunk_entries, layout, start, end, datas, lengths, time_ns):
    """
    Add the Message records of ``layout[start:end]`` (data ``datas``) to the open chunk.

    As mcap's ``Writer.add_message`` of each would, but for the counts (the layout's, until
    :meth:`Layout.settle`). ``lengths``: the data's lengths (int64 array).
    """
    chunk, stats = internals
    records = chunk.record_writer
    headers = layout.headers[start:end]
    headers['length'] = lengths + (_HEADER_BYTES - 9)
    headers['log_time'] = time_ns
    headers['publish_time'] = time_ns
    sizes = lengths + _HEADER_BYTES
    offsets = np.cumsum(sizes) - sizes + records.count
    chunk_entries.add(layout, start, end, offsets, time_ns, chunk.message_indices)
    layout.enter_stats(stats, start, end)
    layout.counts[start:end] += 1
    raw = headers.tobytes()
    parts = [None] * (2 * (end - start))
    parts[::2] = [raw[i:i + _HEADER_BYTES] for i in range(0, len(raw), _HEADER_BYTES)]
    parts[1::2] = datas
    records.write(b''.join(parts))
    n = end - start
    for owner, count in ((chunk, chunk.num_messages), (stats, stats.message_count)):
        owner.message_start_time = time_ns if count == 0 else \
            min(owner.message_start_time, time_ns)
        owner.message_end_time = max(owner.message_end_time, time_ns)
    chunk.num_messages += n
    stats.message_count += n
