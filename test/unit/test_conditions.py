"""The timeline's `when` conditions (timeline.Conditions), pure: topic predicates on message
fields, first hit wins, reach by distance, events fired one by one."""
import types

import pytest

from testing_instance.scenario.timeline import ConditionError, Conditions

EVENTS = [
    {'id': 'start', 'at': 0.0, 'action': 'walk'},
    {'id': 'bright', 'when': {'topic': '/light', 'field': 'data', 'gt': 100}, 'action': 'x'},
    {'id': 'dark', 'when': {'topic': '/light', 'field': 'data', 'lt': 10}, 'action': 'y'},
    {'id': 'door', 'when': {'reach': {'model': 'phone', 'position': [5, 0, 1],
                                      'tolerance': 0.5}}, 'action': 'z'},
]


def _msg(v):
    return types.SimpleNamespace(data=v)


def test_only_when_events_are_conditions_and_their_topics_are_read():
    c = Conditions(EVENTS)
    assert [ev['id'] for ev in c.pending()] == ['bright', 'dark', 'door']
    assert c.topics() == ['/light']
    assert c.wait_for_messages()
    assert c.unsubscribed({'/imu'}) and not c.unsubscribed({'/light'})


def test_the_first_message_that_passes_is_the_hit_and_later_ones_do_not_move_it():
    c = Conditions(EVENTS)
    c.feed('/light', 0.1, _msg(50))
    c.feed('/light', 0.2, _msg(150))
    c.feed('/light', 0.3, _msg(5))
    c.feed('/light', 0.4, _msg(200))
    c.feed('/other', 0.5, _msg(500))
    assert c.hits == {'bright': 0.2, 'dark': 0.3}
    fired = [ev['id'] for ev in c.due(lambda eid, model: (0.0, 0.0, 0.0))]
    assert fired == ['bright', 'dark']       # hits, in the timeline's order; door is far


def test_a_happened_event_is_no_longer_pending_or_fed():
    c = Conditions(EVENTS)
    assert c.happen('bright', 1.0) and not c.happen('bright', 2.0)
    assert c.happened == {'bright': 1.0}
    c.feed('/light', 3.0, _msg(500))
    assert 'bright' not in c.hits
    c.happen('dark', 1.5)
    assert not c.wait_for_messages() and not c.unsubscribed(set())
    assert [ev['id'] for ev in c.pending()] == ['door']


def test_reach_fires_within_tolerance_and_each_event_is_looked_at_after_the_last_fired():
    c = Conditions(EVENTS)
    where = {'phone': (4.7, 0.2, 1.0)}
    asked = []

    def position(event_id, model):
        asked.append((event_id, model))
        return where[model]
    c.feed('/light', 0.1, _msg(150))
    it = c.due(position)
    assert next(it)['id'] == 'bright'
    assert asked == []                        # not asked before 'bright' was fired
    c.happen('bright', 0.1)
    assert next(it)['id'] == 'door' and asked == [('door', 'phone')]
    where['phone'] = (4.0, 0.0, 1.0)
    c2 = Conditions(EVENTS)
    assert [ev['id'] for ev in c2.due(lambda e, m: where[m])] == []


def test_a_field_that_is_not_there_is_an_error_naming_the_event():
    c = Conditions([{'id': 'e1', 'when': {'topic': '/t', 'field': 'nope', 'gt': 1},
                     'action': 'x'}])
    with pytest.raises(ConditionError, match=r"^e1\.when: .*nope"):
        c.feed('/t', 0.0, _msg(3))
