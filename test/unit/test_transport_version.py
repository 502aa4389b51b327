"""The transport's check at import (sim_world.transport.version): rospy must be the version
the layer was written for (Debian 12's python3-rospy) and have every attribute the layer
patches or reads; else one line naming the version and the attribute, and the sim_world node
and run_scenario stop at start with that line, no traceback."""
import os
import subprocess
import sys

import pytest

pytest.importorskip('rospy')

from sim_world.transport import version  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _one_line(exc):
    text = str(exc.value)
    assert '\n' not in text and text.startswith('sim_world.transport: ')
    return text


def test_this_rospy_is_the_one_the_layer_was_written_for():
    assert version.rospy_version() == version.WRITTEN_FOR == '1.15.15'
    assert version.missing() is None
    version.check(env={})                         # nothing raised


def test_a_missing_attribute_is_named_with_the_version(monkeypatch):
    from rospy.impl.tcpros_pubsub import QueuedConnection
    monkeypatch.delattr(QueuedConnection, '_run')
    with pytest.raises(version.RospyMismatch) as e:
        version.check(env={})
    text = _one_line(e)
    assert 'written for rospy 1.15.15' in text and 'found rospy 1.15.15' in text
    assert 'rospy.impl.tcpros_pubsub.QueuedConnection._run' in text


def test_a_missing_module_or_field_is_named():
    with pytest.raises(version.RospyMismatch) as e:
        version.check(attributes=[('rospy.impl.no_such_module', 'X')], env={})
    assert 'without rospy.impl.no_such_module,' in _one_line(e)
    with pytest.raises(version.RospyMismatch) as e:
        version.check(fields=[('rospy.impl.tcpros_pubsub', '_queue_that_is_not')], env={})
    assert 'rospy.impl.tcpros_pubsub: the field _queue_that_is_not' in _one_line(e)


def test_another_version_stops_unless_let_through():
    with pytest.raises(version.RospyMismatch) as e:
        version.check(version='1.16.0', env={})
    text = _one_line(e)
    assert 'written for rospy 1.15.15' in text and 'found rospy 1.16.0' in text
    assert 'SIM_WORLD_ANY_ROSPY=1' in text
    version.check(version='1.16.0', env={'SIM_WORLD_ANY_ROSPY': '1'})      # let through
    with pytest.raises(version.RospyMismatch):    # ... but never with an attribute missing
        version.check(version='1.16.0', attributes=[('rospy', 'no_such')],
                      env={'SIM_WORLD_ANY_ROSPY': '1'})


def test_the_mismatch_is_not_an_exception_a_run_loop_would_swallow():
    assert issubclass(version.RospyMismatch, SystemExit)
    assert not issubclass(version.RospyMismatch, Exception)


@pytest.mark.parametrize('node', [
    ['sim_world/nodes/sim_world'],
    ['testing_instance/nodes/run_scenario', 'testing_instance/examples/compass.yaml'],
])
def test_the_world_node_and_run_scenario_stop_at_start_with_one_line(node, tmp_path):
    """A rospy without QueuedConnection._run (sitecustomize takes it away before the node
    runs): exit status 1, one line on stderr, nothing started (no master: none is needed)."""
    (tmp_path / 'sitecustomize.py').write_text(
        'import rospy.impl.tcpros_pubsub as t\ndel t.QueuedConnection._run\n')
    env = dict(os.environ, PYTHONPATH=str(tmp_path) + os.pathsep +
               os.environ.get('PYTHONPATH', ''), ROS_MASTER_URI='http://localhost:1')
    p = subprocess.run([sys.executable] + [os.path.join(ROOT, node[0])] + node[1:],
                       cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True, timeout=120)
    assert p.returncode == 1
    assert p.stderr.strip().splitlines() == [
        'sim_world.transport: written for rospy 1.15.15 (Debian 12\'s python3-rospy), found '
        'rospy 1.15.15 without rospy.impl.tcpros_pubsub.QueuedConnection._run, which the '
        'lockstep\'s transport uses: this world cannot run with this rospy']
    assert p.stdout == ''
