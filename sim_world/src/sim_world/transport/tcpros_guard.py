"""Guard rospy's TCPROS server against clients that connect and say nothing.

rospy accepts connections in one thread (rospy.impl.tcpros_base.TCPServer.run) and, in that
same thread, reads each connection's handshake header
(TCPROSServer._tcp_server_callback -> rosgraph.network.read_ros_handshake_header: a blocking
recv loop, no timeout, no size bound). One client that connects and sends nothing, half a
header, or a header length of 4 GB stalls every later subscriber and every later service
call of the node -- for rospy's ServiceProxy that is every call, as it connects anew each
time. test/test_fuzz_tcpros.py showed it on sim_world: /gazebo/get_model_state went from 35
calls/s to 0 and a new subscriber never connected while a few silent sockets were open.

``install()`` makes the accept loop hand each connection to a handshake thread of its own
(at most ``MAX_HANDSHAKES`` at once; more are closed at once). That thread waits, with
``MSG_PEEK``, until the whole header is in the socket's buffer, for at most
``HEADER_TIMEOUT`` s, and refuses a header longer than ``MAX_HEADER`` bytes; then it passes
the connection, blocking as before, to rospy's own callback, which reads the header at
once and sets up the publisher or service connection as always (sim_world.transport.connections'
connections included). A dropped connection is one warning line naming the peer and why;
a flood of them (a port scanner, a fuzzer) is said at most ``LOG_BURST`` times per
``LOG_WINDOW`` s, and the next line says how many were dropped without a line.
Install it after ``rospy.init_node`` in a process that serves topics or services (the
sim_world node, and the world embedded in run_scenario: sim_world.gazebo_api does it
through the facade, sim_world.transport.guard_handshakes)."""
import socket
import struct
import threading
import time

__all__ = ['install', 'installed', 'HEADER_TIMEOUT', 'MAX_HEADER', 'MAX_HANDSHAKES', 'stats']

HEADER_TIMEOUT = 5.0       # s from accept until the whole connection header has arrived
MAX_HEADER = 1 << 16       # bytes; rospy's own headers are a few kB (message definitions)
MAX_HANDSHAKES = 256       # connections waiting for their header at once
LOG_BURST = 10             # warning lines about dropped connections ...
LOG_WINDOW = 60.0          # ... per this many s of wall time

_lock = threading.Lock()
_slots = threading.BoundedSemaphore(MAX_HANDSHAKES)
_original = None
stats = {'accepted': 0, 'dropped': 0}


def installed():
    return _original is not None


class Limiter(object):
    """At most ``burst`` lines per ``window`` s; the first line after a quiet spell names
    how many were left unsaid."""

    def __init__(self, burst=LOG_BURST, window=LOG_WINDOW, clock=time.monotonic):
        self.burst, self.window, self.clock = burst, window, clock
        self.start, self.said, self.unsaid = None, 0, 0

    def line(self, text):
        """The line to log for text, or None to stay silent."""
        now = self.clock()
        if self.start is None or now - self.start >= self.window:
            self.start, self.said = now, 0
        if self.said >= self.burst:
            self.unsaid += 1
            return None
        self.said += 1
        if self.unsaid:
            text += ' (and %d more dropped connections without a line before it)' % \
                self.unsaid
            self.unsaid = 0
        return text


_limit = Limiter()


def _drop(sock, addr, why):
    stats['dropped'] += 1
    line = _limit.line('tcpros_guard: dropped the connection from %s:%s: %s' % (
        addr[0] if addr else '?', addr[1] if addr else '?', why))
    if line is not None:
        import rospy
        rospy.logwarn('%s', line)
    try:
        sock.close()
    except OSError:
        pass


def _wait_for_header(sock):
    """None when the whole header is waiting in the socket, else why not."""
    deadline = time.monotonic() + HEADER_TIMEOUT
    want = 4
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            return 'no complete connection header within %g s' % HEADER_TIMEOUT
        sock.settimeout(left)
        try:
            data = sock.recv(min(want, MAX_HEADER + 4), socket.MSG_PEEK)
        except socket.timeout:
            return 'no complete connection header within %g s' % HEADER_TIMEOUT
        except OSError as e:
            return 'socket error before the header: %s' % e
        if not data:
            return 'closed before sending its connection header (%d bytes)' % 0
        if len(data) >= 4:
            (size,) = struct.unpack('<I', data[:4])
            if size > MAX_HEADER:
                return 'connection header of %d bytes announced (at most %d)' % (
                    size, MAX_HEADER)
            if len(data) >= 4 + size:
                return None
            want = 4 + size
        if len(data) < want:
            # the rest has not arrived: sleep a little (MSG_PEEK returns at once while
            # some bytes are there) instead of spinning
            time.sleep(0.005)


def _handshake(server, sock, addr):
    try:
        why = _wait_for_header(sock)
        if why is not None:
            _drop(sock, addr, why)
            return
        sock.settimeout(None)            # rospy's connections are blocking sockets
        _original(server, sock, addr)
    except Exception as e:  # noqa: BLE001 - never let a thread die with a traceback
        _drop(sock, addr, 'handshake failed: %s' % e)
    finally:
        _slots.release()


def _guarded_callback(server, sock, addr):
    """Runs in rospy's accept loop: hand the connection over and return at once."""
    stats['accepted'] += 1
    if not _slots.acquire(blocking=False):
        _drop(sock, addr, '%d connections are already waiting for their headers'
              % MAX_HANDSHAKES)
        return
    try:
        threading.Thread(target=_handshake, args=(server, sock, addr), daemon=True,
                         name='tcpros_handshake').start()
    except RuntimeError as e:             # no thread to be had
        _slots.release()
        _drop(sock, addr, str(e))


def install():
    """Guard this process's TCPROS server (idempotent; before or after it started)."""
    global _original
    from rospy.impl import tcpros_base
    with _lock:
        if _original is None:
            _original = tcpros_base.TCPROSServer._tcp_server_callback
            tcpros_base.TCPROSServer._tcp_server_callback = _guarded_callback
        server = tcpros_base._tcpros_server
        if server is not None and server.tcp_ros_server is not None:
            # already accepting: its TCPServer looks the handler up on every connection
            server.tcp_ros_server.inbound_handler = \
                lambda sock, addr: _guarded_callback(server, sock, addr)
