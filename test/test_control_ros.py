"""ros_control through a running office world (issue 48 part 4), as a Gazebo user runs it:
pybullet_data's xarm6 spawned with its libgazebo_ros_control.so (robotNamespace /xarm), its
controllers' parameters on the parameter server, `rosrun mobile_device_sim spawner` (one
in ROS_NAMESPACE, one with --namespace and --stopped), controller_manager/list_controllers,
the arm's follow_joint_trajectory action through actionlib's SimpleActionClient (a good goal
succeeds, one with an unknown joint is rejected with INVALID_JOINTS), a trajectory on the
command topic, query_state; SIGINT to the spawner stops and unloads its controller. The
handlers and the physics are unit-tested on both engines in test/unit/test_control_trajectory.py."""
import json
import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from fixtures.rosworld import office_world  # noqa: E402

pytestmark = pytest.mark.rostest

PARAMS = '''{arm: {type: position_controllers/JointTrajectoryController,
  joints: [joint1, joint2, joint3, joint4, joint5, joint6],
  constraints: {goal_time: 0.5, stopped_velocity_tolerance: 0.01}},
 joint_state_controller: {type: joint_state_controller/JointStateController, publish_rate: 50}}'''

CLIENT = r'''
import json, sys, rospy, actionlib
from mobile_device_sim.srv import ListControllers, QueryTrajectoryState
from mobile_device_sim.msg import (FollowJointTrajectoryAction, FollowJointTrajectoryGoal,
                                   JointTrajectoryControllerState)
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
rospy.init_node('control_client', anonymous=True)
out = {}
J = ['joint%d' % i for i in range(1, 7)]
rospy.wait_for_service('/xarm/controller_manager/list_controllers', 30)
lc = rospy.ServiceProxy('/xarm/controller_manager/list_controllers', ListControllers)
deadline = rospy.Time.now() + rospy.Duration(30)
while True:
    st = dict((c.name, c.state) for c in lc().controller)
    if st.get('arm') == 'running' and 'joint_state_controller' in st:
        break
    rospy.sleep(0.2)
out['listed'] = st
out['claimed'] = [list(c.claimed_resources[0].resources) for c in lc().controller
                  if c.name == 'arm'][0]

def traj(points, names=J):
    t = JointTrajectory(joint_names=names)
    for s, q in points:
        t.points.append(JointTrajectoryPoint(positions=q, time_from_start=rospy.Duration(s)))
    return t

client = actionlib.SimpleActionClient('/xarm/arm/follow_joint_trajectory',
                                      FollowJointTrajectoryAction)
assert client.wait_for_server(rospy.Duration(30))
goal = [(0.5, [0.3, -0.2, -0.3, 0.2, 0.3, 0.1]), (1.2, [0.6, -0.4, -0.6, 0.4, 0.6, 0.2]),
        (2.0, [0.0, 0.1, -0.2, 0.0, 0.2, 0.0])]
client.send_goal(FollowJointTrajectoryGoal(trajectory=traj(goal)))
assert client.wait_for_result(rospy.Duration(60))
r = client.get_result()
out['result'] = [client.get_state(), r.error_code, r.error_string]
s = rospy.wait_for_message('/xarm/arm/state', JointTrajectoryControllerState, 20)
out['final'] = list(s.actual.positions)
client.send_goal(FollowJointTrajectoryGoal(trajectory=traj([(1.0, [0.1] * 6)], J[:5] + ['elbow'])))
assert client.wait_for_result(rospy.Duration(30))
r = client.get_result()
out['bad'] = [client.get_state(), r.error_code, r.error_string]
pub = rospy.Publisher('/xarm/arm/command', JointTrajectory, queue_size=1, latch=True)
pub.publish(traj([(0.5, [0.2] * 6)]))
deadline = rospy.Time.now() + rospy.Duration(30)
while rospy.Time.now() < deadline:
    s = rospy.wait_for_message('/xarm/arm/state', JointTrajectoryControllerState, 20)
    if max(abs(q - 0.2) for q in s.actual.positions) < 1e-3:
        break
out['topic'] = list(s.actual.positions)
q = rospy.ServiceProxy('/xarm/arm/query_state', QueryTrajectoryState)(rospy.Time.now())
out['query'] = [list(q.name), list(q.position)]
# the e-stop (the plugin's eStopTopic): a trajectory sent while it is on moves nothing;
# released, the controller starts again and holds where the arm is
from std_msgs.msg import Bool
stop = rospy.Publisher('/xarm/e_stop', Bool, queue_size=1, latch=True)
stop.publish(Bool(True))
rospy.sleep(1.0)
pub.publish(traj([(0.3, [0.5] * 6)]))
rospy.sleep(1.0)
out['stopped'] = list(rospy.wait_for_message('/xarm/arm/state', JointTrajectoryControllerState,
                                             20).actual.positions)
stop.publish(Bool(False))
rospy.sleep(1.0)
out['released'] = list(rospy.wait_for_message('/xarm/arm/state', JointTrajectoryControllerState,
                                              20).actual.positions)
# SIGINT to the spawner of 'arm': it stops and unloads it
import os, signal
os.kill(int(os.environ['ARM_SPAWNER_PID']), signal.SIGINT)
deadline = rospy.Time.now() + rospy.Duration(30)
while rospy.Time.now() < deadline:
    after = dict((c.name, c.state) for c in lc().controller)
    if 'arm' not in after:
        break
    rospy.sleep(0.1)
out['after'] = after
print(json.dumps(out))
sys.stdout.flush()
'''

