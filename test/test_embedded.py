"""The embedded world (issue 18 item 2): ``run_scenario --embedded`` builds the launch file's
world in its own process, becomes its /sim_world node and steps it by a function call.

- it is the default for a single run whose launch file has one sim_world node
  (``--world-node``: that node as a process of its own, stepped through /gazebo/step_world);
- it records exactly what the sim_world node's lockstep records, message by message with
  times and bytes, for a scenario that changes everything a scenario can change;
- apps see the same graph: the world's topics and services are served by /sim_world;
- the examples get the same verdicts embedded and with the sim_world node (the
  session's farm: fixtures/example_farm.py);
- what cannot be embedded gets one clear line and exit code 2, no hang.
"""
import os
import re

import pytest

from fixtures.scenario_cli import run_scenario
from test_scenarios import EX, bag_messages, verdicts
from test_warm_farm import MESSY, messy_text

pytestmark = pytest.mark.rostest

GRAPH_APP = """\
import time, rosgraph, rospy
from std_msgs.msg import String
rospy.init_node('graph_app')
pub = rospy.Publisher('~graph', String, queue_size=1, latch=True)
imu = []
while not imu and not rospy.is_shutdown():     # the phone is spawned after the apps start
    pubs, subs, srvs = rosgraph.Master('/graph_app').getSystemState()
    imu = sorted(n for t, ns in pubs if t == '/mobile_device/imu_sensor_data' for n in ns)
    time.sleep(0.01)
step = sorted(n for s, ns in srvs if s == '/gazebo/step_world' for n in ns)
clock = [n for t, ns in subs if t == '/clock' for n in ns]
pub.publish(String(' '.join(imu) + ' | ' + ' '.join(step) + ' | rosout on /clock: %s'
                   % ('yes' if '/rosout' in clock else 'no')))
rospy.spin()
"""


def test_embedded_world_records_what_the_world_node_records(tmp_path):
    rc_e, emb = run_scenario(MESSY, '--embedded', '--record', tmp_path / 'emb.bag')
    rc_c, cold = run_scenario(MESSY, '--world-node', '--record', tmp_path / 'cold.bag')
    assert rc_e == rc_c == 0, emb + cold
    assert verdicts(emb) == verdicts(cold) == {'imu': 'PASS'}
    assert re.search(r'^handshake: \d+ messages from the world, 0 dropped', emb, re.M), emb
    e, c = bag_messages(tmp_path / 'emb.bag'), bag_messages(tmp_path / 'cold.bag')
    assert '/mobile_device/imu_sensor_data' in c and '/gazebo/environment' in c
    assert sorted(e) == sorted(c)
    for topic in c:           # the meta too: same scenario, seed, inputs and types
        assert len(e[topic]) == len(c[topic]), topic
        for i, (x, y) in enumerate(zip(e[topic], c[topic])):
            assert x == y, '%s message %d (time, bytes) differs embedded and not' % (topic, i)
    # and the same file: the messages of one sim time in one order (recording_order), not
    # in the order their threads ran (the world node's all come over sockets)
    assert (tmp_path / 'emb.bag').read_bytes() == (tmp_path / 'cold.bag').read_bytes(), \
        'the same messages in another order in the file, embedded and with the world node'


def test_an_embedded_run_without_other_publishers_looks_for_topics_only_when_told(tmp_path):
    """Without apps, the embedded runner skips the periodic look at the master's topics
    when this process declared no publisher since the last look (no other process can
    have): fewer looks than with the sim_world node, and still the same recording, message
    by message, spawned head and late topics included."""
    no_apps = re.sub(r'apps:\n(  - .*\n)+', '', messy_text()).replace(
        'duration: 1.0', 'duration: 3.0')
    assert 'apps' not in no_apps and 'spawn_model' in no_apps
    sc = tmp_path / 'no_apps.yaml'
    sc.write_text(no_apps)
    rc_e, emb = run_scenario(sc, '--embedded', '--record', tmp_path / 'emb.bag')
    rc_c, node = run_scenario(sc, '--world-node', '--record', tmp_path / 'node.bag')
    assert rc_e == rc_c == 0, emb + node
    looks = [int(re.search(r'^handshake: .*; (\d+) looks for new topics$', out, re.M).group(1))
             for out in (emb, node)]
    assert looks[1] >= 4, node            # the first, after the spawn, at 1, 2 and 3 s
    assert looks[0] < looks[1], (looks, emb)
    e, c = bag_messages(tmp_path / 'emb.bag'), bag_messages(tmp_path / 'node.bag')
    assert sorted(e) == sorted(c) and '/mobile_device/imu_sensor_data' in c
    for topic in c:
        assert e[topic] == c[topic], '%s differs embedded and with the node' % topic


