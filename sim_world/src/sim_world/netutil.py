"""One free TCP port for a new master, a test server or a bench (the one copy the runner,
the tests and the benches share).

``free_port()``: a port the kernel has just handed out on the loopback interface (bound to
port 0, read back, released). Another process may take it before the caller binds it: the
callers that start a master retry once on a new port (testing_instance.run.runner).
``free_port(start)``: the first port from ``start`` on (200 tried) that can be bound now,
for callers that want ports in a known range (pytest-xdist workers, bench/camera).
``master_port()``: a free port for a run's own ROS master, drawn from below the kernel's
ephemeral range (``MASTER_PORTS``). A port from ``free_port()`` is in that range, and a
rosmaster binds it only after its imports (0.2-0.5 s): meanwhile any outgoing connection
on the machine (an XML-RPC call, a TCPROS link, Ray's) can be given it as its local port,
and two jobs can be handed the same one. Below the range only other masters' pickers
compete, and they draw at random from 8,768 ports.

``wait_for_service(name, timeout)``: rospy.wait_for_service without its 0.3 s between looks
(a node waiting for the world's services started up to 0.3 s late: the phone's spawner and
the testing instance, on every scenario's start-up): asks the master every 20 ms.
"""
import random
import socket
import time

__all__ = ['bindable', 'free_port', 'master_port', 'wait_for_service']

#: where master_port draws from: below the ephemeral range (Linux's default 32768-60999),
#: above the test plugin's per-worker ranges (testing_instance.pytest_plugin: 20000-23999)
MASTER_PORTS = (24000, 32767)


def _ephemeral_low():
    try:
        with open('/proc/sys/net/ipv4/ip_local_port_range') as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


def bindable(port, host='127.0.0.1'):
    """Can a TCP socket be bound to (host, port) now?"""
    s = socket.socket()
    try:
        s.bind((host, port))
        return True
    except OSError:
        return False
    finally:
        s.close()


def master_port(tries=100, rng=None):
    """A port for a ROS master that can be bound now on every address (rosmaster binds
    0.0.0.0), drawn at random (``rng``: a random.Random; the port is not data of the run,
    so not the world's seeded generators) from MASTER_PORTS below the ephemeral range;
    ``free_port()`` when none of ``tries`` draws is free."""
    rng = rng or random.SystemRandom()
    low, high = MASTER_PORTS
    high = min(high, _ephemeral_low() - 1)
    if high > low:
        for _ in range(tries):
            port = rng.randint(low, high)
            if bindable(port, ''):
                return port
    return free_port()


def free_port(start=None, host='127.0.0.1'):
    if start is None:
        s = socket.socket()
        try:
            s.bind((host, 0))
            return s.getsockname()[1]
        finally:
            s.close()
    for port in range(int(start), int(start) + 200):
        if bindable(port, host):
            return port
    raise RuntimeError('no free port in %d..%d' % (start, start + 199))


def wait_for_service(name, timeout=None, poll=0.02, caller='/wait_for_service', give_up=None):
    """True once the master knows the service ``name`` (a global name), False after
    ``timeout`` s (None: no limit), when rospy shuts down or when ``give_up()`` is true
    (the process that would offer it has died)."""
    import rosgraph
    try:
        from rospy.core import is_shutdown
    except ImportError:  # pragma: no cover
        def is_shutdown():
            return False
    master = rosgraph.Master(caller)
    deadline = None if timeout is None else time.monotonic() + float(timeout)
    while True:
        try:
            master.lookupService(name)
            return True
        except (rosgraph.MasterException, OSError):
            pass
        if is_shutdown() or (deadline is not None and time.monotonic() >= deadline) or \
                (give_up is not None and give_up()):
            return False
        time.sleep(poll)
