"""One free TCP port for a new master, a test server or a bench (the one copy the runner,
the tests and the benches share).

``free_port()``: a port the kernel has just handed out on the loopback interface (bound to
port 0, read back, released). Another process may take it before the caller binds it: the
callers that start a master retry once on a new port (testing_instance.runner).
``free_port(start)``: the first port from ``start`` on (200 tried) that can be bound now,
for callers that want ports in a known range (pytest-xdist workers, bench/camera).
"""
import socket

__all__ = ['free_port']


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
