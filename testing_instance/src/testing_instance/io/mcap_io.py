"""Recordings of a scenario run: rosbag (the default) or MCAP with ROS 1 encoding.

``open_writer(paths)`` gives an object with rosbag.Bag's writing API (``write(topic, msg,
t)``, ``close()``) for one path or a list of paths; a path ending in ``.mcap`` is written as
MCAP (profile ``ros1``, schema encoding ``ros1msg``, message encoding ``ros1``: what
Foxglove opens directly; the ``mcap`` and ``mcap-ros1-support`` packages), any other path as
a rosbag. ``--record run.bag --record run.mcap`` writes both from the same messages.

``open_reader(path)`` reads either kind back (the format is told by the file's first bytes,
not its name): ``read_messages(topics=None, raw=False)`` yields ``(topic, msg, t)`` in the
order of t (rospy.Time; ``raw=True``: the serialized bytes instead of msg). A file that is
neither, or is cut short, raises RecordingError with one line naming the file and what is
wrong.
"""
import errno
import io
import os

__all__ = ['open_writer', 'open_reader', 'RecordingError', 'is_mcap_path', 'MCAP_MAGIC',
           'BAG_MAGIC', 'McapWriter', 'GuardedWriter']

MCAP_MAGIC = b'\x89MCAP0\r\n'
BAG_MAGIC = b'#ROSBAG V2.0\n'


class RecordingError(Exception):
    """The recording cannot be read (missing, not a recording, truncated)."""


def _why(e):
    """An exception's text on one line ('cut short' when it has none: mcap's EndOfFile)."""
    text = ' '.join(str(e).split())
    return text or 'cut short'


def is_mcap_path(path):
    return str(path).lower().endswith('.mcap')


class McapWriter(object):
    """rosbag.Bag's writing API over an MCAP file with ROS 1 messages."""

    def __init__(self, path):
        from mcap_ros1.writer import Writer
        self.path = str(path)
        self._f = open(self.path, 'wb')
        self._w = Writer(self._f)

    def write(self, topic, msg, t=None):
        ns = t.to_nsec() if t is not None else None
        self._w.write_message(topic, msg, log_time=ns, publish_time=ns)

    def close(self):
        if self._w is not None:
            self._w.finish()
            self._f.close()
            self._w = None


class _Multi(object):
    def __init__(self, writers):
        self.writers = writers

    def write(self, topic, msg, t=None):
        for w in self.writers:
            w.write(topic, msg, t)

    def close(self):
        for w in self.writers:
            w.close()


def _one_writer(path):
    d = os.path.dirname(os.path.abspath(str(path)))
    os.makedirs(d, exist_ok=True)
    if is_mcap_path(path):
        return McapWriter(path)
    from .bagwriter import BagWriter       # rosbag.Bag's bytes, less Python a message
    return BagWriter(str(path))


def open_writer(paths):
    """A writer for one path (str) or several (list): .mcap -> MCAP, else rosbag."""
    if isinstance(paths, (str, bytes, os.PathLike)):
        paths = [paths]
    writers = [_one_writer(p) for p in paths]
    return writers[0] if len(writers) == 1 else _Multi(writers)


