"""The suite's two lanes (fixtures/lanes.py): the rule, and a real ``pytest -n 2 --dist
loadgroup`` over a small tree that puts every integration test on one worker and the unit
tests and the VM test (and the other light files) on the other."""
import json
import os
import subprocess
import sys
import textwrap

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from fixtures import lanes  # noqa: E402

FIXTURES = os.path.join(os.path.dirname(HERE), 'fixtures')


def test_the_rule():
    assert lanes.lane('test/unit/test_yuv.py::test_x') == lanes.LIGHT
    assert lanes.lane('test/test_vm.py::test_v4l2loopback_and_image_sink_in_a_real_kernel') \
        == lanes.LIGHT
    assert lanes.lane('test/test_bench.py::test_bench_quick[scenario]') == lanes.LIGHT
    assert lanes.lane('test/test_tinyros.py::test_fuzz') == lanes.LIGHT
    assert lanes.lane('test/test_core.py::test_a') == lanes.INTEGRATION
    assert lanes.lane('test/test_readme_commands.py::test_p[docs/unit/x.md]') == lanes.LIGHT
    assert lanes.lane('test/test_studio.py::test_p[test/unit/x]') == lanes.INTEGRATION
    assert lanes.lane('test/unitary.py::t') == lanes.INTEGRATION


def _tree(root):
    os.makedirs(os.path.join(root, 'test', 'unit'))
    open(os.path.join(root, 'pytest.ini'), 'w').write('[pytest]\ntestpaths = test\n')
    open(os.path.join(root, 'test', 'conftest.py'), 'w').write(textwrap.dedent('''
        import sys
        sys.path.insert(0, %r)
        import lanes

        def pytest_configure(config):
            config.pluginmanager.register(lanes, 'lanes')
        ''' % FIXTURES))
    body = textwrap.dedent('''
        import json, os

        def _note(name):
            with open(os.path.join(%r, 'seen.jsonl'), 'a') as f:
                f.write(json.dumps([name, os.environ.get('PYTEST_XDIST_WORKER'),
                                    os.getpriority(os.PRIO_PROCESS, 0)]) + '\\n')
        ''' % root)
    files = {'test/test_core.py': 3, 'test/test_world.py': 3, 'test/test_vm.py': 1,
             'test/unit/test_a.py': 4, 'test/unit/test_b.py': 4}
    for path, n in files.items():
        tests = ''.join('def test_%d():\n    _note(%r)\n\n' % (i, '%s::%d' % (path, i))
                        for i in range(n))
        open(os.path.join(root, path), 'w').write(body + '\n' + tests)
    return sum(files.values())


def test_integration_tests_share_one_worker_and_the_light_lane_the_other(tmp_path):
    root = str(tmp_path)
    total = _tree(root)
    env = dict(os.environ, PYTEST_DISABLE_PLUGIN_AUTOLOAD='1')   # only xdist: a quick start
    env.pop('PYTEST_XDIST_WORKER', None)
    r = subprocess.run([sys.executable, '-m', 'pytest', '-p', 'no:cacheprovider', '-q',
                        '-p', 'xdist.plugin', '-n', '2', '--dist', 'loadgroup', 'test'], cwd=root, env=env,
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert r.returncode == 0, r.stdout[-3000:]
    seen = [json.loads(l) for l in open(os.path.join(root, 'seen.jsonl'))]
    assert len(seen) == total, seen
    base = os.getpriority(os.PRIO_PROCESS, 0)
    nice = {name: n for name, _w, n in seen}
    # a light test runs nice (the qemu test does not), an integration test at the priority
    # the run was started with
    assert {nice[n] for n in nice if n.startswith('test/unit/')} == \
        {max(base, lanes.LIGHT_NICE)}, nice
    assert nice['test/test_vm.py::0'] == base and \
        {nice[n] for n in nice if n.startswith(('test/test_core', 'test/test_world'))} == \
        {base}, nice
    workers = {}
    for name, worker, _n in seen:
        workers.setdefault(lanes.lane(name.split('::')[0] + '::t'), set()).add(worker)
    assert len(workers[lanes.INTEGRATION]) == 1, workers
    assert len(workers[lanes.LIGHT]) == 1, workers
    assert workers[lanes.INTEGRATION] != workers[lanes.LIGHT], workers
    # and in each lane in collection order
    integ = [n for n, _w, _n in seen if lanes.lane(n) == lanes.INTEGRATION]
    assert integ == sorted(integ, key=lambda n: (n.split('::')[0], int(n.split('::')[1])))


def test_without_xdist_nothing_is_marked():
    class Item(object):
        def __init__(self, nodeid):
            self.nodeid, self.marks = nodeid, []

        def get_closest_marker(self, name):
            return None

        def add_marker(self, mark):
            self.marks.append(mark)

    class Config(object):
        class option(object):
            dist = 'no'

    items = [Item('test/test_core.py::t'), Item('test/unit/test_a.py::t')]
    lanes.pytest_collection_modifyitems(None, Config(), items)
    assert all(not it.marks for it in items)
    Config.option.dist = 'loadgroup'
    lanes.pytest_collection_modifyitems(None, Config(), items)
    assert [it.marks[0].kwargs.get('name', it.marks[0].args[0]) for it in items] == \
        [lanes.INTEGRATION, lanes.LIGHT]


def test_no_two_test_files_share_a_name():
    """pytest imports test files by their base name (no packages): two files of one name in
    test/ and test/unit/ make the second an import-mismatch error and its tests never run
    (test/unit/test_studio_editor.py beside test/test_studio_editor.py, 2026-12-06)."""
    import collections
    root = os.path.dirname(HERE)
    names = collections.defaultdict(list)
    for d, _dirs, files in os.walk(root):
        if '__pycache__' in d or os.sep + 'data' in d[len(root):]:
            continue
        for f in files:
            if f.startswith('test_') and f.endswith('.py'):
                names[f].append(os.path.relpath(os.path.join(d, f), root))
    assert {n: p for n, p in names.items() if len(p) > 1} == {}
