"""pytest collects scenario files (issue 21): ``pytest testing_instance/examples/``.

Registered through the ``pytest11`` entry point (setup.py; tools/setup writes the same entry
point into the catkin devel space), so sourcing build/env.sh is enough. Only YAML files that
are scenarios are collected: a ``*.yaml``/``*.yml`` file with a top-level ``duration:`` and a
top-level ``expect:`` or ``timeline:`` key (the project's own test/ suite has none, and other
YAML files are left alone). A file without a ``sweep:`` is one test item named after the
scenario; a file with a sweep gives one item per concrete run,
``compass_sweep.yaml::compass_sweep[heading=30,seed=4]`` (``--scenario-defaults``: only the
defaults). Each item runs ``run_scenario FILE --set ... --seed N`` in its own process with
its own master: under pytest-xdist each worker takes master ports from its own range
(worker gwN: 20000 + 1000 N ...), so ``pytest -n 2`` runs two worlds side by side. A failing
item's report holds the FAIL/ERROR lines and the command that reproduces it; ``-k``, ``-x``,
``--junitxml`` work as usual (the junit test case gets the master port and the run's
parameter values as properties). An invalid file is one failing item with the validator's
``FILE:LINE`` lines. ``-p no:scenarios`` switches the plugin off.
"""
import os
import re
import subprocess

import pytest

_TOP_DURATION = re.compile(r'^duration\s*:', re.M)
_TOP_BODY = re.compile(r'^(expect|timeline)\s*:', re.M)
#: master ports of the scenario items: process k (0 without xdist, N + 1 for worker gwN) takes
#: them from PORT_BASE + PORT_SPAN * (k % PORT_RANGES), all of them below the runs' own
#: random draws (sim_world.netutil.MASTER_PORTS, from 24000 on); a 17th worker shares the
#: first range, and a port taken meanwhile is retried on a new one (testing_instance.world.procs)
PORT_BASE, PORT_SPAN, PORT_RANGES = 20000, 250, 16


def is_scenario(path):
    """A YAML file that is a scenario (top-level duration: and expect:/timeline:)."""
    if not str(path).endswith(('.yaml', '.yml')):
        return False
    try:
        with open(str(path), errors='replace') as f:
            text = f.read(200000)
    except OSError:
        return False
    return bool(_TOP_DURATION.search(text) and _TOP_BODY.search(text))


def pytest_addoption(parser):
    g = parser.getgroup('scenarios', 'mobile_device_sim scenario files')
    g.addoption('--scenario-defaults', action='store_true', default=False,
                help='collect a sweep file as one item with its defaults, not one per run')
    g.addoption('--scenario-seed', type=int, default=None, metavar='N',
                help='override every scenario\'s seed')
    g.addoption('--scenario-timeout', type=float, default=900.0, metavar='S',
                help='wall-clock limit of one scenario run (default 900 s)')


def pytest_collect_file(parent, file_path):
    if is_scenario(file_path):
        return ScenarioFile.from_parent(parent, path=file_path)
    return None


class ScenarioFile(pytest.File):
    def collect(self):
        from ..scenario.format import ScenarioError
        from .sweep import plan
        cfg = self.config
        try:
            runs = plan([str(self.path)], sweep=not cfg.getoption('--scenario-defaults'),
                        seed=cfg.getoption('--scenario-seed'))
        except ScenarioError as e:
            yield InvalidScenario.from_parent(
                self, name=os.path.splitext(self.path.name)[0], problems=e.problems)
            return
        for r in runs:
            yield ScenarioItem.from_parent(self, name=r.name, run=r)


class ScenarioFailure(Exception):
    pass


class _ScenarioReport(pytest.Item):
    """What both item kinds report: a ScenarioFailure as its own text (the FAIL lines),
    the scenario's name as the location."""

    def repr_failure(self, excinfo, style=None):
        if isinstance(excinfo.value, ScenarioFailure):
            return str(excinfo.value)
        return super().repr_failure(excinfo)

    def reportinfo(self):
        return self.path, 0, 'scenario %s' % self.name


class InvalidScenario(_ScenarioReport):
    def __init__(self, *, problems, **kw):
        super().__init__(**kw)
        self.problems = problems

    def runtest(self):
        raise ScenarioFailure('ERROR scenario file %s is invalid:\n%s' % (
            self.path, '\n'.join('  ' + p for p in self.problems)))


def _free(port):
    from sim_world.netutil import bindable
    return bindable(port, 'localhost')


_counter = [0]


def worker_port(config):
    """The next free master port of this process's range (xdist worker gwN: range N+1;
    no xdist: range 0). The worker id is xdist's own (config.workerinput), not the
    PYTEST_XDIST_WORKER variable, which a pytest started inside an xdist worker inherits."""
    wid = str(getattr(config, 'workerinput', {}).get('workerid', ''))
    k = int(wid[2:]) + 1 if wid.startswith('gw') and wid[2:].isdigit() else 0
    base = PORT_BASE + PORT_SPAN * (k % PORT_RANGES)
    for _ in range(PORT_SPAN):
        port = base + _counter[0] % PORT_SPAN
        _counter[0] += 1
        if _free(port):
            return port
    from ..run.runner import free_port
    return free_port()


class ScenarioItem(_ScenarioReport):
    def __init__(self, *, run, **kw):
        super().__init__(**kw)
        self.run = run
        for k, v in run.values.items():
            self.user_properties.append((k, v))

    def runtest(self):
        from .sweep import run_command, run_env, verdict_lines
        port = worker_port(self.config)
        self.user_properties.append(('master_port', port))
        self.user_properties.append(('seed', self.run.seed))
        cmd = run_command(self.run) + ['--port', str(port)]
        try:
            p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               text=True, env=run_env(),
                               timeout=self.config.getoption('--scenario-timeout'))
            rc, text = p.returncode, p.stdout
        except subprocess.TimeoutExpired as e:
            rc, text = 2, (e.stdout or '') + '\nERROR the run took longer than ' \
                '--scenario-timeout'
            if isinstance(text, bytes):
                text = text.decode(errors='replace')
        self.output = text
        if rc != 0:
            lines = [ln for ln in verdict_lines(text) if not ln.startswith('PASS ')]
            if not lines:
                lines = text.splitlines()[-15:]
            head = '%s %s (exit %d)' % ('FAIL' if rc == 1 else 'ERROR', self.run.name, rc)
            raise ScenarioFailure('\n'.join([head] + lines + [
                'reproduce: ' + self.run.reproduce()]))

