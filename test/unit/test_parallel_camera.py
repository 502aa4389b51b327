"""The camera in parallel with physics (issue 22 part 5): frames render in the renderer's
worker thread while the world steps on, and still show the scene of their tick, in order,
on their sim-time schedule: the same frames as rendered in the world thread."""
import hashlib
import math

import numpy as np

from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf
from sim_world.world import World

import os
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')
PHONE_XYZ = (3.288, -2.11, 1.0)


def _run(parallel, steps=400):
    w = World(physics='ode', seed=5)
    try:
        w.parallel_render = parallel
        w.load_world_file(OFFICE)
        w.add_model(load_urdf_file(PHONE), pose=Pose(PHONE_XYZ))
        w.add_model(parse_urdf('''<robot name="box"><link name="b">
          <visual><geometry><box size="0.03 0.03 0.03"/></geometry></visual></link>
          <gazebo><static>true</static></gazebo>
          <gazebo reference="b"><material>Gazebo/Red</material></gazebo></robot>''',
                               name='box'), pose=Pose((3.30, -2.2, 0.85)))
        cam = next(p for p in w.plugins['mobile_device'] if type(p).__name__ == 'CameraPlugin')
        cam.force_render = True
        cam.set_update_rate(30.0)
        ticks, frames, threads = [], [], set()
        update, deliver = cam.update, cam._deliver

        def on_update(t):
            ticks.append(round(t, 6))
            update(t)

        def on_deliver(rgb, depth, stamp, want_depth):
            import threading
            threads.add(threading.current_thread().name)
            frames.append(hashlib.sha1(rgb.tobytes()).hexdigest())
            deliver(rgb, depth, stamp, want_depth)
        cam.update, cam._deliver = on_update, on_deliver
        for i in range(steps):
            # the box sweeps through the view, a new place every step: a frame rendered
            # after its tick would show it elsewhere
            w.set_state('box', Pose((3.30 + 0.0004 * i, -2.2 + 0.0008 * i, 0.85)))
            w.step(1, wait=False)
        w.flush()
        return ticks, frames, threads
    finally:
        w.shutdown()


def test_parallel_frames_equal_serial_frames_on_schedule():
    t_par, f_par, th_par = _run(True)
    t_ser, f_ser, th_ser = _run(False)
    assert th_par == {'renderer'} and th_ser == {'MainThread'}
    assert t_par == t_ser and len(t_par) >= 11
    # the camera's schedule: every 1/30 s of sim time
    assert np.allclose(np.diff(t_par), 1 / 30.0, atol=1.5e-3)
    assert f_par == f_ser                       # frame by frame the same pictures
    assert len(set(f_par)) > len(f_par) // 2    # and the box did move between frames


def test_step_waits_for_the_frame_by_default():
    w = World(physics='ode', seed=5)
    try:
        w.load_world_file(OFFICE)
        w.add_model(load_urdf_file(PHONE), pose=Pose(PHONE_XYZ))
        cam = next(p for p in w.plugins['mobile_device'] if type(p).__name__ == 'CameraPlugin')
        cam.force_render = True
        cam.set_update_rate(30.0)
        for k in range(1, 6):
            w.step(34)                           # one frame per call, delivered on return
            assert cam.frames == k and cam.last_image is not None
    finally:
        w.shutdown()
