"""sim_world.logonce.LogOnce: the one "log once" of the repository."""
import logging

from sim_world.logonce import LogOnce


def test_each_text_once_through_a_logger(caplog):
    once = LogOnce(logging.getLogger('t.once'))
    with caplog.at_level(logging.INFO):
        assert once.error('bad a') and not once.error('bad a')
        assert once.warning('bad b') and not once('bad b')
        assert once.info('x', key='k') and not once.error('y', key='k')
    assert [(r.levelname, r.getMessage()) for r in caplog.records] == [
        ('ERROR', 'bad a'), ('WARNING', 'bad b'), ('INFO', 'x')]


def test_until_changed_says_a_problem_again_after_another_or_ok():
    lines = []
    once = LogOnce(lines.append, until_changed=True)
    for text in ('a', 'a', 'b', 'a', 'a'):
        once(text)
    once.ok()
    once('a')
    assert lines == ['a', 'b', 'a', 'a']


def test_reset_and_another_logger_for_one_line():
    lines, other = [], []
    once = LogOnce(lines.append)
    once('a')
    once.reset()
    once('a')
    once.error('b', logger=other.append)
    assert lines == ['a', 'a'] and other == ['b']