@pytest.mark.parametrize('mode', ['--embedded', '--world-node'])
def test_apps_see_the_world_node_of_the_launch_file(tmp_path, mode):
    """The world's topics and services are served by /sim_world, embedded or launched;
    the run's rosout takes no /clock (procs.Core starts it with /use_sim_time remapped
    away: with roscore, and with roslaunch's own master, it took every tick)."""
    (tmp_path / 'graph_app.py').write_text(GRAPH_APP)
    (tmp_path / 'graph.yaml').write_text(
        'name: graph\nduration: 0.3\nworld: {args: {camera_rate: 1}}\n'
        'apps: [{name: graph_app, script: graph_app.py}]\n'
        'expect:\n  - {name: served_by_sim_world, topic: /graph_app/graph, field: data,\n'
        '     eventually: {equals: "/sim_world | /sim_world | rosout on /clock: no"}}\n')
    rc, out = run_scenario(tmp_path / 'graph.yaml', mode)
    assert rc == 0, out
    assert verdicts(out) == {'served_by_sim_world': 'PASS'}, out
    assert 'spawned model' not in out          # the world's log lines go to its log file


def test_examples_get_the_same_verdicts_embedded(example_farm):
    """Examples run alone (embedded: the default) get the verdicts the session's farm of
    warm sim_world nodes gave them (fixtures/example_farm.py): a failing variant with
    passing and failing expectations after timeline events (auto_rotate_fails), the camera
    and an app's display (qr_code), a launch file of its own (battery_saver), two phones
    (nfc_vcard)."""
    for name in ('auto_rotate_fails.yaml', 'qr_code.yaml', 'battery_saver.yaml',
                 'nfc_vcard.yaml'):
        rc, out = run_scenario(os.path.join(EX, name))     # embedded: the default
        assert rc == (1 if 'fails' in name else 0), out
        c = example_farm.verdicts(name)
        assert c and verdicts(out) == c, (name, out, example_farm.out)
    assert set(example_farm.verdicts('auto_rotate_fails.yaml').values()) == {'PASS', 'FAIL'}


def test_what_cannot_be_embedded_is_refused_with_one_line(tmp_path):
    f = os.path.join(EX, 'compass.yaml')
    rc, out = run_scenario('--embedded', '--jobs', '2', f)
    assert rc == 2 and 'ERROR --embedded runs one scenario' in out, out
    # a launch file without a sim_world node
    (tmp_path / 'noworld.launch').write_text(
        '<launch><arg name="paused" default="true"/><arg name="seed" default=""/>'
        '<arg name="real_time_factor" default="0"/><arg name="physics" default="ode"/>'
        '</launch>')
    (tmp_path / 'noworld.yaml').write_text(
        'name: noworld\nduration: 0.5\nworld: {launch: noworld.launch}\n')
    rc, out = run_scenario(tmp_path / 'noworld.yaml', '--embedded', timeout=120)
    assert rc == 2, out
    assert '--embedded: the launch file' in out, out
    assert 'has 0 mobile_device_sim/sim_world nodes' in out, out
    rc, out = run_scenario(f, '--embedded', '--world-node')
    assert rc == 2 and 'exclude each other' in out, out
    # a world node whose world file does not exist: the world's own error, as a run's ERROR
    (tmp_path / 'badworld.launch').write_text(
        '<launch><arg name="paused" default="true"/><arg name="seed" default=""/>'
        '<arg name="real_time_factor" default="0"/><arg name="physics" default="ode"/>'
        '<node name="sim_world" pkg="mobile_device_sim" type="sim_world">'
        '<param name="world_file" value="%s/none.world"/></node></launch>' % tmp_path)
    (tmp_path / 'badworld.yaml').write_text(
        'name: badworld\nduration: 0.5\nworld: {launch: badworld.launch}\n')
    rc, out = run_scenario(tmp_path / 'badworld.yaml', '--embedded', timeout=120)
    assert rc == 2, out
    assert re.search(r'the embedded world /sim_world: cannot load world file \S*none\.world',
                     out), out


def test_a_bad_world_parameter_is_one_line_and_no_wait(tmp_path):
    """~max_step_size that is not a number: embedded, the world's own line as the run's
    ERROR; with the sim_world node, that node's FATAL line in the log tail at once (the
    runner used to wait its whole timeout for /gazebo/step_world of a world already gone)."""
    import time
    f = tmp_path / 'badstep.yaml'
    f.write_text('name: badstep\nduration: 0.5\ntimeout: 200\n'
                 'world: {args: {camera_rate: 1, max_step_size: abc}}\n')
    rc, out = run_scenario(f, timeout=120)
    assert rc == 2, out
    assert "ERROR the embedded world /sim_world: ~max_step_size must be a number, got 'abc'" \
        in out, out
    t0 = time.monotonic()
    rc, out = run_scenario(f, '--world-node', timeout=120)
    assert rc == 2, out
    assert time.monotonic() - t0 < 60, out
    assert re.search(r'^ERROR the world died at sim time 0\.000 s', out, re.M), out
    assert "sim_world: ~max_step_size must be a number, got 'abc'" in out, out


