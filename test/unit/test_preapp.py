"""A scenario's Python app started before the world is ready (testing_instance.world.preapp,
procs.PreApp): it imports the libraries its script imports at its top, talks to no master
until it is told the run's, then runs the script as ``python3 SCRIPT ARGS`` would."""
import json
import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from testing_instance.world import procs
from testing_instance.world.preapp import leading_imports, outside


def test_leading_imports_are_the_imports_before_the_first_other_statement(tmp_path):
    f = tmp_path / 'app.py'
    f.write_text('"""doc"""\nfrom __future__ import annotations\nimport math, os.path\n'
                 'import rospy\nfrom sensor_msgs.msg import Imu\n'
                 'import numpy as np\nX = 1\nimport cv2\n')
    assert leading_imports(str(f)) == ['math', 'os.path', 'rospy', 'sensor_msgs.msg', 'numpy']
    f.write_text('import sys\nsys.path.insert(0, "lib")\nimport mylib\n')
    assert leading_imports(str(f)) == ['sys']            # what follows may need that path
    f.write_text('import json\nfrom . import sibling\nimport yaml\n')
    assert leading_imports(str(f)) == ['json']
    f.write_text('def broken(:\n')
    assert leading_imports(str(f)) == []                 # the script says so itself
    assert leading_imports(str(tmp_path / 'missing.py')) == []


def test_only_libraries_outside_the_apps_folder_are_imported_early(tmp_path, monkeypatch):
    (tmp_path / 'helper.py').write_text('X = 1\n')
    (tmp_path / 'pkg').mkdir()
    (tmp_path / 'pkg' / '__init__.py').write_text('')
    monkeypatch.syspath_prepend(str(tmp_path))
    here = str(tmp_path)
    assert outside('json', here) and outside('sys', here) and outside('rospy', here)
    assert outside('sensor_msgs.msg', here)
    assert not outside('helper', here) and not outside('pkg.sub', here)
    assert not outside('no_such_module_anywhere', here)
    assert not outside('json', '/')                      # everything is below /


APP = '''\
"""An app: what it was started with, as a JSON line."""
import json
import os
import sys
print(json.dumps({'argv': sys.argv, 'name': __name__, 'file': __file__,
                  'path0': sys.path[0], 'cwd': os.getcwd(),
                  'master': os.environ.get('ROS_MASTER_URI')}))
sys.exit(int(os.environ.get('APP_EXIT', '0')))
'''


def _app(tmp_path, text=APP):
    d = tmp_path / 'apps'
    d.mkdir(exist_ok=True)
    f = d / 'app.py'
    f.write_text(text)
    return f


def _listening():
    s = socket.socket()
    s.bind(('127.0.0.1', 0))
    s.listen(8)
    s.settimeout(0.2)
    return s


def _uri(s):
    return 'http://127.0.0.1:%d' % s.getsockname()[1]


def test_a_prestarted_app_runs_as_python_would_run_it_once_told_the_master(tmp_path):
    f = _app(tmp_path)
    env_master, given = _listening(), _listening()
    given_uri = _uri(given)
    env = dict(os.environ, ROS_MASTER_URI=_uri(env_master), PYTHONUNBUFFERED='1')
    log = tmp_path / 'app.log'
    p = procs.PreApp(str(f), ['a b', '_rate:=2', '__name:=app'], env, str(log),
                     cwd=str(tmp_path))
    try:
        assert 'app.py' in ' '.join(procs.cmdline(p.p.pid))   # found by its script's name
        deadline = time.monotonic() + 1.0
        while time.monotonic() < deadline:                     # no master before go
            with pytest.raises(socket.timeout):
                env_master.accept()
        assert p.alive() and log.read_text() == ''            # the script has not run
        p.go(given_uri)
        p.p.wait(30)
    finally:
        p.stop(grace=5.0)
        env_master.close()
        given.close()
    assert p.p.returncode == 0, log.read_text()
    seen = json.loads(log.read_text().strip().splitlines()[-1])
    assert seen['argv'] == [str(f), 'a b', '_rate:=2', '__name:=app']
    assert seen['name'] == '__main__' and seen['file'] == str(f)
    assert seen['path0'] == str(tmp_path / 'apps') and seen['cwd'] == str(tmp_path)
    assert seen['master'] == given_uri


