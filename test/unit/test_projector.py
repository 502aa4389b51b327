"""Projector (simsensors.projector, libgazebo_ros_projector.so): frustum math, image
messages, bad input, and the projected picture seen by a camera. No roscore."""
import logging
import math
import types

import numpy as np
import pytest

from simsensors.projector import (Projector, image_from_msg, pixel_on_plane, pixel_ray,
                                  world_to_pixel)
from sim_world.render import CameraView
from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf
from sim_world.world import World

DOWN = Pose.from_xyz_rpy((0, 0, 2), (0, math.pi / 2, 0))   # link x -> world -z, z -> +x


def test_frustum_maps_image_corners_to_world_points():
    # hfov 90 deg, 640x480, 2 m over the floor: half width 2 m, half height 1.5 m;
    # image top = link +z = world +x, image left = link +y = world +y
    fov, w, h = math.pi / 2, 640, 480
    tl = pixel_on_plane(DOWN, fov, w, h, -0.5, -0.5, (0, 0, 0), (0, 0, 1))
    br = pixel_on_plane(DOWN, fov, w, h, w - 0.5, h - 0.5, (0, 0, 0), (0, 0, 1))
    assert tl == pytest.approx([1.5, 2.0, 0.0], abs=1e-9)
    assert br == pytest.approx([-1.5, -2.0, 0.0], abs=1e-9)
    centre = pixel_on_plane(DOWN, fov, w, h, (w - 1) / 2, (h - 1) / 2, (0, 0, 0), (0, 0, 1))
    assert centre == pytest.approx([0, 0, 0], abs=1e-9)
    u, v, d = world_to_pixel(DOWN, fov, w, h, (1.5, 2.0, 0.0))
    assert (u, v, d) == pytest.approx((-0.5, -0.5, 2.0))
    assert pixel_ray(DOWN, fov, w, h, 319.5, 239.5) == pytest.approx([0, 0, -1])
    # a wall: the projector looks along +x at a wall 3 m away
    side = Pose((0, 0, 1))
    top = pixel_on_plane(side, fov, w, h, 319.5, -0.5, (3, 0, 0), (-1, 0, 0))
    assert top == pytest.approx([3, 0, 1 + 3 * 240 / 320.0])


def _msg(enc, w, h, data, step=None):
    ch = {'mono8': 1, 'rgb8': 3, 'bgr8': 3}.get(enc, 4)
    return types.SimpleNamespace(encoding=enc, width=w, height=h,
                                 step=step or w * ch, data=bytes(data))


def test_image_messages():
    rgb = image_from_msg(_msg('rgb8', 2, 1, [255, 0, 0, 0, 0, 255]))
    assert rgb.shape == (1, 2, 3) and tuple(rgb[0, 0]) == (255, 0, 0)
    bgr = image_from_msg(_msg('bgr8', 1, 1, [255, 0, 0]))
    assert tuple(bgr[0, 0]) == (0, 0, 255)
    assert tuple(image_from_msg(_msg('mono8', 1, 1, [9]))[0, 0]) == (9, 9, 9)
    assert tuple(image_from_msg(_msg('bgra8', 1, 1, [1, 2, 3, 4]))[0, 0]) == (3, 2, 1)
    with pytest.raises(ValueError, match='32FC1'):
        image_from_msg(_msg('32FC1', 1, 1, [0] * 4))
    with pytest.raises(ValueError, match='needs 12 bytes'):
        image_from_msg(_msg('rgb8', 2, 2, [0] * 5))


def _scene(on=True, **params):
    w = World(physics='ode', seed=1, gravity=(0, 0, 0))
    w.add_model(parse_urdf('''<robot name="floor"><link name="base">
      <visual><geometry><box size="4 4 0.02"/></geometry></visual></link>
      <gazebo><static>true</static></gazebo>
      <gazebo reference="base"><material>Gazebo/DarkGrey</material></gazebo></robot>''',
                           name='floor'), pose=Pose((0, 0, -0.01)))
    extra = ''.join('<%s>%s</%s>' % (k, v, k) for k, v in params.items())
    w.add_model(parse_urdf('''<robot name="proj"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial>
      </link><gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
      <gazebo><plugin name="projector" filename="libgazebo_ros_projector.so">
      <fov>0.5</fov><nearClipDist>0.1</nearClipDist><farClipDist>5</farClipDist>
      <updateRate>30</updateRate>%s</plugin></gazebo></robot>''' % extra, name='proj'),
                pose=Pose.from_xyz_rpy((0, 0, 1.0), (0, math.pi / 2, 0)))
    p = next(x for x in w.plugins['proj'] if isinstance(x, Projector))
    return w, p


def _red_green_on_the_floor(w, proj):
    """Projects a picture, left half red, right half green, and steps 40 ms: the renderer,
    a camera looking at the floor and what it saw before the picture."""
    r = w.renderer
    cam = CameraView(160, 120, math.radians(70),
                     Pose.from_xyz_rpy((-1.2, 0, 1.2), (0, math.radians(45), 0)),
                     background=(0.2, 0.2, 0.2))
    dark = r.render(cam).astype(int)          # before any picture
    img = np.zeros((48, 64, 3), np.uint8)
    img[:, :32] = (255, 0, 0)
    img[:, 32:] = (0, 255, 0)
    proj.set_image(img)
    w.step(40)
    return r, cam, dark


