"""Fuzzed models through the real /gazebo/spawn_urdf_model and /gazebo/spawn_sdf_model of a
running office world (issue 19 item 3; the parser-level fuzzer is
test/unit/test_fuzz_spawn.py, whose mutations test/fixtures/fuzz_spawn_client.py sends):
every request is answered, success or ``SpawnModel: ...`` naming the problem on one line;
the world process stays alive; afterwards a clean spawn and /gazebo/get_model_state work
and sim time advances."""
import json
import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from fixtures.rosworld import node_pid, office_world  # noqa: E402

CLIENT = os.path.join(HERE, 'fixtures', 'fuzz_spawn_client.py')
N = int(os.environ.get('MDS_FUZZ_SPAWN_ROS', '60'))

pytestmark = pytest.mark.rostest


def run_client(env, n, seed=0, baseline=0, timeout=900):
    """The client's stats (seed 0: derandomized)."""
    p = subprocess.run([sys.executable, CLIENT, str(n), str(seed), str(baseline)],
                       env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                       timeout=timeout)
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith('{')]
    assert p.returncode == 0 and lines, (p.returncode, p.stdout[-2000:], p.stderr[-3000:])
    return json.loads(lines[-1])


def test_fuzzed_spawns_are_answered_and_the_world_keeps_working(tmp_path):
    with office_world(tmp_path) as env:
        pid = node_pid(env, '/sim_world')
        assert pid
        stats = run_client(env, N)
        assert stats['executions'] == N
        assert stats['findings'] == [], stats['findings']
        assert 0 < stats['successes'] < N, stats       # both kinds of answer were exercised
        assert node_pid(env, '/sim_world') == pid          # the same world process
        os.kill(pid, 0)