def test_the_scripts_libraries_are_imported_before_go_its_own_modules_after(tmp_path):
    lib, marks = tmp_path / 'lib', tmp_path / 'marks'
    lib.mkdir()
    probe = 'import os\nwith open(%r, "a") as f:\n    f.write("%s\\n")\n'
    (lib / 'probe_lib.py').write_text(probe % (str(marks), 'library'))
    f = _app(tmp_path, 'import os\nimport probe_lib\nimport probe_own\nprint("ran")\n')
    (tmp_path / 'apps' / 'probe_own.py').write_text(probe % (str(marks), 'own'))
    env = dict(os.environ, PYTHONUNBUFFERED='1', PYTHONPATH=str(lib))
    p = procs.PreApp(str(f), [], env, str(tmp_path / 'a.log'))
    try:
        deadline = time.monotonic() + 20
        while not marks.exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.3)
        assert marks.read_text() == 'library\n'         # before go: the library alone
        p.go('http://127.0.0.1:1')
        assert p.p.wait(30) == 0
    finally:
        p.stop(grace=5.0)
    assert marks.read_text() == 'library\nown\n'       # each imported once
    assert (tmp_path / 'a.log').read_text() == 'ran\n'


def test_exit_codes_and_tracebacks_are_the_scripts(tmp_path):
    f = _app(tmp_path)
    env = dict(os.environ, PYTHONUNBUFFERED='1', APP_EXIT='3')
    p = procs.PreApp(str(f), [], env, str(tmp_path / 'a.log'))
    p.go('http://127.0.0.1:1')
    assert p.p.wait(30) == 3
    p.finish(time.monotonic())
    (tmp_path / 'apps' / 'app.py').write_text('import os\nraise RuntimeError("no camera")\n')
    p = procs.PreApp(str(f), [], env, str(tmp_path / 'b.log'))
    p.go('http://127.0.0.1:1')
    assert p.p.wait(30) == 1
    p.finish(time.monotonic())
    text = (tmp_path / 'b.log').read_text()
    assert 'RuntimeError: no camera' in text and 'Traceback' in text
    # a library that fails to import early is the script's own error, as without PreApp
    (tmp_path / 'apps' / 'app.py').write_text('import no_such_lib_x\n')
    p = procs.PreApp(str(f), [], env, str(tmp_path / 'c.log'))
    p.go('http://127.0.0.1:1')
    assert p.p.wait(30) == 1
    p.finish(time.monotonic())
    assert "No module named 'no_such_lib_x'" in (tmp_path / 'c.log').read_text()


def test_without_go_the_script_never_runs(tmp_path):
    f = _app(tmp_path)
    env = dict(os.environ, PYTHONUNBUFFERED='1')
    p = procs.PreApp(str(f), [], env, str(tmp_path / 'a.log'))
    p.p.stdin.close()                   # the run ended before the world was ready
    assert p.p.wait(30) == 0
    p.finish(time.monotonic())
    assert (tmp_path / 'a.log').read_text() == ''
    # or the run stops it (SIGINT), once it imports (its libraries) or waits: quietly, and
    # also when it came with SIGINT ignored (a runner in the background of a shell: CI)
    lib, marks = tmp_path / 'lib', tmp_path / 'marks'
    lib.mkdir()
    (lib / 'probe_lib.py').write_text('open(%r, "a").write("x")\n' % str(marks))
    f.write_text('import probe_lib\nprint("ran")\n')
    old = signal.getsignal(signal.SIGINT)
    try:
        for ignored in (False, True):
            # what the children inherit
            signal.signal(signal.SIGINT, signal.SIG_IGN if ignored else old)
            if marks.exists():
                marks.unlink()
            q = procs.PreApp(str(f), [], dict(env, PYTHONPATH=str(lib)),
                             str(tmp_path / 'b.log'))
            deadline = time.monotonic() + 30
            while not marks.exists() and time.monotonic() < deadline:
                time.sleep(0.02)
            q.stop(grace=10.0)
            assert q.p.returncode == 0 and (tmp_path / 'b.log').read_text() == '', ignored
    finally:
        signal.signal(signal.SIGINT, old)
    q = procs.PreApp(str(f), [], env, str(tmp_path / 'c.log'))
    q.stop(grace=5.0)                   # at once
    assert not q.alive()
    assert sys.executable == q.cmd[0]


