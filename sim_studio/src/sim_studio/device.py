"""The device panel's data: the latest message of each topic a phone publishes, as named
fields (``flatten``, no ROS in it), and the subscriptions that keep them (``DeviceWatch``).

A phone's topics are those under its namespace (``/mobile_device/...``) on the master;
images, point clouds, camera infos and audio are not panel values (the camera panel shows
the image) and are left out. Each subscription keeps only its latest message (queue size
1) and flattening happens when the stream sends (a few times a second), so the panel costs
the world one deserialisation per message and nothing else."""
import math
import threading

__all__ = ['flatten', 'DeviceWatch', 'SKIP_TYPES', 'MAX_FIELDS']

#: message types that are not panel values
SKIP_TYPES = ('sensor_msgs/Image', 'sensor_msgs/CompressedImage', 'sensor_msgs/CameraInfo',
              'sensor_msgs/PointCloud2', 'sensor_msgs/PointCloud', 'mobile_device_sim/AudioData',
              'audio_common_msgs/AudioData', 'mobile_device_sim/ContactsState',
              'nmea_msgs/Sentence', 'std_msgs/String')
MAX_FIELDS = 24          # per topic
MAX_ITEMS = 4            # of an array (its first ones)
SKIP_FIELDS = ('covariance', 'header', 'frame_id', 'seq')


def _stamp(msg):
    h = getattr(msg, 'header', None)
    st = getattr(h, 'stamp', None)
    return st.to_sec() if st is not None and hasattr(st, 'to_sec') else None


def flatten(msg, limit=MAX_FIELDS):
    """(header stamp in s or None, [(field path, value)]) of a ROS message: numbers and
    booleans as floats, short strings as strings, arrays by their first items
    (``name[i]``), ``rospy.Time``/``Duration`` in seconds; headers and covariances left
    out, at most ``limit`` fields."""
    out = []

    def walk(v, path):
        if len(out) >= limit:
            return
        last = path.rsplit('.', 1)[-1].split('[')[0]
        if any(s in last for s in SKIP_FIELDS):
            return
        if hasattr(v, 'to_sec'):
            out.append((path, float(v.to_sec())))
        elif isinstance(v, bool):
            out.append((path, 1.0 if v else 0.0))
        elif isinstance(v, (int, float)):
            f = float(v)
            out.append((path, f if math.isfinite(f) else str(f)))
        elif isinstance(v, str):
            if len(v) <= 40:
                out.append((path, v))
        elif isinstance(v, (bytes, bytearray)):
            return
        elif isinstance(v, (list, tuple)):
            for i, x in enumerate(v[:MAX_ITEMS]):
                walk(x, '%s[%d]' % (path, i))
        elif hasattr(v, '__slots__'):
            for name in v.__slots__:
                walk(getattr(v, name), '%s.%s' % (path, name) if path else name)
    walk(msg, '')
    return _stamp(msg), out


class DeviceWatch(object):
    """Subscriptions to the topics of the phones' namespaces; ``values()`` their latest
    messages flattened. ``refresh()`` looks for topics that appeared since (call it every
    few seconds: plugins load after the studio starts)."""

    def __init__(self, rospy, namespaces):
        self.rospy = rospy
        self.namespaces = ['/%s/' % ns.strip('/') for ns in namespaces]
        self.subs = {}              # topic -> Subscriber
        self.types = {}             # topic -> type name
        self.latest = {}            # topic -> (message, count)
        self._lock = threading.Lock()

    def add(self, namespace):
        """Watch the topics of one more phone (one spawned after the studio started): found
        by the next ``refresh``."""
        ns = '/%s/' % namespace.strip('/')
        if ns not in self.namespaces:
            self.namespaces.append(ns)

    def wanted(self, topics):
        """[(topic, type)] of the master's ``topics`` the panel shows."""
        return sorted((t, ty) for t, ty in topics
                      if any(t.startswith(ns) for ns in self.namespaces)
                      and ty not in SKIP_TYPES)

    def refresh(self):
        import roslib.message
        for topic, ty in self.wanted(self.rospy.get_published_topics()):
            if topic in self.subs:
                continue
            cls = roslib.message.get_message_class(ty)
            if cls is None:
                continue
            self.types[topic] = ty
            self.subs[topic] = self.rospy.Subscriber(
                topic, cls, self._on_msg, callback_args=topic, queue_size=1)

    def _on_msg(self, msg, topic):
        with self._lock:
            n = self.latest.get(topic, (None, 0))[1]
            self.latest[topic] = (msg, n + 1)

    def values(self):
        """{topic: {'type', 'stamp', 'n' (messages so far), 'fields': [[path, value]]}}."""
        with self._lock:
            latest = dict(self.latest)
        out = {}
        for topic, (msg, n) in sorted(latest.items()):
            stamp, fields = flatten(msg)
            out[topic] = {'type': self.types.get(topic), 'stamp': stamp, 'n': n,
                          'fields': [list(f) for f in fields]}
        return out

    def close(self):
        for s in self.subs.values():
            s.unregister()
        self.subs = {}
