"""Where vnc_image_client's password comes from (vnc_image_client.node.PasswordSource)."""
import os

from vnc_image_client.node import PasswordSource, read_password_file


class FakeStdin(object):
    def __init__(self, tty):
        self.tty = tty

    def isatty(self):
        return self.tty


def test_parameter_value_wins_and_is_never_re_asked():
    asked = []
    s = PasswordSource('secret', stdin=FakeStdin(True), prompt=lambda p: asked.append(p) or 'x')
    assert s() == 'secret' and s() == 'secret'
    assert asked == []
    assert s.retry() is False            # a wrong parameter value is not retried


def test_tty_prompt_without_parameter_then_cached():
    asked = []
    s = PasswordSource(None, stdin=FakeStdin(True), where='h:1',
                       prompt=lambda p: asked.append(p) or 'typed')
    assert s() == 'typed' and s() == 'typed'
    assert asked == ['Password for VNC server h:1: ']
    assert s.retry() is True             # rejected: ask again ...
    assert s() == 'typed' and len(asked) == 2
    s.retry()
    s()
    assert s.retry() is False            # ... at most three times


def test_no_tty_no_parameter_gives_nothing():
    s = PasswordSource(None, stdin=FakeStdin(False), prompt=lambda p: 1 / 0)
    assert s() is None
    assert s.retry() is False


def test_password_file(tmp_path):
    p = tmp_path / 'pw'
    p.write_bytes(b'pa ss\r\nsecond line\n')
    errors = []
    assert read_password_file(str(p), errors.append) == 'pa ss'
    assert read_password_file(str(tmp_path / 'missing'), errors.append) is None
    assert len(errors) == 1 and 'missing' in errors[0] and 'No such file' in errors[0]
    os.chmod(str(p), 0o600)
