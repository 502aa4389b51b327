"""rviz on every phone: sim_world/config/phone.rviz shows the launch file's phone (robot model
from ``robot_description``, plain tf frames, its camera on /mobile_device/image_raw); each
further phone spawned from the same description with ``-robot_namespace /NS`` gets a robot
model display of the same description with TF prefix ``NS`` (its frames are ``NS/<link>``,
sim_world.spawn) and an image display of ``/NS/image_raw``.

    rosrun mobile_device_sim rviz_phones [--config FILE] [--phones "phone2 phone_b"] [rviz args]
    roslaunch mobile_device_sim rviz.launch phones:="phone2"

``phone_config(text, phones)`` is the pure part (tested in test/unit/test_rviz_config.py).
"""
import argparse
import os
import sys
import tempfile

__all__ = ['phone_config', 'main']

_MODEL = '''    - Class: rviz/RobotModel
      Enabled: true
      Name: Phone {ns}
      Robot Description: {description}
      TF Prefix: {ns}
      Visual Enabled: true
      Collision Enabled: false
      Alpha: 1
      Value: true
    - Class: rviz/Image
      Enabled: true
      Name: Camera {ns}
      Image Topic: /{ns}/image_raw
      Transport Hint: raw
      Normalize Range: true
      Queue Size: 2
      Value: true
'''


def phone_config(text, phones, description='robot_description'):
    """The rviz config ``text`` (phone.rviz) with a robot model and a camera image display for
    each namespace in ``phones`` (names without slashes; empty ones are skipped), inserted
    after the config's own robot model (with no phones, ``text`` unchanged: a config of the
    user's own needs no particular display); ValueError when phones are to be added and
    ``text`` has no rviz/RobotModel and rviz/TF display, or a namespace holds characters a
    ROS name cannot."""
    import re
    anchor = '    - Class: rviz/TF\n'
    if not [ns for ns in phones if ns.strip('/')]:
        return text                  # nothing to add: any config of the user's own goes as is
    if '    - Class: rviz/RobotModel\n' not in text or anchor not in text:
        raise ValueError('the rviz config has no RobotModel and TF displays to add phones beside')
    extra = []
    for ns in phones:
        ns = ns.strip('/')
        if not ns:
            continue
        if not re.match(r'^[A-Za-z][A-Za-z0-9_/]*$', ns):
            raise ValueError('phone namespace %r is not a ROS name' % ns)
        extra.append(_MODEL.format(ns=ns, description=description))
    return text.replace(anchor, ''.join(extra) + anchor, 1)


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    here = os.path.dirname(os.path.abspath(__file__))
    default = os.path.join(here, '..', '..', 'config', 'phone.rviz')
    p = argparse.ArgumentParser(prog='rviz_phones', description=__doc__.split('\n\n')[0])
    p.add_argument('--config', default=os.path.normpath(default))
    p.add_argument('--phones', default='', help='namespaces of further phones, space-separated')
    a, rest = p.parse_known_args([x for x in argv if not x.startswith('__')])
    try:
        with open(a.config) as f:
            text = phone_config(f.read(), a.phones.replace(',', ' ').split())
    except (OSError, ValueError) as e:
        sys.stderr.write('rviz_phones: %s\n' % e)
        return 1
    fd, path = tempfile.mkstemp(prefix='phones_', suffix='.rviz')
    with os.fdopen(fd, 'w') as f:
        f.write(text)
    os.execvp('rviz', ['rviz', '-d', path] + rest + [x for x in argv if x.startswith('__')])
