"""rviz shows every phone (issue 46): sim_world.rviz_config adds a robot model (TF prefix of
the phone's namespace) and a camera image per further phone to phone.rviz; rviz.launch's
``phones`` argument reaches it. The rendered rviz itself: test/test_rviz.py."""
import os

import pytest
import yaml

from sim_world.rviz_config import phone_config

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BASE = open(os.path.join(ROOT, 'sim_world', 'config', 'phone.rviz')).read()


def displays(text):
    return yaml.safe_load(text)['Visualization Manager']['Displays']


def test_no_phones_is_the_config_unchanged():
    assert phone_config(BASE, []) == BASE
    assert phone_config(BASE, ['', '/']) == BASE


def test_each_phone_gets_a_robot_model_and_its_camera():
    d = displays(phone_config(BASE, ['phone2', '/phone_b/']))
    models = [x for x in d if x['Class'] == 'rviz/RobotModel']
    assert [(m['TF Prefix'] or '', m['Robot Description']) for m in models] == [
        ('', 'robot_description'), ('phone2', 'robot_description'),
        ('phone_b', 'robot_description')]
    images = {x['Image Topic'] for x in d if x['Class'] == 'rviz/Image'}
    assert {'/mobile_device/image_raw', '/phone2/image_raw', '/phone_b/image_raw'} <= images
    assert len({x['Name'] for x in d}) == len(d)          # rviz needs distinct names


def test_bad_namespace_and_config_are_refused():
    with pytest.raises(ValueError, match='not a ROS name'):
        phone_config(BASE, ['2 phones'])
    with pytest.raises(ValueError, match='RobotModel'):
        phone_config('Panels: []\n', ['phone2'])
    # no phone to add: a config of the user's own goes through unchanged
    assert phone_config('Panels: []\n', []) == 'Panels: []\n'
    assert phone_config('Panels: []\n', ['', '/']) == 'Panels: []\n'


def test_rviz_launch_passes_phones():
    import subprocess
    r = subprocess.run(['roslaunch', '--args', 'rviz', os.path.join(
        ROOT, 'sim_world', 'launch', 'rviz.launch'), 'world:=false', 'phones:=phone2 phone_b'],
        capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert 'rviz_phones' in r.stdout and "phone2 phone_b" in r.stdout
