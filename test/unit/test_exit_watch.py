"""The suite's exit watch (test/fixtures/exit_watch.py, armed by conftest): a thread left
running after the last test is named, and the process exits 1 instead of hanging."""
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
TEST = os.path.dirname(HERE)

SCRIPT = '''
import sys, threading
sys.path.insert(0, %r)
from fixtures import exit_watch
stop = threading.Event()
if sys.argv[1] == 'leak':
    threading.Thread(target=stop.wait, name='forgotten writer').start()
exit_watch.arm(seconds=2)
print('main done', flush=True)
'''


def _run(mode):
    t0 = time.monotonic()
    p = subprocess.run([sys.executable, '-c', SCRIPT % TEST, mode], stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True, timeout=60)
    return p, time.monotonic() - t0


def test_a_thread_left_running_is_named_and_the_process_exits_1():
    p, took = _run('leak')
    assert p.returncode == 1, (p.returncode, p.stderr)
    assert 'main done' in p.stdout
    assert "threads still running after the last test" in p.stderr
    assert "'forgotten writer'" in p.stderr and 'Timeout' in p.stderr
    assert 'in wait' in p.stderr                   # the stack says where it waits
    assert took < 30


def test_without_a_leak_the_process_ends_at_once_with_its_own_status():
    p, took = _run('clean')
    assert p.returncode == 0, p.stderr
    assert p.stderr == '' and took < 30


LEAKY_TEST = '''
import threading
stop = threading.Event()

def test_quiet():
    assert True

def test_that_forgets_its_thread():
    threading.Thread(target=stop.wait, name='forgotten writer').start()

def test_after_it():
    assert True
'''


def test_under_pytest_the_thread_is_named_with_the_test_that_started_it(tmp_path):
    (tmp_path / 'test_leaky.py').write_text(LEAKY_TEST)
    env = dict(os.environ, PYTHONPATH=TEST + os.pathsep + os.environ.get('PYTHONPATH', ''))
    t0 = time.monotonic()
    p = subprocess.run([sys.executable, '-c',
                        'import sys, pytest\n'
                        'from fixtures import exit_watch\n'
                        'exit_watch.SECONDS = 2\n'
                        'sys.exit(pytest.main(["-q", "-p", "no:cacheprovider", "-p", '
                        '"fixtures.exit_watch", sys.argv[1]]))', str(tmp_path / 'test_leaky.py')],
                       cwd=str(tmp_path), env=env, stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True, timeout=120)
    assert '3 passed' in p.stdout, p.stdout
    assert p.returncode == 1, (p.returncode, p.stderr)
    assert ("'forgotten writer' (started in test_leaky.py::test_that_forgets_its_thread)"
            in p.stderr), p.stderr
    assert 'test_quiet' not in p.stderr and 'test_after_it' not in p.stderr
    assert time.monotonic() - t0 < 60


TWO_SPEEDS = '''
import time

def test_fast():
    assert True

def test_slow():
    time.sleep(3)
'''


def test_an_xdist_worker_idle_while_another_works_is_not_killed(tmp_path):
    """Under `-n 2` the worker that ran out of tests waits for the controller to end the
    run: no timer there (it once printed 'Timeout' and exited 1 mid-suite)."""
    (tmp_path / 'test_speeds.py').write_text(TWO_SPEEDS)
    env = dict(os.environ, MDS_EXIT_WATCH_SECONDS='1',
               PYTHONPATH=TEST + os.pathsep + os.environ.get('PYTHONPATH', ''))
    p = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                        '-p', 'fixtures.exit_watch', '-n', '2', '--dist', 'load',
                        str(tmp_path / 'test_speeds.py')],
                       cwd=str(tmp_path), env=env, stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, timeout=120)
    assert '2 passed' in p.stdout, p.stdout
    assert 'Timeout' not in p.stdout and p.returncode == 0, p.stdout


def test_the_seconds_come_from_the_environment_and_a_bad_value_is_named():
    import pytest
    from fixtures import exit_watch
    assert exit_watch._seconds({}) == 120
    assert exit_watch._seconds({'MDS_EXIT_WATCH_SECONDS': ' 7 '}) == 7
    with pytest.raises(ValueError, match="MDS_EXIT_WATCH_SECONDS must be a whole number of "
                                         "seconds, got 'soon'"):
        exit_watch._seconds({'MDS_EXIT_WATCH_SECONDS': 'soon'})
