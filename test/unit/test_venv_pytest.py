"""Issue 46: after `source build/env.sh`, `pytest` is the venv's entry script (tools/setup
writes it; pytest itself is Debian's, seen through --system-site-packages) with
pytest-xdist and the scenario plugin, not whatever else is on PATH (/usr/bin/pytest, a pyenv
shim) -- README's `pytest -n 2 testing_instance/examples/compass_sweep.yaml`."""
import os
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENV_SH = os.path.join(ROOT, 'build', 'env.sh')

pytestmark = pytest.mark.skipif(not os.path.isfile(ENV_SH),
                                reason='build/env.sh missing: tools/setup has not run')


def in_env(cmd):
    return subprocess.run(['bash', '-c', 'source "%s" && %s' % (ENV_SH, cmd)], cwd='/tmp',
                          capture_output=True, text=True, timeout=120)


def test_pytest_is_the_venvs_with_xdist_and_the_scenario_plugin():
    r = in_env('command -v pytest')
    assert r.returncode == 0, r.stderr
    path = r.stdout.strip()
    assert path == os.path.join(ROOT, 'build', 'venv', 'bin', 'pytest'), path
    with open(path) as f:
        first = f.readline()
    assert first.strip() == '#!' + os.path.join(ROOT, 'build', 'venv', 'bin', 'python3')
    r = in_env('pytest --help')
    assert r.returncode == 0, r.stderr[-2000:]
    assert '--numprocesses' in r.stdout                 # pytest-xdist: -n
    assert '--scenario-seed' in r.stdout                # testing_instance.pytest_plugin
