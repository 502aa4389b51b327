"""Issue 46 through ROS, on a running office world (test/fixtures/rosworld.py):

- the README's `rosparam set robot_description "$(xacro sim_world/urdf/mobile_device.urdf.xacro)"`
  works (rosparam parses the value as YAML: one string) and reads back as the same robot;
- `spawn_model ... -model phone2 -robot_namespace /phone2` from that description gives a second
  phone beside office.launch's /mobile_device one, with its own sensors, services and faults;
- a spawn without a namespace whose plugins would take another model's names is refused with
  one line naming both models and the name, suggesting -robot_namespace; nothing of it stays
  and the first model keeps running."""
import json
import os
import subprocess
import sys
import xmlrpc.client

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from fixtures.rosworld import office_world  # noqa: E402

ROOT = os.path.dirname(HERE)
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')
CLIENT = os.path.join(HERE, 'fixtures', 'spawn_ns_client.py')

pytestmark = pytest.mark.rostest


def sh(env, cmd, timeout=60):
    return subprocess.run(['bash', '-c', cmd], env=env, cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout)


def spawn(env, *args):
    return sh(env, 'rosrun mobile_device_sim spawn_model -urdf -param robot_description '
              + ' '.join(args), timeout=90)


def client(env, what):
    """What fixtures/spawn_ns_client.py saw (one rospy process for all the checks)."""
    r = subprocess.run([sys.executable, CLIENT, what], env=env, capture_output=True, text=True,
                       timeout=180)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith('{')]
    assert r.returncode == 0 and lines, (r.stdout[-2000:], r.stderr[-3000:])
    return json.loads(lines[-1])


def test_rosparam_set_and_two_phones_side_by_side(tmp_path):
    from sim_world.urdf import parse_urdf
    xml = subprocess.run(['xacro', PHONE], check=True, capture_output=True, text=True).stdout
    with office_world(tmp_path) as env:
        # 1. the README's rosparam set, read back
        r = sh(env, 'rosparam set robot_description "$(xacro %s)"' % PHONE)
        assert r.returncode == 0, r.stderr[-2000:]
        code, _m, value = xmlrpc.client.ServerProxy(env['ROS_MASTER_URI']).getParam(
            '/test', '/robot_description')
        assert code == 1 and isinstance(value, str)
        assert value == yaml.safe_load(xml)             # what rosparam promises: the string
        a, b = parse_urdf(xml, name='a'), parse_urdf(value, name='a')
        assert sorted(a.links) == sorted(b.links) and len(a.plugins) == len(b.plugins)

        # 2. a second phone from the same description, in /phone2
        r = spawn(env, '-model phone2 -x 3 -y -2 -z 1.2 -robot_namespace /phone2')
        assert r.returncode == 0, r.stdout + r.stderr
        seen = client(env, 'phones')
        assert seen['/phone2/imu_sensor_data'] == 'phone2/mobile_device_frame', seen
        assert seen['/phone2/image_raw'] == 'phone2/mobile_camera_optical_frame', seen
        assert seen['/phone2/magnetic'] == 'phone2/mobile_device_frame', seen
        assert seen['/mobile_device/imu_sensor_data'] == 'mobile_device_frame', seen
        for srv in ('/phone2/inject_touch', '/phone2/press_button', '/phone2/set_device_time',
                    'fault'):
            assert seen[srv][0] is True, (srv, seen[srv])
        assert seen['phone2_imu_after_fault'] is None, seen             # its fault ...
        assert seen['mobile_device_imu_after_fault'] == 'mobile_device_frame', seen  # only

        # 3. no namespace: the first spawn takes the global names, the second is refused
        r = spawn(env, '-model lone -x 2 -y -2 -z 1.2')
        assert r.returncode == 0, r.stdout + r.stderr
        r = spawn(env, '-model lone2 -x 2 -y -1 -z 1.2')
        assert r.returncode == 1
        lines = [ln for ln in (r.stdout + r.stderr).splitlines() if 'clashes' in ln]
        assert len(lines) == 1, r.stdout + r.stderr
        assert "'lone2'" in lines[0] and "'lone'" in lines[0]
        assert '/imu_sensor_data' in lines[0] and '-robot_namespace /lone2' in lines[0]
        seen = client(env, 'after')
        assert seen['lone2'][0] is False                                # no body
        assert seen['lone'][0] is True
        assert seen['/imu_sensor_data'] == 'mobile_device_frame'        # the first runs on
        assert seen['/set_device_time'][0] is True, seen                # and serves
