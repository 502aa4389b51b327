#!/usr/bin/env python3
"""Regenerate docs/projector.png: the office world's phone held 0.35 m over the desk, its
top edge tilted down, projecting a test picture (colour bars and a label) onto the desk
through its pico projector (simsensors.projector) past a mug that shadows part of it,
seen by the simulator's renderer.
Run: source build/env.sh && python3 docs/make_projector_png.py"""
import math
import os
import re

import cv2
import numpy as np

from sim_world.render import CameraView
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
launch = open(os.path.join(ROOT, 'sim_world/launch/office.launch')).read()


def arg(n):
    return float(re.search(r'name="%s" default="([^"]+)"' % n, launch).group(1))


w = World(physics='ode', seed=1, gravity=(0, 0, 0))
w.load_world_file(os.path.join(ROOT, 'sim_world/worlds/office.world'))
x, y, z = arg('phone_x'), arg('phone_y'), arg('phone_z')
w.add_model(load_urdf_file(os.path.join(ROOT, 'sim_world/urdf/mobile_device.urdf.xacro')),
            pose=Pose.from_xyz_rpy((x, y, z + 0.35), (0, math.radians(70), 0)))
proj = next(p for p in w.plugins['mobile_device'] if type(p).__name__ == 'Projector')
img = np.zeros((240, 320, 3), np.uint8)
bars = [(255, 255, 255), (255, 255, 0), (0, 255, 255), (0, 255, 0), (255, 0, 255),
        (255, 0, 0), (0, 0, 255), (40, 40, 40)]
for i, c in enumerate(bars):
    img[:160, i * 40:(i + 1) * 40] = c
cv2.putText(img, 'mobile_device', (20, 215), cv2.FONT_HERSHEY_SIMPLEX, 1.1, (255, 255, 255), 3)
proj.set_image(img)
w.step(50)
pp = w.link_pose('mobile_device', 'mobile_projector')
# a mug standing on the desk in the beam (the projector's shadow map: its shadow behind it)
ray = pp.rotate(np.array([1.0, 0, 0]))
hit = pp.p + ray * (0.75 - pp.p[2]) / ray[2]                 # centre of the picture on the desk
foot = pp.p + (hit - pp.p) * 0.8
w.add_model(parse_urdf('''<robot name="mug"><link name="m"><visual>
  <geometry><cylinder radius="0.035" length="0.1"/></geometry></visual></link>
  <gazebo><static>true</static></gazebo>
  <gazebo reference="m"><material>Gazebo/Grey</material></gazebo></robot>''', name='mug'),
            pose=Pose((foot[0], foot[1] - 0.04, 0.80)))
w.step(10)
eye = pp.p + np.array([-0.45, -0.6, 0.05])
target = pp.p + pp.rotate(np.array([0.2, 0, 0]))
d = target - eye
view = CameraView(640, 480, math.radians(55), Pose.from_xyz_rpy(
    tuple(eye), (0, -math.atan2(d[2], math.hypot(d[0], d[1])), math.atan2(d[1], d[0]))))
rgb = w.renderer.render(view)
cv2.imwrite(os.path.join(ROOT, 'docs/projector.png'), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
w.shutdown()
