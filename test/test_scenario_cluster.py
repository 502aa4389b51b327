"""The farm on Ray (issue 21), on a local two-node Ray cluster (ray.cluster_utils: two
raylets with one CPU each on this machine): a sweep of a real example runs on both nodes and
gives the same summary as a local --jobs 2 farm; a node killed mid-sweep has its run retried
on the other node, counted once and named as retried; an unreachable address is one line,
exit 2, within seconds."""
import json
import os
import re
import subprocess
import sys
import time

import pytest

from fixtures.scenario_cli import scenario_env

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
NODE = os.path.join(ROOT, 'testing_instance', 'nodes', 'run_scenario')
DECL = os.path.join(ROOT, 'testing_instance', 'examples', 'compass_declination.yaml')

ray = pytest.importorskip('ray', reason='Ray is installed by tools/setup')
pytestmark = pytest.mark.rostest


env = scenario_env


def sweep_cmd(out, *extra):
    # declination 0 and 10 (--shard 0/2 of 0, 5, 10, 20): one pass, one fail
    return [sys.executable, NODE, DECL, '--sweep', '--shard', '0/2', '--out', str(out)] + \
        list(extra)


def statuses(out):
    s = json.loads((out / 'summary.json').read_text())
    return s, {r['name']: r['status'] for r in s['runs']}


def _raylet_pid(node):
    from ray._private import ray_constants
    return node.all_processes[ray_constants.PROCESS_TYPE_RAYLET][0].process.pid


def _children():
    kids = {}
    for d in os.listdir('/proc'):
        if d.isdigit():
            try:
                with open('/proc/%s/stat' % d) as f:
                    ppid = int(f.read().rsplit(')', 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            kids.setdefault(ppid, []).append(int(d))
    return kids


def _runs_below(pid):
    """The run_scenario processes among the descendants of pid."""
    kids, todo, found = _children(), [pid], []
    while todo:
        for k in kids.get(todo.pop(), []):
            todo.append(k)
            try:
                with open('/proc/%d/cmdline' % k, 'rb') as f:
                    if b'run_scenario' in f.read():
                        found.append(k)
            except OSError:
                pass
    return found


@pytest.fixture
def cluster():
    """A head node without CPUs (the GCS; no runs) and two worker nodes with one CPU each.
    The submitter's driver attaches to one of the three raylets of this machine: the test
    kills a worker it is not attached to (a driver whose own raylet dies loses its tasks,
    on any Ray cluster)."""
    from ray.cluster_utils import Cluster
    c = Cluster(initialize_head=True, head_node_args={'num_cpus': 0})
    workers = [c.add_node(num_cpus=1), c.add_node(num_cpus=1)]
    c.wait_for_nodes()
    yield c, workers, c.address
    c.shutdown()


def test_unreachable_cluster_is_one_line(tmp_path):
    t0 = time.monotonic()
    p = subprocess.run(sweep_cmd(tmp_path / 'x', '--cluster', 'localhost:1'),
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=120, env=env())
    assert p.returncode == 2, p.stdout
    lines = [ln for ln in p.stdout.splitlines() if ln.strip()]
    assert lines == [ln for ln in lines if ln.startswith('ERROR')] and len(lines) == 1, p.stdout
    assert 'cannot reach the Ray cluster at localhost:1' in p.stdout
    assert time.monotonic() - t0 < 30


def test_cluster_sweep_equals_local_farm_and_survives_a_node(cluster, tmp_path,
                                                            declination_sweep):
    c, workers, address = cluster
    # the local --jobs 2 farm: the session's sweep (fixtures/example_farm.py)
    rc, text, local = declination_sweep
    assert rc == 1, text
    _, ref = statuses(local)
    assert sorted(ref.values()) == ['FAIL', 'PASS'], ref

    both = tmp_path / 'both'
    p = subprocess.run(sweep_cmd(both, '--cluster', address, '--junit', tmp_path / 'j',
                                 '--report', tmp_path / 'rc'), stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, timeout=600, env=env())
    assert p.returncode == 1, p.stdout
    s, got = statuses(both)
    assert got == ref, p.stdout
    assert s['mode'] == 'cluster' and len(s['nodes']) == 2, s['nodes']     # both nodes ran
    assert s['retried'] == [] and s['total'] == 2
    assert sorted(os.listdir(tmp_path / 'j')) == sorted(
        [r['id'] + '.xml' for r in s['runs']] + ['sweep.xml'])            # the local layout
    # --report: each run's report shipped back from its worker, and the farm index, laid out
    # as the local farm's
    layout = sorted(os.listdir(local / 'report'))
    assert layout == sorted([r['id'] for r in s['runs']] + ['index.html']), layout
    assert sorted(os.listdir(tmp_path / 'rc')) == layout
    for r in s['runs']:
        page = (tmp_path / 'rc' / r['id'] / 'index.html').read_text()
        assert ref[r['name']] in page and 'points_to_true_north' in page
    index = (tmp_path / 'rc' / 'index.html').read_text()
    assert all('href="%s/index.html"' % r['id'] in index for r in s['runs']), index

    # a node killed mid-sweep: its run is retried on the other node, counted once
    killed = tmp_path / 'killed'
    proc = subprocess.Popen(sweep_cmd(killed, '--cluster', address), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, env=env())
    first = proc.stdout.readline()
    m = re.search(r'submitted through node (\w+)', first)
    assert m, first
    victim = [w for w in workers if not w.node_id.startswith(m.group(1))][0]
    # kill the victim once its run is under way: a run_scenario below its raylet (a fixed
    # sleep raced: on a faster machine both runs had finished before the kill)
    deadline = time.monotonic() + 300
    while not _runs_below(_raylet_pid(victim)):
        assert proc.poll() is None and time.monotonic() < deadline, 'no run on the victim'
        time.sleep(0.05)
    time.sleep(1.0)
    c.remove_node(victim, allow_graceful=False)
    text, _ = proc.communicate(timeout=600)
    text = first + text
    assert proc.returncode == 1, text
    assert (killed / "summary.json").exists(), text
    s, got = statuses(killed)
    assert got == ref, text
    assert s['total'] == 2 and len(s['runs']) == 2
    assert len(s['retried']) == 1, text
    assert 'retried after a node died (counted once)' in text
