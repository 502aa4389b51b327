"""test/fixtures/env_kept.py: a test that loses an environment variable errors, named, and
the tests after it get the variable back."""
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
TEST = os.path.dirname(HERE)

PROBE = '''
import os

def test_deletes_a_variable():
    del os.environ['MDS_PROBE']

def test_changes_one_with_monkeypatch(monkeypatch):
    monkeypatch.setenv('MDS_PROBE', 'other')

def test_adds_one():
    os.environ['MDS_PROBE_NEW'] = '1'

def test_after_them():
    assert os.environ['MDS_PROBE'] == 'kept'
'''


def test_a_lost_variable_is_given_back_and_the_test_that_lost_it_errors(tmp_path):
    (tmp_path / 'test_probe.py').write_text(PROBE)
    env = dict(os.environ, MDS_PROBE='kept',
               PYTHONPATH=TEST + os.pathsep + os.environ.get('PYTHONPATH', ''))
    p = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                        '-p', 'fixtures.env_kept', '-rE', 'test_probe.py'],
                       cwd=str(tmp_path), env=env, stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, timeout=120)
    assert '4 passed, 1 error' in p.stdout, p.stdout
    assert 'ERROR at teardown of test_deletes_a_variable' in p.stdout, p.stdout
    assert 'the test removed or changed MDS_PROBE in os.environ' in p.stdout
    assert p.stdout.count('ERROR at teardown') == 1             # monkeypatch and a new one: fine
