"""The runner's inbox: stamp order, per-topic counts, waiting for exact counts."""
import threading

from testing_instance.run.inbox import Inbox


def test_take_sorts_by_stamp_then_topic_then_arrival_and_empties():
    ib = Inbox()
    ib.put(2.0, '/b', 'b2')
    ib.put(1.0, '/b', 'b1')
    ib.put(1.0, '/a', 'a1')
    ib.put(1.0, '/b', 'b1bis')
    assert [m for _t, _s, _tp, m in ib.take()] == ['a1', 'b1', 'b1bis', 'b2']
    assert ib.take() == []
    assert ib.counts == {'/a': 1, '/b': 3}


def test_wait_counts_returns_when_the_messages_arrive_and_names_what_is_missing():
    ib = Inbox()
    ib.put(0.0, '/imu', 1)

    def later():
        for i in range(3):
            ib.put(0.01 * i, '/imu', i)

    th = threading.Thread(target=later)
    th.start()
    assert ib.wait_counts({'/imu': 4}, timeout=30.0, world=False) == {}
    th.join()
    assert ib.wait_counts({'/imu': 4, '/gps': 2}, timeout=0.05, world=False) == \
        {'/gps': (0, 2)}


def test_world_counts_only_count_the_world_nodes_messages():
    ib = Inbox()
    ib.put(0.0, '/imu', 'from an app')
    assert ib.wait_counts({'/imu': 1}, timeout=0.02) == {'/imu': (0, 1)}
    ib.put(0.0, '/imu', 'from the world', from_world=True)
    assert ib.wait_counts({'/imu': 1}, timeout=0.02) == {}
    assert ib.counts == {'/imu': 2} and ib.from_world == {'/imu': 1}


def test_settle_waits_while_messages_keep_arriving():
    import time
    ib = Inbox()

    def burst():
        for i in range(20):
            ib.put(0.0, '/x', i)
            time.sleep(0.005)

    th = threading.Thread(target=burst)
    th.start()
    ib.put(0.0, '/x', -1)
    ib.settle(quiet=0.2, longest=30.0)      # gaps are 5 ms: returns only after the burst
    assert ib.counts == {'/x': 21}
    th.join()


def test_unstamped_messages_are_held_until_the_handshake_times_them():
    box = Inbox()
    box.put(1.02, '/imu', 'a')
    box.hold('/app/out', 'x')
    box.put(1.04, '/imu', 'b')
    assert box.counts == {'/imu': 2, '/app/out': 1}     # counted at once
    assert [m for _t, _s, _tp, m in box.take()] == ['a', 'b']
    box.hold('/led', 'y', from_world=True, tag=1.031)
    assert box.from_world == {'/led': 1}
    assert box.stamp_held(lambda topic, tag: 1.05 if tag is None else tag) == \
        [(1.05, '/app/out', 'x'), (1.031, '/led', 'y')]
    assert [(t, m) for t, _s, _tp, m in box.take()] == [(1.031, 'y'), (1.05, 'x')]
    assert box.stamp_held(lambda topic, tag: 0) == [] and box.take() == []


def test_a_pipelined_replay_times_the_apps_answers_one_slice_later():
    """later(topic, tag): those messages wait for the next stamp_held, once; the world's
    (tagged) are timed at once; order of arrival is kept."""
    box = Inbox()
    apps = lambda topic, tag: tag is None      # noqa: E731
    box.hold('/app/out', 'x1')
    box.hold('/led', 'w1', from_world=True, tag=0.02)
    assert box.stamp_held(lambda topic, tag: 0.05 if tag is None else tag, apps) == \
        [(0.02, '/led', 'w1')]
    box.hold('/app/out', 'x2')
    assert box.stamp_held(lambda topic, tag: 0.10 if tag is None else tag, apps) == \
        [(0.10, '/app/out', 'x1')]
    box.hold('/app/out', 'x3')
    # the last slice: everything
    assert box.stamp_held(lambda topic, tag: 0.15) == \
        [(0.15, '/app/out', 'x2'), (0.15, '/app/out', 'x3')]
    assert box.counts == {'/app/out': 3, '/led': 1}
