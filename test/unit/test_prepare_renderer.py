"""World.prepare_renderer (issue 18): the renderer (GL context, imports, the models'
meshes) is made before a run's first step when a camera will draw, not inside the first
frame's tick, and only then. The frames are the same either way."""
import hashlib

from sim_world.plugins import Plugin
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf
from sim_world.world import World

from worlds import OFFICE, PHONE

PHONE_XYZ = (3.288, -2.11, 1.0)


def _phone_world():
    w = World(physics='ode', seed=3)
    w.load_world_file(OFFICE)
    w.add_model(load_urdf_file(PHONE), pose=Pose(PHONE_XYZ))
    return w


def _camera(w):
    return next(p for p in w.plugins['mobile_device'] if type(p).__name__ == 'CameraPlugin')


def _frames(w, steps=250):
    cam = _camera(w)
    cam.set_update_rate(20.0)
    out = []
    deliver = cam._deliver

    def keep(rgb, depth, stamp, want_depth):
        out.append(hashlib.sha1(rgb.tobytes()).hexdigest())
        deliver(rgb, depth, stamp, want_depth)
    cam._deliver = keep
    w.step(steps)
    return out


def test_a_camera_that_will_draw_gets_the_renderer_before_the_first_step():
    w = _phone_world()
    try:
        assert w.renderer_if_created is None              # nothing made it at load
        assert _camera(w).will_draw()
        assert w.prepare_renderer() is True
        r = w.renderer_if_created
        assert r is not None
        assert w.prepare_renderer() is True and w.renderer_if_created is r   # once
        ahead = _frames(w)
    finally:
        w.shutdown()
    w = _phone_world()
    try:
        lazy = _frames(w)                                 # made by the first frame's tick
    finally:
        w.shutdown()
    assert len(ahead) >= 4 and ahead == lazy


def test_no_renderer_without_a_camera_that_draws():
    w = World(physics='ode', seed=3)
    try:
        w.add_model(parse_urdf('<robot name="box"><link name="b"><visual><geometry>'
                               '<box size="0.1 0.1 0.1"/></geometry></visual></link>'
                               '<gazebo><static>true</static></gazebo></robot>',
                               name='box'), pose=Pose((0, 0, 1)))
        assert w.prepare_renderer() is False and w.renderer_if_created is None
    finally:
        w.shutdown()
    w = _phone_world()
    try:
        _camera(w).wanted = lambda: (False, False)        # nobody subscribes to it
        assert w.prepare_renderer() is False and w.renderer_if_created is None
    finally:
        w.shutdown()


def test_a_plugin_whose_question_fails_leaves_the_renderer_to_its_tick():
    w = _phone_world()
    try:
        cam = _camera(w)

        def broken():
            raise RuntimeError('no')
        cam.will_draw = broken
        assert w.prepare_renderer() is False and w.renderer_if_created is None
        assert Plugin.will_draw(cam) is False               # the base class never draws
        w.step(60)                                          # the camera's tick makes it
        assert w.renderer_if_created is not None and cam.frames >= 1
    finally:
        w.shutdown()
