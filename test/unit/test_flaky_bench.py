"""bench/flaky's reading of JUnit files and its tally, and the seeded test order it runs the
suite in (test/fixtures/shuffle.py)."""
from types import SimpleNamespace

from fixtures import shuffle
from fixtures.bench_module import load_bench


def _bench():
    return load_bench('flaky')


JUNIT = '''<?xml version="1.0" encoding="utf-8"?>
<testsuites><testsuite name="pytest" errors="1" failures="1" skipped="1" tests="5">
<testcase classname="test.unit.test_a" name="test_ok" time="0.1"/>
<testcase classname="test.unit.test_a" name="test_bad" time="0.1">
  <failure message="assert 1 == 2&#10;more">trace</failure></testcase>
<testcase classname="test.unit.test_b" name="test_err" time="0.1">
  <error message="RuntimeError: boom">trace</error></testcase>
<testcase classname="test.unit.test_b" name="test_skip" time="0.0">
  <skipped message="no qemu"/></testcase>
<testcase classname="test.unit.test_b" name="test_teardown" time="0.1"/>
<testcase classname="test.unit.test_b" name="test_teardown" time="0.1">
  <error message="teardown failed">trace</error></testcase>
</testsuite></testsuites>'''


def test_results_read_every_outcome_and_an_error_in_teardown(tmp_path):
    b = _bench()
    p = tmp_path / 'j.xml'
    p.write_text(JUNIT)
    r = b.results(str(p))
    assert r['test.unit.test_a::test_ok'] == ('passed', '')
    assert r['test.unit.test_a::test_bad'][0] == 'failed'
    assert r['test.unit.test_a::test_bad'][1].startswith('assert 1 == 2')
    assert r['test.unit.test_a::test_bad'][1].endswith('\n\ntrace')     # the traceback too
    assert r['test.unit.test_b::test_err'] == ('failed', 'RuntimeError: boom\n\ntrace')
    assert r['test.unit.test_b::test_skip'][0] == 'skipped'
    assert r['test.unit.test_b::test_teardown'] == ('failed', 'teardown failed\n\ntrace')
    assert b.results(str(tmp_path / 'missing.xml')) == {}
    (tmp_path / 'cut.xml').write_text(JUNIT[:200])
    assert b.results(str(tmp_path / 'cut.xml')) == {}


def test_tally_counts_results_failures_and_the_seeds_that_replay_them():
    b = _bench()
    t = b.Tally()
    t.add('quiet', 11, {'a::x': ('passed', ''), 'a::y': ('failed', 'assert 0\nmore'),
                        'a::s': ('skipped', '')})
    t.add('quiet', 12, {'a::x': ('passed', ''), 'a::y': ('passed', '')})
    t.add('loaded', 13, {'a::x': ('failed', 'late'), 'a::y': ('failed', 'again')})
    assert t.tests == {'a::x', 'a::y'}
    assert t.pass_rate('quiet') == 0.75 and t.pass_rate('loaded') == 0.0
    lines = t.lines(['quiet', 'loaded'])
    assert 'flaky_tests: 2' in lines and 'flaky_failures_quiet: 1' in lines
    assert 'flaky_tests_failed_loaded: 2' in lines and 'flaky_runs_loaded: 1' in lines
    assert 'failed: a::y quiet 1/2 loaded 1/1 seeds [11, 13]: assert 0' in lines
    assert 'failed: a::x quiet 0/2 loaded 1/1 seeds [13]: late' in lines


ROSTEST_MESSAGE = """AssertionError: ... logging to /x/rostest-vm-1.log
  [INFO] [1795949120.759891]: vnc_image_client: 127.0.0.1:30853 -> /vnc_image
E         test_3_wrong_password (__main__.VncNodeTest.test_3_wrong_password) ... FAIL
E         FAIL: test_3_wrong_password (__main__.VncNodeTest.test_3_wrong_password)
E         ----------------------------------------------------------------------
E         Traceback (most recent call last):
E           File "/x/vnc_image_client_rostest.py", line 141, in test_3_wrong_password
E             self.assertEqual(len(errs), 1, [e.msg for e in errs])
E         AssertionError: 0 != 1 : []
E         FAILED (failures=1)"""


