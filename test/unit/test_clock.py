"""Clock sources of the runner's loop (no ROS)."""
import pytest

from testing_instance.run.clock import ReplayClock, WorldClock


def test_replay_clock_publishes_a_slice_in_order_with_clock_before_each():
    out = []
    msgs = [(0.1, '/a', 'a1'), (0.2, '/ev', {'id': 'e'}), (0.25, '/b', 'b1'), (0.3, '/a', 'a2')]
    c = ReplayClock(msgs, lambda tp, m, t: out.append(('pub', tp, m)),
                    lambda t: out.append(('clock', t)),
                    lambda ev, t: out.append(('ev', ev['id'], t)), '/ev')
    assert c.step_to(0.25) == 0.25
    assert out == [('clock', 0.1), ('pub', '/a', 'a1'), ('ev', 'e', 0.2), ('clock', 0.25),
                   ('pub', '/b', 'b1'), ('clock', 0.25)]
    assert c.counts == {'/a': 1, '/b': 1}        # events are not published
    del out[:]
    assert c.step_to(0.5) == 0.5
    assert out == [('clock', 0.3), ('pub', '/a', 'a2'), ('clock', 0.5)]
    assert c.counts == {'/a': 2, '/b': 1}


def test_world_clock_returns_the_reached_time_and_reports_a_dead_world():
    class Res(object):
        sim_time = 1.5
    assert WorldClock(lambda t: Res(), None).step_to(1.5) == 1.5
    seen = []

    def dead(t):
        raise IOError('connection refused')

    def on_error(e):
        seen.append(str(e))
        raise RuntimeError('world stopped: %s' % e)
    with pytest.raises(RuntimeError, match='world stopped: connection refused'):
        WorldClock(dead, on_error).step_to(2.0)
    assert seen == ['connection refused']
