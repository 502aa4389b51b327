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
    once = LogOnce(say=lines.append, until_changed=True)
    for text in ('a', 'a', 'b', 'a', 'a'):
        once(text)
    once.ok()
    once('a')
    assert lines == ['a', 'b', 'a', 'a']


class _Logger(object):
    """Not a logging.Logger: logging's methods only (like sim_world.node's rospy logger)."""

    def __init__(self):
        self.lines = []

    def error(self, fmt, *args):
        self.lines.append(('error', fmt % args))

    def warning(self, fmt, *args):
        self.lines.append(('warning', fmt % args))


def test_reset_and_another_logger_for_one_line():
    lines, other = [], _Logger()
    once = LogOnce(say=lines.append)
    once('a')
    once.reset()
    once('a')
    once.warning('b', logger=other)
    assert lines == ['a', 'a'] and other.lines == [('warning', 'b')]


def test_a_logger_with_logging_methods_only():
    lg = _Logger()
    once = LogOnce(lg)
    once.error('100%% bad')
    once.error('100%% bad')
    assert lg.lines == [('error', '100%% bad')]
