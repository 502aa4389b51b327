"""Articulated models through a running office world (issue 48): `spawn_model -J`, the
joint and link services with a real roscore, /tf_static without movable joints,
/gazebo/link_states, and the joint state publisher plugin feeding Debian's
robot_state_publisher, whose link tf matches the physics within 1 mm and 1 mrad. The handlers themselves are unit-tested on both engines in
test/unit/test_joint_api.py; this checks they are served, with gazebo_msgs' types."""
import json
import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from fixtures.rosworld import office_world  # noqa: E402

pytestmark = pytest.mark.rostest

PENDULUM = '''<robot name="pend"><link name="world"/>
<joint name="fix" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 2"/></joint>
<link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
<joint name="hinge" type="continuous"><parent link="base"/><child link="rod"/><axis xyz="0 0 1"/></joint>
<link name="rod"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
<inertia ixx="0.02" iyy="0.02" izz="0.001"/></inertial></link>
<gazebo><plugin name="jsp" filename="libgazebo_ros_joint_state_publisher.so">
<jointName>hinge</jointName><updateRate>100</updateRate></plugin></gazebo></robot>'''

CLIENT = r'''
import json, rospy
from mobile_device_sim.srv import *
from mobile_device_sim.msg import LinkStates
from tf2_msgs.msg import TFMessage
rospy.init_node('joint_client', anonymous=True)
out = {}
for s in ('get_joint_properties', 'apply_joint_effort', 'set_model_configuration',
          'get_model_properties', 'get_link_state', 'clear_joint_forces'):
    rospy.wait_for_service('/gazebo/' + s, 20)
gjp = rospy.ServiceProxy('/gazebo/get_joint_properties', GetJointProperties)
r = gjp('pend::hinge')
out['spawned_position'] = r.position[0] if r.position else None
out['type'] = r.type
r = gjp('nope')
out['unknown'] = [r.success, r.status_message]
r = rospy.ServiceProxy('/gazebo/get_model_properties', GetModelProperties)('pend')
out['joints'] = list(r.joint_names)
r = rospy.ServiceProxy('/gazebo/set_model_configuration', SetModelConfiguration)(
    'pend', '', ['hinge'], [0.1])
out['config'] = r.success
r = rospy.ServiceProxy('/gazebo/get_link_state', GetLinkState)('pend::rod', '')
out['rod_z'] = r.link_state.pose.position.z
r = rospy.ServiceProxy('/gazebo/apply_joint_effort', ApplyJointEffort)(
    'pend::hinge', 1.0, rospy.Time(0), rospy.Duration(-1))
out['effort'] = r.success
rospy.ServiceProxy('/gazebo/clear_joint_forces', JointRequest)('pend::hinge')
ls = rospy.wait_for_message('/gazebo/link_states', LinkStates, 20)
out['link_states'] = [n for n in ls.name if n.startswith('pend::')]
import tf2_ros
from sensor_msgs.msg import JointState
js = rospy.wait_for_message('/joint_states', JointState, 20)
out['joint_states'] = [list(js.name), js.position[0], js.header.stamp.to_sec()]
# at rest for the comparison: the effort above left the rod turning
rospy.ServiceProxy('/gazebo/set_model_configuration', SetModelConfiguration)(
    'pend', '', ['hinge'], [0.2])
rospy.sleep(1.0)
buf = tf2_ros.Buffer()
tf2_ros.TransformListener(buf)
t = buf.lookup_transform('base', 'rod', rospy.Time(0), rospy.Duration(20)).transform
gls = rospy.ServiceProxy('/gazebo/get_link_state', GetLinkState)('pend::rod', 'pend::base')
p = gls.link_state.pose
out['tf_vs_physics'] = [t.translation.x - p.position.x, t.translation.y - p.position.y,
                        t.translation.z - p.position.z, t.rotation.z - p.orientation.z,
                        t.rotation.w - p.orientation.w]
tf = rospy.wait_for_message('/tf_static', TFMessage, 20)
out['tf_static'] = sorted(t.child_frame_id for t in tf.transforms if t.child_frame_id in
                          ('base', 'rod'))
print(json.dumps(out))
'''


def test_spawn_with_J_and_the_joint_services(tmp_path):
    urdf = tmp_path / 'pend.urdf'
    urdf.write_text(PENDULUM)
    with office_world(tmp_path) as env:
        p = subprocess.run(['rosrun', 'mobile_device_sim', 'spawn_model', '-urdf', '-file',
                            str(urdf), '-model', 'pend', '-x', '6', '-J', 'hinge', '0.3'],
                           env=env, capture_output=True, text=True, timeout=60)
        assert p.returncode == 0, p.stderr[-2000:]
        # Debian's robot_state_publisher: the links' tf from the plugin's joint_states
        subprocess.run(['rosparam', 'set', '/robot_description', PENDULUM], env=env, check=True,
                       timeout=30)
        rsp = subprocess.Popen(['rosrun', 'robot_state_publisher', 'robot_state_publisher'],
                               env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            c = subprocess.run([sys.executable, '-c', CLIENT], env=env, capture_output=True,
                               text=True, timeout=120)
        finally:
            rsp.terminate()
            rsp.wait(20)
        lines = [ln for ln in c.stdout.splitlines() if ln.startswith('{')]
        assert c.returncode == 0 and lines, c.stderr[-3000:]
        out = json.loads(lines[-1])
    assert abs(out['spawned_position'] - 0.3) < 5e-3     # -J (a vertical axis: it stays)
    assert out['type'] == 1                              # CONTINUOUS
    assert out['unknown'][0] is False and "'nope'" in out['unknown'][1]
    assert out['joints'] == ['hinge'] and out['config'] and out['effort']
    assert abs(out['rod_z'] - 2.0) < 5e-3               # the rod's frame is at the hinge
    assert sorted(out['link_states']) == ['pend::base', 'pend::rod', 'pend::world']
    assert out['tf_static'] == ['base']                  # the movable joint is not static
    names, q, stamp = out['joint_states']
    assert names == ['hinge'] and q == q and stamp > 0      # sim-time stamps
    dx, dy, dz, dqz, dqw = out['tf_vs_physics']     # robot_state_publisher vs the physics
    assert max(abs(dx), abs(dy), abs(dz)) < 1e-3 and max(abs(dqz), abs(dqw)) < 5e-4
