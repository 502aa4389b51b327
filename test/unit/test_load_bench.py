"""bench/load's comparison of two recordings: the first topic that differs, and how many."""
from fixtures.bench_module import load_bench


def _bench():
    return load_bench('load')


REF = {'/a': [(1, b'x')], '/b': [(2, b'y')], '/c': [(3, b'z'), (4, b'w')]}


def test_the_same_recordings_have_no_difference():
    assert _bench().first_difference(REF, dict(REF)) is None


def test_the_first_topic_that_differs_says_where_and_the_others_are_counted():
    load = _bench()
    got = dict(REF, **{'/b': [(5, b'y')], '/c': [(3, b'z')]})
    assert load.first_difference(REF, got) == (
        '/b: message 0 differs (recorded at 2 vs 5 ns); 2 topics differ (also /c)')
    assert load.first_difference(REF, dict(REF, **{'/c': [(3, b'z')]})) == \
        '/c: 2 vs 1 messages'
    many = {'/t%d' % i: [(i, b'')] for i in range(9)}
    line = load.first_difference(many, {})
    assert line.startswith('/t0: 1 vs 0 messages; 9 topics differ (also /t1, /t2, /t3, /t4, '
                           '/t5, ...)'), line