def test_camera_sees_the_projected_picture_on_the_floor_and_not_when_off(caplog):
    w, proj = _scene()
    try:
        r, cam, dark = _red_green_on_the_floor(w, proj)
        assert w.power.draws('proj')['projector'] == pytest.approx(1.5)
        lit = r.render(cam).astype(int)
        # image left = projector link +y = world +y (pitched down); 0.2 m each side
        ul, vl = [int(round(c)) for c in cam.project((0, 0.06, 0))[0]]
        ur, vr = [int(round(c)) for c in cam.project((0, -0.06, 0))[0]]
        left, right = lit[vl, ul], lit[vr, ur]
        gain_l, gain_r = left - dark[vl, ul], right - dark[vr, ur]
        assert gain_l[0] > 60 and gain_l[1] < 10 and gain_l[2] < 10, (left, dark[vl, ul])
        assert gain_r[1] > 60 and gain_r[0] < 10 and gain_r[2] < 10, (right, dark[vr, ur])
        import cv2
        cv2.imwrite('/tmp/projector_test.png', lit[:, :, ::-1].astype(np.uint8))
        outside = lit[[int(round(c)) for c in cam.project((0.0, 0.6, 0))[0]][::-1][0],
                      [int(round(c)) for c in cam.project((0.0, 0.6, 0))[0]][0]]
        assert abs(int(outside[0]) - int(outside[1])) < 25, outside   # grey: outside frustum
        proj.enable(False)
        w.step(40)
        assert w.power.draws('proj')['projector'] == 0.0
        off = r.render(cam).astype(int)
        assert abs(off[vl, ul, 0] - off[vl, ul, 1]) < 25 and abs(off[vr, ur, 0] - off[vr, ur, 1]) < 25
        # bad input: unsupported encoding -> one line, the picture is kept
        proj.enable(True)
        with caplog.at_level(logging.ERROR):
            proj._on_image(_msg('32FC1', 1, 1, [0] * 4))
        assert sum('32FC1' in rec.getMessage() for rec in caplog.records) == 1
        w.step(40)
        again = r.render(cam).astype(int)
        assert again[vl, ul, 0] > again[vl, ul, 1] + 60
        # attenuation: the same picture from 2 m is dimmer than from 1 m
        before = int(again[vl, ul, 0])
        w.set_state('proj', Pose.from_xyz_rpy((0, 0, 2.0), (0, math.pi / 2, 0)))
        w.step(40)
        far = r.render(cam).astype(int)
        ul2, vl2 = [int(round(c)) for c in cam.project((0, 0.12, 0))[0]]
        assert far[vl2, ul2, 0] - far[vl2, ul2, 1] < before - again[vl, ul, 1] - 20
    finally:
        w.shutdown()


def test_unreadable_texture_file_one_line_and_world_runs(tmp_path, caplog):
    with caplog.at_level(logging.ERROR):
        w, proj = _scene(textureName=str(tmp_path / 'nope.png'))
    try:
        assert sum('nope.png' in r.getMessage() for r in caplog.records) == 1
        w.step(100)
        assert proj.image is None and proj.last_value is False
    finally:
        w.shutdown()


def test_an_object_between_the_projector_and_the_floor_blocks_the_picture():
    """Occlusion (a shadow map from the projector): a board 0.5 m under the projector stops
    the red half of the picture; the floor behind it shows none, the board shows it; the
    green half still lands on the floor. Without the board the floor shows red there."""
    w, proj = _scene()
    try:
        r, cam, dark = _red_green_on_the_floor(w, proj)

        def px(p, im):
            u, v = [int(round(c)) for c in cam.project(p)[0]]
            return im[v, u] - dark[v, u], (u, v)
        shade, green = (0.0, 0.15, 0.0), (0.0, -0.1, 0.0)
        free = r.render(cam).astype(int)
        assert px(shade, free)[0][0] > 60                       # red on the floor
        board = parse_urdf('''<robot name="board"><link name="b">
          <visual><geometry><box size="0.1 0.1 0.01"/></geometry></visual></link>
          <gazebo><static>true</static></gazebo>
          <gazebo reference="b"><material>Gazebo/DarkGrey</material></gazebo></robot>''',
                           name='board')
        w.add_model(board, pose=Pose((0, 0.06, 0.5)))
        w.step(40)
        blocked = r.render(cam).astype(int)
        gain, (u, v) = px(shade, blocked)
        assert abs(gain[0]) < 12, gain                          # the board's shadow: no red
        assert px(green, blocked)[0][1] > 60                    # green half unaffected
        # the board itself shows the picture (its top, seen from the camera)
        ub, vb = [int(round(c)) for c in cam.project((0, 0.06, 0.505))[0]]
        assert blocked[vb, ub, 0] - blocked[vb, ub, 1] > 40
        # without the shadow map the picture paints through the board onto the floor
        r.projector_shadows = False
        through = r.render(cam).astype(int)
        assert px(shade, through)[0][0] > 60
    finally:
        w.shutdown()
