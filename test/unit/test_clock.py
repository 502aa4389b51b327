"""The clocks of the run's one loop (no ROS)."""
import pytest

from testing_instance.run.clock import ReplayClock, WorldClock
from testing_instance.scenario.results import RunError


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
    from types import SimpleNamespace
    seen = []
    r = SimpleNamespace(sc=SimpleNamespace(apps=[], slice=0.05, pipeline=False), t=1.0,
                        hands=SimpleNamespace(inputs_sent=False), embedded=False,
                        rospy=SimpleNamespace(get_name=lambda: '/runner'),
                        intake=SimpleNamespace(note_times=seen.append),
                        world=SimpleNamespace(stopped=lambda: seen.append('stopped')),
                        check_world=lambda: seen.append('checked'),
                        world_log=lambda: ['last line'])
    answer = SimpleNamespace(success=True, sim_time=1.5, topics=['/imu', '/fix'],
                             counts=[10, 1], dropped=[2, 0])
    r.step_srv = lambda **kw: answer
    c = WorldClock(r)
    assert (c.longest, c.settle_every, c.acts) == (0.25, 0.25, True)
    assert c.step_to(1.5) == 1.5
    assert c.published == {'/imu': 8, '/fix': 1} and c.dropped == {'/imu': 2}
    assert seen == [answer]

    def dead(**kw):
        raise IOError('connection refused')
    r.step_srv = dead
    with pytest.raises(RunError) as e:
        c.step_to(2.0)
    assert str(e.value) == ('the world stopped answering at sim time 1.000 s (step_world: '
                            'connection refused)')
    assert e.value.log_lines == ['last line'] and seen[1:] == ['stopped', 'checked']
    # with apps every slice is a step and a handshake
    r.sc.apps = [{'name': 'app'}]
    assert (WorldClock(r).longest, WorldClock(r).settle_every) == (0.05, 0.05)
