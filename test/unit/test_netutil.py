"""sim_world.netutil without a roscore: free ports, and wait_for_service asking the master
every 20 ms (rospy's own waits 0.3 s between looks) until it knows the service."""
import socket
import time

import pytest

rosgraph = pytest.importorskip('rosgraph')
from sim_world import netutil  # noqa: E402


class FakeMaster(object):
    """Knows the service from ``after`` s on."""
    asked = []

    def __init__(self, caller, after=0.1):
        self.t0 = time.monotonic()
        self.after = after

    def lookupService(self, name):
        FakeMaster.asked.append(time.monotonic() - self.t0)
        if time.monotonic() - self.t0 < self.after:
            raise rosgraph.MasterError('unknown service %s' % name)
        return 'rosrpc://localhost:1234'


def test_wait_for_service_asks_often_until_the_service_appears(monkeypatch):
    monkeypatch.setattr(rosgraph, 'Master', FakeMaster)
    FakeMaster.asked = []
    assert netutil.wait_for_service('/gazebo/step_world', timeout=5.0) is True
    # about 6 looks in the 0.1 s before it appears (rospy's wait: 1), the last one after
    assert len(FakeMaster.asked) >= 3 and FakeMaster.asked[-1] >= 0.1, FakeMaster.asked


def test_wait_for_service_gives_up_at_its_timeout(monkeypatch):
    monkeypatch.setattr(rosgraph, 'Master', lambda caller: FakeMaster(caller, after=60))
    t0 = time.monotonic()
    assert netutil.wait_for_service('/nobody', timeout=0.2) is False
    assert 0.2 <= time.monotonic() - t0 < 1.0


def test_free_port_can_be_bound():
    port = netutil.free_port()
    s = socket.socket()
    try:
        s.bind(('127.0.0.1', port))
    finally:
        s.close()
