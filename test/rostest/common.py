"""What the rostest scripts share (issue 17): sim time, a recorder, model helpers.

The scripts run as executables under rostest, so this folder is on their sys.path:
``from common import start, sim_sleep, Recorder``. ``start`` calls ``rospy.init_node`` and
waits for the world; the rest is for after it.
"""
import subprocess
import threading
import time

import rospy
from rosgraph_msgs.msg import Clock

__all__ = ['start', 'SimClock', 'sim_now', 'sim_sleep', 'Recorder', 'wait_models',
           'model_state_msg', 'wait_connected', 'rosservice', 'rated_topics']

_lock = threading.Lock()
_clock = []


class SimClock(object):
    """The latest /clock, kept by a subscriber (no round trip per poll)."""

    def __init__(self):
        self.t = None
        self.sub = rospy.Subscriber('/clock', Clock, self._on, queue_size=10)

    def _on(self, m):
        self.t = m.clock.to_sec()

    def now(self, timeout=60.0):
        deadline = time.time() + timeout
        while self.t is None:
            if time.time() > deadline:
                raise AssertionError('no /clock within %g s' % timeout)
            time.sleep(0.005)
        return self.t

    def sleep(self, seconds, timeout=150.0):
        """Wait until ``seconds`` of sim time have passed (wall-clock ``timeout``)."""
        start = self.now()
        deadline = time.time() + timeout
        while self.t - start < seconds:
            if time.time() > deadline:
                raise AssertionError('sim time did not advance %g s in %g s of wall time'
                                     % (seconds, timeout))
            time.sleep(0.005)


def _shared():
    with _lock:
        if not _clock:
            _clock.append(SimClock())
        return _clock[0]


def sim_now():
    return _shared().now()


def sim_sleep(seconds, timeout=150.0):
    _shared().sleep(seconds, timeout)


class Recorder(object):
    """Every message of a topic, with the sim time each arrived at (``times``)."""

    def __init__(self, topic, cls, queue_size=1000):
        self.msgs, self.times = [], []
        self.clock = _shared()
        self.sub = rospy.Subscriber(topic, cls, self._on, queue_size=queue_size)

    def _on(self, m):
        self.msgs.append(m)
        self.times.append(self.clock.t)


def wait_models(get_model_state, names, timeout=90.0):
    """Wait until every model in ``names`` exists (spawned by the launch file)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        if all(get_model_state(n, 'world').success for n in names):
            return
        time.sleep(0.2)
    raise AssertionError('models %s were not spawned within %g s' % (', '.join(names), timeout))


def start(node, models=('mobile_device',), timeout=90.0):
    """``rospy.init_node(node)``, then wait for the world's model services, until every
    model in ``models`` is spawned and for sim time (so a ``Recorder`` made next stamps every
    message). Returns the (get_model_state, set_model_state) proxies."""
    from mobile_device_sim.srv import GetModelState, SetModelState
    rospy.init_node(node)
    rospy.wait_for_service('/gazebo/get_model_state', timeout=60)
    get = rospy.ServiceProxy('/gazebo/get_model_state', GetModelState)
    wait_models(get, models, timeout)
    sim_now()
    return get, rospy.ServiceProxy('/gazebo/set_model_state', SetModelState)


def wait_connected(pub, sub, subscribers=1, timeout=60.0):
    """Wait (at most ``timeout`` s of wall time) until ``pub`` has ``subscribers``
    subscribers and ``sub`` a publisher; AssertionError with both counts if not (a wait
    that went on silently once cost audio_device.test a minute on every run, waiting for a
    subscriber that never comes)."""
    deadline = time.time() + timeout
    while pub.get_num_connections() < subscribers or sub.get_num_connections() == 0:
        if time.time() >= deadline:
            raise AssertionError(
                '%s has %d subscriber(s), not %d, and %s %d publisher(s) after %g s'
                % (pub.resolved_name, pub.get_num_connections(), subscribers,
                   sub.resolved_name, sub.get_num_connections(), timeout))
        time.sleep(0.1)


def rosservice(*args):
    """``rosservice call ARGS`` as a user types it: what it printed."""
    out = subprocess.run(['rosservice', 'call'] + list(args), stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, timeout=60)
    return out.stdout


def rated_topics(test, ns, topics):
    """Asserts (``test``: a TestCase) that every topic ``ns + name`` of ``topics`` ({name:
    (documented type, class, rate in Hz or None)}) has its documented type on the master;
    the (name, rate) of those with a rate, sorted."""
    import rosgraph
    types = dict(rosgraph.Master('/test').getTopicTypes())
    rated = []
    for topic, (typ, _, rate) in sorted(topics.items()):
        test.assertEqual(types.get(ns + topic), typ, topic)
        if rate is not None:
            rated.append((topic, rate))
    return rated


def model_state_msg(model, xyz, rpy=(0.0, 0.0, 0.0), frame='world'):
    """A ModelState placing ``model`` at ``xyz`` with roll/pitch/yaw ``rpy`` (rad)."""
    from mobile_device_sim.msg import ModelState
    from sim_world.transforms import quat_from_rpy
    m = ModelState(model_name=model, reference_frame=frame)
    m.pose.position.x, m.pose.position.y, m.pose.position.z = (float(v) for v in xyz)
    q = quat_from_rpy(*rpy)
    m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z, m.pose.orientation.w = \
        (float(v) for v in q)
    return m
