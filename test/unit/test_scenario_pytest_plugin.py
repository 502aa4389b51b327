"""The pytest plugin of the testing instance (testing_instance.pytest_plugin): registered
through the pytest11 entry point, it collects scenario YAML files only (one item per file,
one per concrete run of a sweep), leaves other YAML files and the project's own suite
alone, and an invalid file is one failing item with the validator's FILE:LINE lines (no
world starts). pytest runs in subprocesses; no roscore."""
import importlib.metadata
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EX = os.path.join(ROOT, 'testing_instance', 'examples')


def pytest_run(*args, cwd=None):
    p = subprocess.run([sys.executable, '-m', 'pytest', '-p', 'no:cacheprovider'] +
                       [str(a) for a in args], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, cwd=cwd or ROOT, timeout=120)
    return p.returncode, p.stdout


def test_registered_through_the_pytest11_entry_point():
    eps = {e.name: e.value for e in importlib.metadata.entry_points(group='pytest11')}
    assert eps.get('scenarios') == 'testing_instance.pytest_plugin', eps
    with open(os.path.join(ROOT, 'setup.py')) as f:
        assert "'pytest11': ['scenarios = testing_instance.pytest_plugin']" in f.read()


def test_collects_scenarios_and_sweep_runs_only(tmp_path):
    (tmp_path / 'config.yaml').write_text('duration_of_x: 3\nfoo: [1, 2]\n')
    (tmp_path / 'not_a_scenario.yaml').write_text('duration: 3\nother: 1\n')
    rc, out = pytest_run('--collect-only', '-q', tmp_path, EX + '/compass_sweep.yaml',
                         EX + '/compass.yaml')
    items = [ln for ln in out.splitlines() if '::' in ln]
    assert len(items) == 25, out
    assert 'testing_instance/examples/compass.yaml::compass' in items
    assert 'testing_instance/examples/compass_sweep.yaml::compass_sweep[heading=30,seed=5]' \
        in items
    assert not any('config.yaml' in i or 'not_a_scenario' in i for i in items), out
    rc, out = pytest_run('--collect-only', '-q', '--scenario-defaults',
                         EX + '/compass_sweep.yaml')
    assert [ln for ln in out.splitlines() if '::' in ln] == [
        'testing_instance/examples/compass_sweep.yaml::compass_sweep'], out
    # -p no:scenarios switches it off; the project's own suite collects no YAML item
    rc, out = pytest_run('--collect-only', '-q', '-p', 'no:scenarios', EX)
    assert 'no tests collected' in out, out
    rc, out = pytest_run('--collect-only', '-q', 'test/unit')
    assert rc == 0 and '.yaml::' not in out and ' collected' in out, out[-2000:]


def test_invalid_scenario_is_one_failing_item_with_file_and_line(tmp_path):
    f = tmp_path / 'typo.yaml'
    f.write_text('parameters: {h: 0}\nduration: 2\ntimeline:\n'
                 "  - {at: 0.5, action: rotate, model: m, rpy: [0, 0, '${hh}']}\n"
                 'expect:\n  - {topic: /x, always: {gt: 1}}\n')
    rc, out = pytest_run('-q', '--junitxml', tmp_path / 'j.xml', f)
    assert rc == 1, out
    assert '1 failed' in out, out
    assert ("typo.yaml:4: timeline[0].rpy[2]: unknown parameter 'hh' in '${hh}' (did you mean "
            "'h'?); declared: h") in out, out
    assert 'Traceback' not in out
    assert '<failure' in (tmp_path / 'j.xml').read_text()


def test_master_ports_follow_xdist_s_own_worker_id(monkeypatch):
    from testing_instance import pytest_plugin as pp

    class Config(object):
        pass
    # a pytest started inside an xdist worker inherits PYTEST_XDIST_WORKER: not a worker
    monkeypatch.setenv('PYTEST_XDIST_WORKER', 'gw1')
    plain = pp.worker_port(Config())
    assert pp.PORT_BASE <= plain < pp.PORT_BASE + pp.PORT_SPAN, plain
    worker = Config()
    worker.workerinput = {'workerid': 'gw1'}
    port = pp.worker_port(worker)
    assert pp.PORT_BASE + 2 * pp.PORT_SPAN <= port < pp.PORT_BASE + 3 * pp.PORT_SPAN, port
    # every worker's range lies below the runs' own random draws (netutil.master_port)
    from sim_world.netutil import MASTER_PORTS
    worker.workerinput = {'workerid': 'gw40'}
    assert pp.PORT_BASE <= pp.worker_port(worker) < MASTER_PORTS[0]
    assert pp.PORT_BASE + pp.PORT_SPAN * pp.PORT_RANGES <= MASTER_PORTS[0]
