"""What the rostest scripts share (issue 17): sim time, a recorder, model helpers.

The scripts run as executables under rostest, so this folder is on their sys.path:
``from common import sim_sleep, Recorder, wait_models``. Call after ``rospy.init_node``.
"""
import threading
import time

import rospy
from rosgraph_msgs.msg import Clock

__all__ = ['SimClock', 'sim_now', 'sim_sleep', 'Recorder', 'wait_models', 'model_state_msg']

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
