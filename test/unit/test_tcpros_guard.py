"""sim_world.transport.tcpros_guard without a roscore: when a connection's header is complete, and
the connections it drops (silent, announcing a huge header, closed early). With a real world
and raw sockets: test/test_fuzz_tcpros.py."""
import socket
import struct
import threading

import pytest

pytest.importorskip('rospy')
from sim_world.transport import tcpros_guard  # noqa: E402


@pytest.fixture
def pair(monkeypatch):
    monkeypatch.setattr(tcpros_guard, 'HEADER_TIMEOUT', 0.3)
    a, b = socket.socketpair()
    yield a, b
    a.close()
    b.close()


def test_a_complete_header_passes_and_stays_in_the_socket(pair):
    a, b = pair
    body = struct.pack('<I', 9) + b'topic=/ab'
    b.sendall(struct.pack('<I', len(body)) + body)
    assert tcpros_guard._wait_for_header(a) is None
    assert a.recv(100) == struct.pack('<I', len(body)) + body     # rospy reads it whole


def test_a_header_arriving_in_pieces_is_waited_for(pair):
    a, b = pair
    body = b'\x05\x00\x00\x00x=1234' * 3
    data = struct.pack('<I', len(body)) + body
    b.sendall(data[:3])
    threading.Timer(0.1, lambda: b.sendall(data[3:])).start()
    assert tcpros_guard._wait_for_header(a) is None


def test_silent_half_huge_and_closed_connections_are_refused_by_reason(pair):
    a, b = pair
    assert 'no complete connection header within 0.3 s' in tcpros_guard._wait_for_header(a)
    b.sendall(struct.pack('<I', 100) + b'abc')
    assert 'no complete connection header' in tcpros_guard._wait_for_header(a)
    c, d = socket.socketpair()
    d.sendall(struct.pack('<I', 0xFFFFFFF0) + b'x')
    assert 'connection header of 4294967280 bytes announced' in \
        tcpros_guard._wait_for_header(c)
    d.close()
    e, f = socket.socketpair()
    f.close()
    assert 'closed before sending its connection header' in tcpros_guard._wait_for_header(e)
    c.close()
    e.close()


def test_a_flood_of_dropped_connections_is_said_a_few_times_a_minute():
    now = [0.0]
    lim = tcpros_guard.Limiter(burst=3, window=60.0, clock=lambda: now[0])
    said = [lim.line('drop %d' % i) for i in range(10)]
    assert said[:3] == ['drop 0', 'drop 1', 'drop 2'] and said[3:] == [None] * 7
    now[0] = 61.0                          # the next minute: said again, with the count
    assert lim.line('drop 10') == \
        'drop 10 (and 7 more dropped connections without a line before it)'
    assert lim.line('drop 11') == 'drop 11'
