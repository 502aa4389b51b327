"""Every benchmark keeps running: each executable file in bench/ (found by glob, so a
bench added later is covered without editing this file) is run with ``--quick`` in the
project environment (build/env.sh: the venv python, PYOPENGL_PLATFORM=osmesa,
ROS_HOSTNAME=localhost, ROS_HOME in build/). It must exit 0 within the time limit and print
its figures: at least one ``name: number`` line and at least one figure whose name says
``ratio`` (the project's figures are ratios to a baseline measured in the same run).
Wall-clock speed is not asserted: only that the bench runs and reports."""
import glob
import os
import re
import signal
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BENCHES = sorted(p for p in glob.glob(os.path.join(ROOT, 'bench', '*'))
                 if os.path.isfile(p) and os.access(p, os.X_OK))
#: --quick promises < 60 s on an unloaded machine; the suite's machine may be shared
TIMEOUT = int(os.environ.get('MDS_BENCH_TIMEOUT', '240'))
FIGURE = re.compile(r'^([A-Za-z0-9_.\-/]+):\s+(-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?|-?inf|nan)\s*$',
                    re.M)


def _env():
    build = os.environ.get('MDS_BUILD', os.path.join(ROOT, 'build'))
    env = dict(os.environ)
    venv_bin = os.path.join(build, 'venv', 'bin')
    if os.path.isdir(venv_bin):
        env['PATH'] = venv_bin + os.pathsep + env.get('PATH', '')
    env.setdefault('PYOPENGL_PLATFORM', 'osmesa')
    env['ROS_HOSTNAME'] = env.get('ROS_HOSTNAME') or 'localhost'
    env.setdefault('ROS_HOME', os.path.join(build, 'ros_home'))
    env.setdefault('ROS_LOG_DIR', os.path.join(env['ROS_HOME'], 'log'))
    os.makedirs(env['ROS_LOG_DIR'], exist_ok=True)
    env['PYTHONUNBUFFERED'] = '1'
    return env


def test_there_are_benches():
    assert BENCHES, 'no executable file in bench/'


@pytest.mark.slow
@pytest.mark.parametrize('bench', BENCHES, ids=[os.path.basename(b) for b in BENCHES])
def test_bench_quick(bench):
    env = _env()
    # '#!/usr/bin/env python3' finds the venv's python first on the PATH of env
    cmd = [bench, '--quick']
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)      # the bench and its roscore/nodes
        out, err = proc.communicate()
        pytest.fail('%s --quick did not finish in %d s\n%s\n%s' % (bench, TIMEOUT, out[-3000:],
                                                                    err[-3000:]))
    assert proc.returncode == 0, '%s --quick exited %d\n%s\n%s' % (
        bench, proc.returncode, out[-3000:], err[-5000:])
    figures = FIGURE.findall(out)
    assert figures, 'no "name: number" figure line in the output of %s:\n%s' % (bench, out[-3000:])
    ratios = [n for n, _ in figures if 'ratio' in n]
    assert ratios, 'no ratio figure in the output of %s:\n%s' % (bench, out[-3000:])
