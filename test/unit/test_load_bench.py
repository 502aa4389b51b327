"""bench/load's comparison of two recordings: the first topic that differs, and how many."""
import importlib.machinery
import importlib.util
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _bench():
    path = os.path.join(ROOT, 'bench', 'load')
    loader = importlib.machinery.SourceFileLoader('bench_load', path)
    spec = importlib.util.spec_from_loader('bench_load', loader)
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    return mod


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