RUNNER = '''\
import sys, time
sys.path.insert(0, %r)
from testing_instance.world import procs
p = procs.PreApp(sys.argv[1], [], None, sys.argv[2])
p.go(sys.argv[3])
print(p.p.pid, flush=True)
time.sleep(600)
'''


def test_an_app_whose_shutdown_hangs_goes_a_grace_after_its_runner_is_killed(tmp_path):
    """Found in CI: run_scenario SIGKILLed while its app was in a call to the master left the
    app running for good. The parent-death SIGTERM ran rospy's handler in the app's main
    thread, whose shutdown waited for the lock of the master proxy that thread held. Here
    the master accepts the app's call and never answers: its shutdown hangs too."""
    from testing_instance.world import preapp
    kid = tmp_path / 'kid'
    f = _app(tmp_path, 'import subprocess\nimport rospy\n'        # a child of its own too
             'open(%r, "w").write(str(subprocess.Popen(["sleep", "600"]).pid))\n'
             'rospy.init_node("stuck")\nrospy.spin()\n' % str(kid))
    master = _listening()
    master.settimeout(30)
    log = tmp_path / 'app.log'
    src = os.path.dirname(os.path.dirname(os.path.abspath(procs.__file__)))
    runner = subprocess.Popen([sys.executable, '-c', RUNNER % src, str(f), str(log),
                               _uri(master)], stdout=subprocess.PIPE, text=True)
    app = int(runner.stdout.readline())
    held = []
    try:
        held.append(master.accept()[0])              # the app is in its call to the master
        time.sleep(0.5)
        assert procs.alive(app)
        runner.kill()
        runner.wait()
        gone = time.monotonic()
        deadline = gone + preapp.GRACE + 20
        while procs.alive(app) and time.monotonic() < deadline:
            time.sleep(0.05)
        took = time.monotonic() - gone
        assert not procs.alive(app), log.read_text()
        child = int(kid.read_text())
        deadline = time.monotonic() + 10
        while procs.alive(child) and time.monotonic() < deadline:
            time.sleep(0.05)                             # (a zombie until init reaps it)
        assert not procs.alive(child)                    # its group went with it
    finally:
        if procs.alive(app):
            os.kill(app, signal.SIGKILL)
        for s in held:
            s.close()
        master.close()
    # it did hang: it went by the watch, once the grace was over
    assert took >= preapp.GRACE - 0.5
    assert 'the runner is gone and the app did not end in 5 s' in log.read_text()


def test_a_finished_runner_keeps_the_apps_stdin_to_itself(tmp_path):
    """The script reads /dev/null, not the runner's pipe; the runner's end closes at finish."""
    f = _app(tmp_path, 'import sys\nprint(repr(sys.stdin.read()))\n')
    p = procs.PreApp(str(f), [], dict(os.environ, PYTHONUNBUFFERED='1'),
                     str(tmp_path / 'a.log'))
    p.go('http://127.0.0.1:1')
    assert p.p.wait(30) == 0
    assert not p.p.stdin.closed          # open while the app runs
    p.finish(time.monotonic())
    assert p.p.stdin.closed
    assert (tmp_path / 'a.log').read_text() == "''\n"