class GuardedWriter(object):
    """The runner's recording: rosbag.Bag's writing API over every ``--record`` path that
    never raises once open, so that a storage fault costs the recording, not the run.

    - A write that fails (``ENOSPC`` on a full filesystem, ``EIO``...) stops that file; its
      message and sim time are kept in ``problems``. At ``close()`` a rosbag cut short is
      reindexed in place (rosbag's own reindex truncates the partial chunk, which frees the
      room its index needs), so what was written before the fault stays readable.
    - A file whose folder is removed while it is written (Linux keeps the open file) is
      written to the end and saved, whole and indexed, to ``salvage_dir`` at ``close()``
      (default: $SCENARIO_SALVAGE_DIR, else <tmp>/scenario_salvage).

    ``problems`` holds one line per fault, naming the file: the runner ends the run as ERROR
    with them after its verdicts (exit 2)."""

    CHECK_EVERY = 256        # writes between looks at whether a file was removed

    def __init__(self, paths, salvage_dir=None):
        self.paths = [str(p) for p in record_paths(paths)]
        self.salvage_dir = salvage_dir
        self.writers, self.failed, self.removed = [], {}, {}
        self.written = [0] * len(self.paths)
        self.last_t = [None] * len(self.paths)
        self.problems = []
        self._n = 0
        try:
            for p in self.paths:
                self.writers.append(_one_writer(p))
        except OSError as e:
            for w in self.writers:
                _close_quietly(w)
            raise RecordingError('cannot create the recording %s: %s' % (
                e.filename or p, e.strerror or e))

    def write(self, topic, msg, t=None):
        self._n += 1
        for i, w in enumerate(self.writers):
            if i in self.failed:
                continue
            try:
                w.write(topic, msg, t)
                self.written[i] += 1
                self.last_t[i] = t
            except OSError as e:
                self.failed[i] = (e, t)
            if self._n % self.CHECK_EVERY == 0 and i not in self.removed and _unlinked(w):
                self.removed[i] = t

    def close(self):
        for i, (path, w) in enumerate(zip(self.paths, self.writers)):
            keep = None
            if _unlinked(w):
                self.removed.setdefault(i, self.last_t[i])
                keep = _reopen(w)          # the same file, readable after the writer closes
            try:
                w.close()
            except OSError as e:
                self.failed.setdefault(i, (e, self.last_t[i]))
                _close_quietly(w)
            if i in self.failed:
                self.problems.append(self._after_failure(i, path, keep))
            elif keep is not None:
                self.problems.append(self._salvage(i, path, keep))
            if keep is not None:
                keep.close()
        self.writers = []
        return self.problems

    def _after_failure(self, i, path, keep):
        e, t = self.failed[i]
        what = 'the recording %s could not be written at sim time %s: %s' % (
            path, _sec(t), e.strerror or e)
        if e.errno == errno.ENOSPC:
            what += ' (its filesystem is full)'
        if keep is not None:
            return what + '; its folder was removed too: nothing was kept'
        if is_mcap_path(path):
            return what + '; the MCAP file has no summary: stream readers read it up to there'
        try:
            n, end = _reindex_bag(path)
        except Exception as ex:  # noqa: BLE001 - rosbag raises several kinds
            return what + '; it could not be reindexed (%s): try `rosbag reindex %s`' % (
                ex, path)
        return what + '; %d messages up to sim time %s stay readable (reindexed)' % (
            n, _sec(end))

    def _salvage(self, i, path, keep):
        import shutil
        import tempfile
        d = self.salvage_dir or os.environ.get('SCENARIO_SALVAGE_DIR') or \
            os.path.join(tempfile.gettempdir(), 'scenario_salvage')
        what = 'the folder of the recording %s was removed during the run (noticed at sim ' \
               'time %s)' % (path, _sec(self.removed[i]))
        try:
            os.makedirs(d, exist_ok=True)
            dest = os.path.join(d, '%d-%s' % (os.getpid(), os.path.basename(path)))
            keep.seek(0)
            with open(dest, 'wb') as f:
                shutil.copyfileobj(keep, f)
        except OSError as e:
            return what + '; it could not be saved elsewhere: %s' % (e.strerror or e)
        return what + '; the whole recording (%d messages) is saved as %s' % (
            self.written[i], dest)


def _sec(t):
    return '?' if t is None else '%.3f s' % t.to_sec()


def _fileobj(w):
    return getattr(w, '_file', None) or getattr(w, '_f', None)     # rosbag.Bag, McapWriter


def _unlinked(w):
    f = _fileobj(w)
    try:
        return f is not None and not f.closed and os.fstat(f.fileno()).st_nlink == 0
    except (OSError, ValueError):
        return False


def _reopen(w):
    try:
        return open('/proc/self/fd/%d' % _fileobj(w).fileno(), 'rb')
    except (OSError, ValueError, AttributeError):
        return None


def _close_quietly(w):
    f = _fileobj(w)
    try:
        if f is not None:
            f.close()
    except OSError:
        pass


def _reindex(f):
    """What `rosbag reindex` does to a bag without its index (cut short, never closed):
    its complete chunks indexed, a partial last chunk cut off. ``f``: a path (the file
    itself) or a binary file object."""
    import rosbag
    b = rosbag.Bag(f, 'a', allow_unindexed=True)
    try:
        for _ in b.reindex():
            pass
    finally:
        b.close()


def _reindex_bag(path):
    """Reindex a rosbag cut short in place; returns the number of messages and the end
    time (rospy.Time) that stay readable."""
    import rosbag
    _reindex(path)
    with rosbag.Bag(path) as b:
        n = b.get_message_count()
        import rospy
        return n, rospy.Time.from_sec(b.get_end_time()) if n else None


def record_paths(record):
    """The list of recording paths of a --record value (None, a path or a list)."""
    if not record:
        return []
    if isinstance(record, (str, bytes, os.PathLike)):
        return [record]
    return list(record)


def _kind(path):
    try:
        with open(path, 'rb') as f:
            head = f.read(16)
    except OSError as e:
        raise RecordingError('cannot open the recording %s: %s' % (path, e.strerror or e))
    if head.startswith(MCAP_MAGIC):
        return 'mcap'
    if head.startswith(BAG_MAGIC):
        return 'bag'
    raise RecordingError('%s is not a recording (neither a rosbag nor an MCAP file: it '
                         'starts with %r)' % (path, head[:8]))


