"""Renderer.set_link_color: a link drawn in a colour set at run time, unlit (emissive) or
lit, and back to its material (the LED and the thermal display use it). No roscore."""
import math

import numpy as np
import pytest

from sim_world.model import Geometry, Link, Material, Model, Visual
from sim_world.render import CameraView, Renderer
from sim_world.transforms import Pose


def _scene():
    r = Renderer()
    r.set_lights([], ambient=(0, 0, 0), default_sun=False)         # a dark world
    vis = Visual(Geometry('box', size=(0.4, 0.4, 0.05)),
                 material=Material((0.1, 0.1, 0.1, 1.0), name='dark'))
    r.add_model(Model('m', links={'led': Link('led', visuals=[vis])}, pose=Pose()))
    view = CameraView(40, 40, math.radians(60), Pose.from_xyz_rpy((0, 0, 1), (0, math.pi / 2, 0)),
                      background=(0, 0, 0))
    return r, view


def test_unlit_colour_is_seen_in_the_dark_and_restored():
    r, view = _scene()
    assert r.render(view).max() < 5                       # lit dark material, no light
    r.set_link_color('m', 'led', (1.0, 0.0, 0.0), lit=False)
    rgb = r.render(view)
    assert list(rgb[20, 20]) == [255, 0, 0]
    r.set_link_color('m', 'led', (0.0, 0.5, 1.0, 1.0), lit=False)
    assert list(r.render(view)[20, 20]) == pytest.approx([0, 128, 255], abs=1)
    r.set_link_color('m', 'led', None)
    assert r.render(view).max() < 5


def test_lit_colour_needs_light_and_bad_input_is_refused():
    r, view = _scene()
    r.set_link_color('m', 'led', (1.0, 0.0, 0.0), lit=True)
    assert r.render(view).max() < 5                       # lit: dark without lights
    with pytest.raises(ValueError, match='0..1'):
        r.set_link_color('m', 'led', (2.0, 0.0, 0.0))
    with pytest.raises(KeyError):
        r.set_link_color('m', 'nolink', (1.0, 0.0, 0.0))
    assert np.asarray(r.render(view)).max() < 5           # the last good state stays
