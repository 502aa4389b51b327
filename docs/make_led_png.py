#!/usr/bin/env python3
"""Regenerate docs/led.png: the office world's phone (office.launch pose) with its
notification LED lit green, seen by the simulator's renderer from in front of its top end.
Run: source build/env.sh && python3 docs/make_led_png.py"""
import math
import os
import re

import cv2
import numpy as np

from sim_world.render import CameraView
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
launch = open(os.path.join(ROOT, 'sim_world/launch/office.launch')).read()


def arg(n):
    return float(re.search(r'name="%s" default="([^"]+)"' % n, launch).group(1))


w = World(physics='ode', seed=1)
w.load_world_file(os.path.join(ROOT, 'sim_world/worlds/office.world'))
w.add_model(load_urdf_file(os.path.join(ROOT, 'sim_world/urdf/mobile_device.urdf.xacro')),
            pose=Pose.from_xyz_rpy((arg('phone_x'), arg('phone_y'), arg('phone_z')),
                                   (0, 0, arg('phone_yaw'))))
led = next(p for p in w.plugins['mobile_device'] if type(p).__name__ == 'Led')
led.command(color='#00ff00', on_ms=500, off_ms=500)
w.step(20)
lp = w.link_pose('mobile_device', 'mobile_led')
top = w.link_pose('mobile_device', 'mobile_base_link').rotate(np.array([1.0, 0, 0]))
eye = lp.p + top * 0.09 + np.array([0, 0, 0.07])
d = lp.p - eye
view = CameraView(640, 480, math.radians(50), Pose.from_xyz_rpy(
    tuple(eye), (0, -math.atan2(d[2], math.hypot(d[0], d[1])), math.atan2(d[1], d[0]))))
rgb = w.renderer.render(view)
cv2.imwrite(os.path.join(ROOT, 'docs/led.png'), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
w.shutdown()