def test_spawner_list_controllers_and_the_trajectory_action(tmp_path):
    import pybullet_data
    urdf = os.path.join(pybullet_data.getDataPath(), 'xarm', 'xarm6_robot.urdf')
    # the arm's own plugin, with an e-stop topic as a Gazebo user adds it
    text = open(urdf).read()
    assert '<robotNamespace>/xarm</robotNamespace>' in text
    urdf = str(tmp_path / 'xarm6_estop.urdf')
    open(urdf, 'w').write(text.replace(
        '<robotNamespace>/xarm</robotNamespace>',
        '<robotNamespace>/xarm</robotNamespace><eStopTopic>e_stop</eStopTopic>'))
    with office_world(tmp_path, 'physics:=bullet') as env:
        p = subprocess.run(['rosrun', 'mobile_device_sim', 'spawn_model', '-urdf', '-file', urdf,
                            '-model', 'xarm6', '-x', '3', '-y', '-1'],
                           env=env, capture_output=True, text=True, timeout=60)
        assert p.returncode == 0, p.stderr[-2000:]
        subprocess.run(['rosparam', 'set', '/xarm', PARAMS], env=env, check=True, timeout=30)
        arm = subprocess.Popen(['rosrun', 'mobile_device_sim', 'spawner', 'arm'],
                               env=dict(env, ROS_NAMESPACE='/xarm'), stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
        jsc = subprocess.Popen(['rosrun', 'mobile_device_sim', 'spawner', '--namespace', '/xarm',
                                '--stopped', 'joint_state_controller'], env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            c = subprocess.run([sys.executable, '-c', CLIENT], capture_output=True, text=True,
                               env=dict(env, ARM_SPAWNER_PID=str(arm.pid)), timeout=150)
            lines = [ln for ln in c.stdout.splitlines() if ln.startswith('{')]
            assert c.returncode == 0 and lines, c.stderr[-3000:]
            out = json.loads(lines[-1])
            log = arm.communicate(timeout=30)[0]
        finally:
            for proc in (arm, jsc):
                if proc.poll() is None:
                    proc.kill()
                    proc.wait()
    assert out['listed'] == {'arm': 'running', 'joint_state_controller': 'initialized'}
    assert out['claimed'] == ['joint%d' % i for i in range(1, 7)]
    assert out['result'] == [3, 0, '']                       # SUCCEEDED, SUCCESSFUL
    assert max(abs(a - b) for a, b in zip(out['final'], [0.0, 0.1, -0.2, 0.0, 0.2, 0.0])) < 5e-3
    state, code, text = out['bad']
    assert state == 5 and code == -2 and "'elbow'" in text   # REJECTED, INVALID_JOINTS
    assert max(abs(q - 0.2) for q in out['topic']) < 1e-3
    assert out['query'][0][0] == 'joint1' and out['query'][1] == [pytest.approx(0.2)] * 6
    assert max(abs(q - 0.2) for q in out['stopped']) < 2e-3, out['stopped']
    assert max(abs(q - 0.2) for q in out['released']) < 2e-3, out['released']
    assert 'Stopping and unloading' in log and 'Loaded controllers: arm' in log
    assert out['after'] == {'joint_state_controller': 'initialized'}