def test_a_rostests_headline_is_its_unittest_failure_and_the_whole_text_is_kept():
    """A rostest's message is its whole output (log lines first): the line printed is
    unittest's FAIL line with its error (found: the first line said nothing of what
    failed), and every failure's whole text is kept with its way and seed."""
    b = _bench()
    assert b.headline(ROSTEST_MESSAGE) == (
        'FAIL: test_3_wrong_password: AssertionError: 0 != 1 : []')
    assert b.headline('assert 1 == 2\nmore') == 'assert 1 == 2'
    assert b.headline('') == ''
    t = b.Tally()
    t.add('loaded', 7, {'r::vnc': ('failed', ROSTEST_MESSAGE)})
    assert ('failed: r::vnc quiet 0/0 loaded 1/1 seeds [7]: FAIL: test_3_wrong_password: '
            'AssertionError: 0 != 1 : []') in t.lines(['quiet', 'loaded'])
    assert t.texts == [('r::vnc', 'loaded', 7, ROSTEST_MESSAGE)]


def _items(spec):
    return [SimpleNamespace(nodeid='%s::%s' % (f, t)) for f, t in spec]


def test_shuffle_moves_whole_files_and_the_seed_brings_the_order_back():
    spec = [('f%d.py' % i, 't%d' % j) for i in range(8) for j in range(3)]
    items = _items(spec)
    a = shuffle.by_file(items, 7)
    assert shuffle.by_file(items, 7) == a                       # the same seed, the same order
    assert sorted(id(x) for x in a) == sorted(id(x) for x in items)
    files = [x.nodeid.split('::')[0] for x in a]
    runs = [f for k, f in enumerate(files) if k == 0 or files[k - 1] != f]
    assert len(runs) == 8                                       # each file's tests together
    for f in set(files):
        assert [x.nodeid for x in a if x.nodeid.startswith(f + '::')] == \
            ['%s::t%d' % (f, j) for j in range(3)]              # and in their own order
    orders = {tuple(runs)} | {tuple(dict.fromkeys(x.nodeid.split('::')[0]
                                                  for x in shuffle.by_file(items, s)))
                              for s in range(1, 6)}
    assert len(orders) > 1                                      # seeds give other orders


def test_no_seed_no_change_and_a_bad_seed_is_one_clear_line(monkeypatch):
    monkeypatch.delenv(shuffle.ENV, raising=False)
    assert shuffle.seed() is None
    monkeypatch.setenv(shuffle.ENV, ' 42 ')
    assert shuffle.seed() == 42
    monkeypatch.setenv(shuffle.ENV, 'abc')
    try:
        shuffle.seed()
    except ValueError as e:
        assert str(e) == "MDS_SHUFFLE_SEED must be an integer, got 'abc'"
    else:
        raise AssertionError('a bad seed was taken')


def test_a_repetition_that_ran_no_test_breaks_the_bench_with_pytests_words(tmp_path):
    """No result at all (not even a skip) is the bench's error, not a pass rate of nan."""
    flaky = _bench()
    junit = tmp_path / 'none.xml'
    said = flaky.ran_nothing(flaky.results(str(junit)), [
        'no tests ran in 0.48s', 'ERROR: file or directory not found: test/x.py'], 7)
    assert said == ('bench/flaky: a repetition (seed 7) ran no test; pytest said:\n'
                    '  no tests ran in 0.48s\n'
                    '  ERROR: file or directory not found: test/x.py')
    junit.write_text(JUNIT)
    assert flaky.ran_nothing(flaky.results(str(junit)), [], 7) is None
    skipped_only = JUNIT.split('<testcase')[0] + '<testcase classname="a" name="t">' \
        '<skipped message="no qemu"/></testcase></testsuite></testsuites>'
    junit.write_text(skipped_only)
    assert flaky.ran_nothing(flaky.results(str(junit)), [], 7) is None   # a skip is a result
