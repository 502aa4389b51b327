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


class _Draws(object):
    """A random.Random stand-in whose randint gives ``ports`` in turn (the last again)."""
    def __init__(self, *ports):
        self.ports, self.asked = list(ports), []

    def randint(self, a, b):
        self.asked.append((a, b))
        return self.ports.pop(0) if len(self.ports) > 1 else self.ports[0]


def test_a_master_port_is_free_and_below_the_ephemeral_range():
    low, high = netutil.MASTER_PORTS
    for _ in range(20):
        port = netutil.master_port()
        assert low <= port <= high < netutil._ephemeral_low()
        s = socket.socket()
        try:
            s.bind(('', port))
        finally:
            s.close()


def test_a_taken_master_port_is_passed_over_and_all_taken_falls_back_to_free_port():
    held = socket.socket()
    held.bind(('', 0))
    held.listen(1)
    taken = held.getsockname()[1]
    try:
        want = netutil.master_port()
        draws = _Draws(taken, taken, want)
        assert netutil.master_port(rng=draws) == want
        assert draws.asked == [netutil.MASTER_PORTS] * 3
        draws = _Draws(taken)
        port = netutil.master_port(tries=5, rng=draws)
        assert len(draws.asked) == 5 and port != taken and netutil.bindable(port, '')
    finally:
        held.close()


def test_master_ports_end_below_a_lowered_ephemeral_range(monkeypatch):
    monkeypatch.setattr(netutil, '_ephemeral_low', lambda: 30000)
    draws = _Draws(25000)
    netutil.master_port(rng=draws)
    assert draws.asked[0] == (netutil.MASTER_PORTS[0], 29999)
    # no room below it at all: the kernel's free port
    monkeypatch.setattr(netutil, '_ephemeral_low', lambda: 1024)
    draws = _Draws(25000)
    assert netutil.master_port(rng=draws) > 0 and draws.asked == []
