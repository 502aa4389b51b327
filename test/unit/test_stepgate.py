"""sim_world.stepgate without a roscore: while the gate is closed (the world steps a
pipelined slice) a message received from a socket and a service request wait in the thread
that got them, and go through, in order, once it is open again."""
import threading
import time

import pytest

pytest.importorskip('rospy')

from rospy.impl.tcpros_service import ServiceImpl  # noqa: E402
from rospy.topics import _SubscriberImpl  # noqa: E402

from sim_world import stepgate  # noqa: E402


class FakeSub(object):
    """What _SubscriberImpl.receive_callback reads of its implementation."""
    statistics_logger = None

    def __init__(self, got):
        self.callbacks = [(lambda m, _a: got.append(m), None)]

    def _invoke_callback(self, msg, cb, cb_args):
        cb(msg, cb_args)


class FakeService(object):
    """What ServiceImpl._handle_request reads: its handler, response class, seq."""
    seq = 0
    response_class = None

    def __init__(self, got):
        self.handler = lambda req: got.append(req)


def _later(fn, *args):
    th = threading.Thread(target=fn, args=args, daemon=True)
    th.start()
    return th


def test_inputs_wait_while_the_gate_is_closed(monkeypatch):
    got = []
    stepgate.install()
    stepgate.install()                                   # once per process
    monkeypatch.setattr('rospy.impl.tcpros_service.convert_return_to_response',
                        lambda r, cls: r)

    class Transport(object):
        write_buff = type('B', (), {'write': lambda self, b: None})()

        def send_message(self, resp, seq):
            got.append('answered')
    stepgate.close()
    try:
        assert stepgate.is_closed()
        a = _later(_SubscriberImpl.receive_callback, FakeSub(got), ['m1', 'm2'], None)
        time.sleep(0.05)
        b = _later(ServiceImpl._handle_request, FakeService(got), Transport(), 'req')
        time.sleep(0.2)
        assert got == [] and a.is_alive() and b.is_alive()    # both wait
    finally:
        stepgate.reopen()
    a.join(5)
    b.join(5)
    assert not a.is_alive() and not b.is_alive()
    assert sorted(got) == ['answered', 'm1', 'm2', 'req']
    assert got.index('m1') < got.index('m2') and got.index('req') < got.index('answered')
    # open: at once, in the calling thread
    _SubscriberImpl.receive_callback(FakeSub(got), ['m3'], None)
    assert got[-1] == 'm3' and not stepgate.is_closed()
