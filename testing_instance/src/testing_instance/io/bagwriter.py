"""The runner's rosbag writer: the bytes rosbag.Bag writes (format 2.0, uncompressed chunks
of 768 kB, their index records, the connections and chunk infos at the end, the file header
rewritten at close), with far less Python per message.

rosbag.Bag.write builds each record's header from a dict of packed fields, compares
genpy.Time objects (three ``__cmp__`` calls a message), keeps an index entry object for
every message (the runner's old ``LeanBag`` cleared them) and writes a record as four or
five small writes, each a seek and position check on the file. In a recorded 60 s sensors
scenario that was 47 us of the world's thread a message under cProfile (19,403 messages).
Here a chunk is built in memory: a message is one serialization, one precomputed record
prefix, one struct pack and one index tuple; the chunk goes to the file in one write when
it is full. ``test/unit/test_mcap_io.py`` compares the file with rosbag.Bag's, byte for byte.

The chunk being built is in memory: a writer killed mid-chunk leaves the chunks before it
(rosbag's reindex, ``mcap_io._reindex``, cuts a partial last chunk off anyway). A failing
write (a full filesystem) raises OSError at the chunk's end, in ``write`` or ``close``.
"""
import io
import struct

__all__ = ['BagWriter', 'CHUNK_THRESHOLD']

VERSION = b'#ROSBAG V2.0\n'
FILE_HEADER_LENGTH = 4096
CHUNK_THRESHOLD = 768 * 1024           # rosbag.Bag's default chunk_threshold
OP_MSG_DATA, OP_FILE_HEADER, OP_INDEX_DATA, OP_CHUNK, OP_CHUNK_INFO, OP_CONNECTION = \
    2, 3, 4, 5, 6, 7

_U32 = struct.Struct('<L')
_TIME_LEN = struct.Struct('<LLL')        # secs, nsecs, then the data's length
_ENTRY = struct.Struct('<LLL')           # an index entry: secs, nsecs, offset in the chunk
_PAIR = struct.Struct('<LL')


def _field(k, v):
    k = k.encode() if isinstance(k, str) else k
    v = v.encode() if isinstance(v, str) else v
    return _U32.pack(len(k) + 1 + len(v)) + k + b'=' + v


def _header(fields):
    """A record header as rosbag writes it: its length, then each field."""
    body = b''.join(_field(k, v) for k, v in fields)
    return _U32.pack(len(body)) + body


def _time(secs, nsecs):
    return _PAIR.pack(secs, nsecs)


class _Connection(object):
    __slots__ = ('id', 'topic', 'header', 'prefix')

    def __init__(self, conn_id, topic, msg):
        cls = msg.__class__
        self.id = conn_id
        self.topic = topic
        self.header = [('topic', topic), ('type', cls._type), ('md5sum', cls._md5sum),
                       ('message_definition', cls._full_text)]
        # (genpy message classes: _type, _md5sum, _full_text)
        # a message data record up to its time: header length, op, conn, 'time=' field's
        # length and name (the time, the data's length and the data follow)
        conn = _U32.pack(conn_id)
        body_len = (4 + 3 + 1) + (4 + 5 + 4) + (4 + 5 + 8)
        self.prefix = (_U32.pack(body_len) + _field('op', bytes([OP_MSG_DATA])) +
                       _field('conn', conn) + _U32.pack(5 + 8) + b'time=')

    def record(self):
        """The connection record (rosbag writes the same one in the chunk and at the end)."""
        return (_header([('op', bytes([OP_CONNECTION])), ('topic', self.topic),
                         ('conn', _U32.pack(self.id))]) + _header(self.header))