class _BagReader(object):
    def __init__(self, path):
        import rosbag
        self.path = path
        self.damage = None      # what is wrong with a file read only up to its damage
        try:
            self.bag = rosbag.Bag(path)
        except rosbag.ROSBagUnindexedException:
            self.bag = self._reindexed(path)
        except Exception as e:  # noqa: BLE001 - rosbag raises several kinds
            raise RecordingError('cannot read the rosbag %s: %s' % (path, e))

    def _reindexed(self, path):
        """A bag without its index (cut short, or never closed): its complete chunks, as
        `rosbag reindex` finds them, indexed in memory (the file stays as it is)."""
        import rosbag
        class _Memory(io.BytesIO):
            mode = 'r+b'         # rosbag checks that its file is binary

            def close(self):     # rosbag closes it when it has written the index
                pass
        try:
            with open(path, 'rb') as f:
                mem = _Memory(f.read())
            _reindex(mem)
            bag = rosbag.Bag(_Memory(mem.getvalue()), 'r')
        except Exception as e:  # noqa: BLE001
            raise RecordingError('cannot read the rosbag %s: it has no index (cut short?) '
                                 'and reindexing failed: %s' % (path, e))
        self.damage = ('the rosbag %s has no index (cut short, or not closed): only its '
                       'complete chunks are read' % path)
        return bag

    def read_messages(self, topics=None, raw=False):
        try:
            for topic, msg, t in self.bag.read_messages(topics=topics, raw=raw):
                yield topic, (bytes(msg[1]) if raw else msg), t
        except Exception as e:  # noqa: BLE001
            raise RecordingError('cannot read the rosbag %s: %s' % (self.path, e))

    def close(self):
        self.bag.close()


class _McapReader(object):
    def __init__(self, path):
        self.path = path
        self.f = open(path, 'rb')
        self.classes = {}
        self.damage = None      # what is wrong with a file read only up to its damage

    def _class(self, schema, channel):
        key = schema.id
        if key not in self.classes:
            cls = None
            try:
                import roslib.message
                cls = roslib.message.get_message_class(schema.name)
            except Exception:  # noqa: BLE001 - unknown package
                cls = None
            md5 = channel.metadata.get('md5sum') if channel.metadata else None
            text = schema.data.decode()
            if cls is None or (md5 and cls._md5sum != md5) or \
                    (not md5 and cls._full_text.strip() != text.strip()):
                from genpy import dynamic
                cls = dynamic.generate_dynamic(schema.name, text)[schema.name]
            self.classes[key] = cls
        return self.classes[key]

    def read_messages(self, topics=None, raw=False):
        """In log time order (the summary's index); a file whose summary cannot be read
        (cut short) is read from its start in file order up to its damage
        (``self.damage`` says what is wrong), then RecordingError."""
        from mcap.reader import NonSeekingReader, make_reader
        from mcap.exceptions import McapError
        self.f.seek(0)
        n = 0
        try:
            try:
                for item in self._decoded(make_reader(self.f).iter_messages(
                        topics=topics, log_time_order=True), raw):
                    n += 1
                    yield item
                return
            except RecordingError:
                raise
            except Exception as e:  # noqa: BLE001 - no summary: stream from the start
                if n:
                    raise
                self.damage = ('the index of the MCAP file %s cannot be read (%s: %s): it is '
                               'read from its start' % (self.path, type(e).__name__, _why(e)))
            self.f.seek(0)
            for item in self._decoded(NonSeekingReader(self.f).iter_messages(
                    topics=topics, log_time_order=False), raw):
                yield item
        except RecordingError:
            raise
        except (McapError, EOFError, ValueError, OSError, KeyError, AssertionError,
                io.UnsupportedOperation) as e:
            raise RecordingError('cannot read the MCAP file %s (truncated or damaged?): %s: '
                                 '%s' % (self.path, type(e).__name__, _why(e)))
        except Exception as e:  # noqa: BLE001 - anything else a damaged file raises
            raise RecordingError('cannot read the MCAP file %s (truncated or damaged?): %s: '
                                 '%s' % (self.path, type(e).__name__, _why(e)))

    def _decoded(self, records, raw):
        import rospy
        for schema, channel, m in records:
            t = rospy.Time(m.log_time // 10 ** 9, m.log_time % 10 ** 9)
            if raw:
                yield channel.topic, bytes(m.data), t
                continue
            if schema is None or channel.message_encoding != 'ros1':
                raise RecordingError('%s: channel %s is not ROS 1 encoded (%s)' % (
                    self.path, channel.topic, channel.message_encoding))
            msg = self._class(schema, channel)()
            msg.deserialize(m.data)
            yield channel.topic, msg, t

    def close(self):
        self.f.close()


def open_reader(path):
    """A reader of a rosbag or an MCAP file (told apart by their first bytes)."""
    path = str(path)
    return _McapReader(path) if _kind(path) == 'mcap' else _BagReader(path)
