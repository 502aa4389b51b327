"""`rosrun mobile_device_sim NAME` finds NAME among every executable file of the package's
tree (its source folder, where package.xml is, and the build's devel space): two executable
files of one name anywhere in the tree make rosrun ask "You have chosen a non-unique
executable, please pick one" and exit 127 without a terminal. bench/studio beside
sim_studio/nodes/studio did that to every `rosrun mobile_device_sim studio` (fresh clone of
2026-12-06 13:55). So no executable of the tree shares its name with a node."""
import collections
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SKIP = {'.git', 'build', '__pycache__', 'node_modules', 'out'}


def _executables(root):
    out = collections.defaultdict(list)
    for d, dirs, files in os.walk(root):
        dirs[:] = [x for x in dirs if x not in SKIP and not x.startswith('.')]
        for f in files:
            p = os.path.join(d, f)
            if os.path.isfile(p) and os.access(p, os.X_OK):
                out[f].append(os.path.relpath(p, root))
    return out


def test_no_executable_shares_a_nodes_name():
    exe = _executables(ROOT)
    nodes = sorted({f for f, paths in exe.items()
                    if any(p.split(os.sep)[1:2] == ['nodes'] for p in paths)})
    assert 'studio' in nodes and 'sim_world' in nodes and 'run_scenario' in nodes
    clashes = {n: sorted(exe[n]) for n in nodes if len(exe[n]) > 1}
    assert not clashes, 'rosrun would ask which one: %s' % clashes


def test_the_check_sees_a_clash(tmp_path):
    for p in ('sim_studio/nodes/studio', 'bench/studio', 'bench/other'):
        f = tmp_path / p
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text('#!/bin/sh\n')
        f.chmod(0o755)
    exe = _executables(str(tmp_path))
    assert sorted(exe['studio']) == ['bench/studio', 'sim_studio/nodes/studio']
    assert exe['other'] == ['bench/other']
