"""rviz shows a robot's joints moving (issue 48 part 7), as a Gazebo user sets it up: a
pendulum with libgazebo_ros_joint_state_publisher.so spawned in the office world under
``-robot_namespace /pend``, Debian's robot_state_publisher in that namespace turning
``/pend/joint_states`` into tf, and rviz (under Xvfb, `roslaunch mobile_device_sim rviz.launch`)
with a RobotModel display of ``/pend/robot_description`` looking down on it. The joint is set
with ``/gazebo/set_model_configuration`` to two angles; in each screenshot (xwd) the red rod
must point from the hinge along the joint's angle, within 3 degrees, as seen from above."""
import math
import os
import shutil
import subprocess
import time

import cv2
import numpy as np
import pytest

from fixtures.xwd import screenshot, start_xvfb, stop_groups
from sim_world.netutil import master_port

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, 'build', 'test-output')

PENDULUM = '''<robot name="pend"><link name="world"/>
<joint name="fix" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 2"/></joint>
<link name="base"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
<joint name="hinge" type="continuous"><parent link="base"/><child link="rod"/><axis xyz="0 0 1"/></joint>
<link name="rod"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
<inertia ixx="0.002" ixy="0" ixz="0" iyy="0.09" iyz="0" izz="0.09"/></inertial>
<visual><origin xyz="0.5 0 0"/><geometry><box size="1 0.08 0.08"/></geometry>
<material name="red"><color rgba="1 0 0 1"/></material></visual></link>
<gazebo><plugin name="jsp" filename="libgazebo_ros_joint_state_publisher.so">
<jointName>hinge</jointName><updateRate>50</updateRate></plugin></gazebo></robot>'''

# rviz looking straight down on the hinge (x to the right of the screen, y up: yaw pi/2 puts
# the orbit camera south of the focal point, pitch near pi/2 above it)
CONFIG = '''Panels: []
Visualization Manager:
  Class: ""
  Displays:
    - Class: rviz/RobotModel
      Enabled: true
      Name: Pendulum
      Robot Description: /pend/robot_description
      TF Prefix: ""
      Visual Enabled: true
      Collision Enabled: false
      Alpha: 1
      Value: true
  Enabled: true
  Global Options:
    Background Color: 48; 48; 48
    Fixed Frame: world
    Frame Rate: 15
  Name: root
  Tools: []
  Value: true
  Views:
    Current:
      Class: rviz/Orbit
      Distance: 4
      Focal Point:
        X: 0
        Y: 0
        Z: 2
      Pitch: 1.5697
      Yaw: -1.5708
      Target Frame: <Fixed Frame>
      Name: Current View
      Near Clip Distance: 0.01
Window Geometry:
  Height: 700
  Width: 900
  X: 0
  Y: 0
'''


def rod_angle(rgb):
    """(red pixels, angle of the red rod in the image with y up, rad, or None): the rod's
    principal axis, pointing from the hinge (at the view's centre, near the screen's) to the
    rod's far end."""
    r, g, b = (rgb[:, :, i].astype(int) for i in range(3))
    ys, xs = np.nonzero((r > 150) & (g < 80) & (b < 80))
    if len(xs) < 200:
        return len(xs), None
    pts = np.stack([xs - xs.mean(), -(ys - ys.mean())], axis=1)
    w, v = np.linalg.eigh(np.cov(pts.T))
    axis = v[:, np.argmax(w)]
    out = np.array([xs.mean() - rgb.shape[1] / 2.0, -(ys.mean() - rgb.shape[0] / 2.0)])
    if axis @ out < 0:
        axis = -axis
    return len(xs), math.atan2(axis[1], axis[0])


def _set(env, angle):
    return subprocess.run(['rosservice', 'call', '/gazebo/set_model_configuration',
                           '{model_name: pend, joint_names: [hinge], joint_positions: [%g]}'
                           % angle], env=env, capture_output=True, text=True, timeout=60)


@pytest.mark.slow
def test_rviz_draws_the_pendulum_at_its_joint_angle(tmp_path):
    for tool in ('rviz', 'Xvfb', 'xwd'):
        if shutil.which(tool) is None:
            pytest.skip('%s is not installed (tools/setup installs rviz, xvfb, x11-apps)' % tool)
    xvfb, display = start_xvfb('900x700x24')
    port = master_port()
    env = dict(os.environ, DISPLAY=display, ROS_MASTER_URI='http://localhost:%d' % port,
               ROS_HOSTNAME='localhost')
    (tmp_path / 'pend.urdf').write_text(PENDULUM)
    (tmp_path / 'pend.rviz').write_text(CONFIG)
    log = open(tmp_path / 'rviz.log', 'w')
    launch = subprocess.Popen(['roslaunch', '-p', str(port), 'mobile_device_sim', 'rviz.launch',
                               'config:=%s' % (tmp_path / 'pend.rviz')],
                              env=env, stdout=log, stderr=subprocess.STDOUT,
                              start_new_session=True)
    rsp = None
    os.makedirs(OUT, exist_ok=True)
    try:
        end = time.time() + 120
        while True:
            assert launch.poll() is None, open(tmp_path / 'rviz.log').read()[-3000:]
            p = subprocess.run(['rosrun', 'mobile_device_sim', 'spawn_model', '-urdf', '-file',
                                str(tmp_path / 'pend.urdf'), '-model', 'pend',
                                '-robot_namespace', '/pend', '-J', 'hinge', '0.0'],
                               env=env, capture_output=True, text=True, timeout=90)
            if p.returncode == 0:
                break
            assert time.time() < end, p.stderr[-2000:]
            time.sleep(2)
        subprocess.run(['rosparam', 'set', '/pend/robot_description', PENDULUM], env=env,
                       check=True, timeout=30)
        rsp = subprocess.Popen(['rosrun', 'robot_state_publisher', 'robot_state_publisher',
                                '__ns:=/pend'], env=env, stdout=log, stderr=subprocess.STDOUT,
                               start_new_session=True)
        seen = {}
        for angle in (0.0, 1.2):
            assert _set(env, angle).returncode == 0
            want = angle
            got = None
            end = time.time() + 60
            while time.time() < end:
                time.sleep(1.5)
                rgb = screenshot(display)
                if rgb is None:
                    continue
                cv2.imwrite(os.path.join(OUT, 'rviz_joint.png'), rgb[:, :, ::-1])
                n, a = rod_angle(rgb)
                if a is None:
                    continue
                err = math.atan2(math.sin(a - want), math.cos(a - want))
                got = (n, a, err)
                if abs(err) < math.radians(3):
                    cv2.imwrite(os.path.join(OUT, 'rviz_joint_%g.png' % angle), rgb[:, :, ::-1])
                    break
            seen[angle] = got
            assert got is not None, 'rviz never drew the red rod (%s; log: %s)' % (
                os.path.join(OUT, 'rviz_joint.png'), open(tmp_path / 'rviz.log').read()[-2000:])
            assert abs(got[2]) < math.radians(3), (angle, got)
        # the two pictures differ by the joint's motion
        assert seen[1.2][1] - seen[0.0][1] == pytest.approx(1.2, abs=0.1)
    finally:
        stop_groups((rsp, launch, xvfb))
        log.close()
