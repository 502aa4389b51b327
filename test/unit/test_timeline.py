"""The runner's pure timeline: agenda order and the lockstep slice plan."""
from testing_instance.scenario.timeline import Agenda, next_stop


def test_agenda_pops_in_time_then_insertion_order_only_when_due():
    a = Agenda()
    out = []
    a.push(2.0, lambda t: out.append(('b', t)), 'b')
    a.push(1.0, lambda t: out.append(('a', t)), 'a')
    a.push(2.0, lambda t: out.append(('c', t)), 'c')
    assert len(a) == 3 and a.next_time() == 1.0
    assert a.pop_due(0.5) is None
    fn, what = a.pop_due(1.0)
    assert what == 'a'
    fn(1.0)
    assert a.pop_due(1.9) is None
    assert a.pop_due(1.9996)[1] == 'b'          # within 0.5 ms: due
    assert a.pop_due(2.0)[1] == 'c'
    assert a.pop_due(99.0) is None and a.next_time() is None
    assert out == [('a', 1.0)]


def test_next_stop_rule():
    assert next_stop(0.0, 10.0, 0.25) == 0.25
    assert next_stop(9.9, 10.0, 0.25) == 10.0                       # never past the end
    assert next_stop(0.0, 10.0, 0.25, agenda_next=0.1) == 0.1      # an action first
    assert next_stop(0.0, 10.0, 0.25, None, True, 0.05) == 0.05    # a condition waits
    assert next_stop(0.0, 10.0, 0.25, None, False, 0.05) == 0.25
    assert next_stop(1.0, 10.0, 0.25, agenda_next=1.0) == 1.001    # at least 1 ms on
