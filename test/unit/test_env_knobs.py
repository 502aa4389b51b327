"""The environment's duration knobs (MDS_STOP_GRACE, MDS_APP_HANG_AFTER): a bad value is one
line naming the variable and its value, and the default is used; the import does not fail."""
import os
import subprocess
import sys

import pytest

from testing_instance.world.procs import env_seconds

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.mark.parametrize('text', ['abc', '', 'nan', 'inf', '-1', '0'])
def test_a_bad_value_is_named_and_the_default_used(monkeypatch, capsys, text):
    monkeypatch.setenv('MDS_TEST_KNOB', text)
    assert env_seconds('MDS_TEST_KNOB', 7.0) == 7.0
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'MDS_TEST_KNOB=%r' % text in err and 'using 7' in err


def test_a_good_value_and_an_unset_one(monkeypatch, capsys):
    monkeypatch.setenv('MDS_TEST_KNOB', '2.5')
    assert env_seconds('MDS_TEST_KNOB', 7.0) == 2.5
    monkeypatch.delenv('MDS_TEST_KNOB')
    assert env_seconds('MDS_TEST_KNOB', 7.0) == 7.0
    assert capsys.readouterr().err == ''


def test_the_modules_import_with_bad_knobs():
    env = dict(os.environ, MDS_STOP_GRACE='ten', MDS_APP_HANG_AFTER='-3',
               PYTHONPATH=os.path.join(ROOT, 'testing_instance', 'src') + os.pathsep +
               os.environ.get('PYTHONPATH', ''))
    p = subprocess.run([sys.executable, '-c', 'from testing_instance.world import apps, procs; '
                        'print(procs.STOP_GRACE, apps.HANG_AFTER)'],
                       env=env, capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ['10.0', '10.0']
    assert "MDS_STOP_GRACE='ten'" in p.stderr and "MDS_APP_HANG_AFTER='-3'" in p.stderr
    assert 'Traceback' not in p.stderr