def test_a_misspelt_world_argument_is_one_line_before_anything_starts(tmp_path):
    """roslaunch ignores an argument its launch file does not declare: the scenario would
    run on the default camera rate. The runner names it and the close one, and starts no
    master, world or app (no start-up line)."""
    f = tmp_path / 'typo.yaml'
    f.write_text('name: typo\nduration: 0.5\nworld: {args: {camera_rat: 30}}\n')
    for mode in ('--embedded', '--world-node'):
        rc, out = run_scenario(f, mode, '--seed', '1', timeout=120)
        assert rc == 2, out
        lines = [ln for ln in out.splitlines() if ln.startswith('ERROR')]
        assert len(lines) == 1, out
        assert lines[0].startswith('ERROR world.args: camera_rat is not an argument of ')
        assert 'office.launch, so roslaunch would ignore it. Did you mean camera_rate?' \
            in lines[0], out
        assert 'timeline:' not in out and 'start-up:' not in out, out


LAB_LAUNCH = """<launch>
  <!-- the office world with its nodes in the namespace /lab and the IMU remapped -->
  <arg name="paused" default="true"/>
  <arg name="seed" default=""/>
  <arg name="real_time_factor" default="0"/>
  <arg name="physics" default="ode"/>
  <group ns="lab">
    <remap from="/mobile_device/imu_sensor_data" to="/lab/imu"/>
    <include file="$(find mobile_device_sim)/sim_world/launch/office.launch">
      <arg name="paused" value="$(arg paused)"/>
      <arg name="seed" value="$(arg seed)"/>
      <arg name="real_time_factor" value="$(arg real_time_factor)"/>
      <arg name="physics" value="$(arg physics)"/>
      <arg name="flycam" value="false"/>
      <arg name="camera_rate" value="1"/>
    </include>
  </group>
</launch>
"""

LAB_APP = """\
import rosgraph, rospy
from std_msgs.msg import String
from sensor_msgs.msg import Imu
rospy.init_node('lab_app')
pub = rospy.Publisher('~seen', String, queue_size=1, latch=True)
def on_imu(_m):
    pubs, _subs, srvs = rosgraph.Master('/lab_app').getSystemState()
    imu = sorted(n for t, ns in pubs if t == '/lab/imu' for n in ns)
    step = sorted(n for s, ns in srvs if s == '/gazebo/step_world' for n in ns)
    pub.publish(String(' '.join(imu) + ' | ' + ' '.join(step)))
    sub.unregister()
sub = rospy.Subscriber('/lab/imu', Imu, on_imu)
rospy.spin()
"""


def test_a_namespaced_and_remapped_world_node_is_embedded_as_it_is_launched(tmp_path):
    """The launch file's world node in a namespace (/lab/sim_world) with a remapping: the
    embedded run is that node (an app sees it publish the remapped IMU and serve
    /gazebo/step_world) and records what the sim_world node records."""
    (tmp_path / 'lab.launch').write_text(LAB_LAUNCH)
    (tmp_path / 'lab_app.py').write_text(LAB_APP)
    (tmp_path / 'lab.yaml').write_text(
        'name: lab\nduration: 0.5\nworld: {launch: lab.launch}\n'
        'apps: [{name: lab_app, script: lab_app.py}]\n'
        'expect:\n'
        '  - {name: imu, topic: /lab/imu, rate: {near: 100, tol: 3}}\n'
        "  - {name: graph, topic: /lab_app/seen, field: data, eventually: "
        "{equals: '/lab/sim_world | /lab/sim_world'}}\n")
    rc_e, emb = run_scenario(tmp_path / 'lab.yaml', '--embedded', '--record',
                             tmp_path / 'emb.bag')
    rc_n, node = run_scenario(tmp_path / 'lab.yaml', '--world-node', '--record',
                              tmp_path / 'node.bag')
    assert rc_e == 0 and rc_n == 0, emb + node
    assert verdicts(emb) == verdicts(node) == {'imu': 'PASS', 'graph': 'PASS'}, emb + node
    e, n = bag_messages(tmp_path / 'emb.bag'), bag_messages(tmp_path / 'node.bag')
    assert '/lab/imu' in n and '/mobile_device/imu_sensor_data' not in n
    assert '/lab_app/seen' in n and '/mobile_device/camera_info' in n
    # the whole recording, message by message: the runner waits for the world's side of
    # its subscriptions before sim time 0, also when the world node is /lab/sim_world (it
    # asked a /sim_world that was not there; a node run once lacked a 1 Hz camera's first
    # frame, see the README)
    assert sorted(e) == sorted(n)
    for topic in n:
        assert e[topic] == n[topic], '%s differs embedded and not' % topic
    import json
    import rosbag
    with rosbag.Bag(str(tmp_path / 'node.bag')) as b:       # what a replay feeds back
        meta = [json.loads(m.data) for _t, m, _s in b.read_messages(['/scenario/meta'])]
    assert '/lab/imu' in meta[0]['inputs'], meta