class BagWriter(object):
    """Writes a rosbag file at ``path``: ``write(topic, msg, t)`` (t: a rospy/genpy Time),
    ``close()``. ``_file`` is the open file (the recording's guards look at it)."""

    def __init__(self, path, chunk_threshold=CHUNK_THRESHOLD):
        self._file = open(path, 'w+b')
        self._chunk_threshold = chunk_threshold
        self._conns = {}                 # topic -> _Connection
        self._chunks = []                # (pos, start, end, [(conn id, count)])
        self._buf = io.BytesIO()
        self._chunk = None               # bytearray of the open chunk's data
        self._file.write(VERSION)
        self._file.write(self._file_header(0, 0, 0))
        self._pos = len(VERSION) + 4 + 4 + FILE_HEADER_LENGTH   # header: its len, data len

    @staticmethod
    def _file_header(index_pos, conn_count, chunk_count):
        fields = [('op', bytes([OP_FILE_HEADER])), ('index_pos', struct.pack('<Q', index_pos)),
                  ('conn_count', _U32.pack(conn_count)), ('chunk_count', _U32.pack(chunk_count))]
        body = b''.join(_field(k, v) for k, v in fields)
        pad = FILE_HEADER_LENGTH - len(body)
        return _U32.pack(len(body)) + body + _U32.pack(pad) + b' ' * pad

    def write(self, topic, msg, t):
        if self._file is None:
            raise ValueError('I/O operation on closed bag')
        secs, nsecs = t.secs, t.nsecs
        when = (secs, nsecs)
        chunk = self._chunk
        if chunk is None:
            chunk = self._chunk = bytearray()
            self._start = self._end = when
            self._index = {}             # conn id -> [(secs, nsecs, offset)], first-use order
            self._ordered = {}
        c = self._conns.get(topic)
        if c is None:
            c = self._conns[topic] = _Connection(len(self._conns), topic, msg)
            chunk += c.record()
        buf = self._buf
        buf.seek(0)
        buf.truncate(0)
        msg.serialize(buf)
        data = buf.getvalue()
        entries = self._index.get(c.id)
        if entries is None:
            entries = self._index[c.id] = []
            self._ordered[c.id] = True
        elif when < entries[-1][:2]:
            self._ordered[c.id] = False
        entries.append((secs, nsecs, len(chunk)))
        chunk += c.prefix
        chunk += _TIME_LEN.pack(secs, nsecs, len(data))
        chunk += data
        if when > self._end:
            self._end = when
        elif when < self._start:
            self._start = when
        if len(chunk) > self._chunk_threshold:
            self._write_chunk()

    def _write_chunk(self):
        chunk, self._chunk = self._chunk, None
        size = _U32.pack(len(chunk))
        out = bytearray(_header([('op', bytes([OP_CHUNK])), ('compression', 'none'),
                                 ('size', size)]))
        out += size
        out += chunk
        counts = []
        for conn_id, entries in self._index.items():
            if not self._ordered[conn_id]:
                entries.sort(key=lambda e: (e[0], e[1]))       # stable: as rosbag's insort
            out += _header([('op', bytes([OP_INDEX_DATA])), ('conn', _U32.pack(conn_id)),
                            ('ver', _U32.pack(1)), ('count', _U32.pack(len(entries)))])
            out += _U32.pack(12 * len(entries))
            out += b''.join(_ENTRY.pack(*e) for e in entries)
            counts.append((conn_id, len(entries)))
        self._chunks.append((self._pos, self._start, self._end, counts))
        self._file.write(out)
        self._pos += len(out)

    def close(self):
        """Write the open chunk, the connections and chunk infos, the file header again;
        close the file. Closing a closed writer does nothing."""
        f = self._file
        if f is None:
            return
        try:
            if self._chunk is not None:
                self._write_chunk()
            index_pos = self._pos
            out = bytearray()
            for c in self._conns.values():
                out += c.record()
            for pos, start, end, counts in self._chunks:
                out += _header([('op', bytes([OP_CHUNK_INFO])), ('ver', _U32.pack(1)),
                                ('chunk_pos', struct.pack('<Q', pos)),
                                ('start_time', _time(*start)), ('end_time', _time(*end)),
                                ('count', _U32.pack(len(counts)))])
                out += _U32.pack(8 * len(counts))
                out += b''.join(_PAIR.pack(*p) for p in counts)
            f.write(out)
            f.seek(len(VERSION))
            f.write(self._file_header(index_pos, len(self._conns), len(self._chunks)))
        finally:
            self._file = None
            f.close()
