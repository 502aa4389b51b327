"""One free TCP port for a new master, a test server or a bench (the one copy the runner,
the tests and the benches share).

``free_port()``: a port the kernel has just handed out on the loopback interface (bound to
port 0, read back, released). Another process may take it before the caller binds it: the
callers that start a master retry once on a new port (testing_instance.runner).
``free_port(start)``: the first port from ``start`` on (200 tried) that can be bound now,
for callers that want ports in a known range (pytest-xdist workers, bench/camera).

``wait_for_service(name, timeout)``: rospy.wait_for_service without its 0.3 s between looks
(a node waiting for the world's services started up to 0.3 s late: the phone's spawner and
the testing instance, on every scenario's start-up): asks the master every 20 ms.
"""
import socket
import time

__all__ = ['free_port', 'wait_for_service']


def free_port(start=None, host='127.0.0.1'):
    if start is None:
        s = socket.socket()
        try:
            s.bind((host, 0))
            return s.getsockname()[1]
        finally:
            s.close()
    for port in range(int(start), int(start) + 200):
        s = socket.socket()
        try:
            s.bind((host, port))
            return port
        except OSError:
            continue
        finally:
            s.close()
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
