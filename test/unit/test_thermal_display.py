"""Thermal display (simsensors.thermal_display) on the phone: first-order time constant on
sim time (63 % after tau), colour red/blue/neutral, bad input, and the back seen red from
below by a camera. No roscore."""
import logging
import math
import os

import numpy as np
import pytest

from simsensors.thermal_display import ThermalDisplay, first_order, thermal_color
from sim_world.render import CameraView
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')


@pytest.fixture
def phone():
    w = World(physics='ode', seed=1)
    w.add_model(load_urdf_file(PHONE), pose=Pose((0, 0, 1)))
    th = next(p for p in w.plugins['mobile_device'] if isinstance(p, ThermalDisplay))
    yield w, th
    w.shutdown()


def test_colour_mapping():
    black = (0.05, 0.05, 0.05)
    assert thermal_color(33.0, black) == pytest.approx(black)
    assert thermal_color(43.0, black) == pytest.approx((1, 0, 0))
    assert thermal_color(50.0, black) == pytest.approx((1, 0, 0))
    hot = thermal_color(38.0, black)
    assert hot[0] > 0.5 and hot[1] < 0.05 and hot[2] < 0.05
    cold = thermal_color(23.0, black)
    assert cold[2] == pytest.approx(1.0) and cold[0] == pytest.approx(0.0)
    assert first_order(33.0, 43.0, 3.0, 3.0) == pytest.approx(33 + 10 * (1 - math.exp(-1)))


def test_time_constant_63_percent_after_tau(phone):
    w, th = phone
    assert th.body == 'mobile_back' and th.p.timeConstant == 3.0
    assert th.temperature == 33.0
    w.step(50)
    assert th.command(43.0)
    w.step(50)                                      # taken at the 10 Hz tick t = 0.1
    t0 = w.sim_time
    assert th.temperature == pytest.approx(33.0) and th.target == 43.0
    w.step(1000)
    assert th.temperature < 33.0 + 10 * 0.63 * 0.5   # it does not jump
    w.step(2000)                                    # t0 + tau
    assert w.sim_time - t0 == pytest.approx(3.0)
    frac = (th.temperature - 33.0) / 10.0
    assert frac == pytest.approx(1 - math.exp(-1), abs=1e-6)       # 63.2 %
    assert th.last_msg.temperature == pytest.approx(th.temperature)
    assert w.power.draws('mobile_device')['thermal_display'] == pytest.approx(
        0.05 * (th.temperature - 33.0))
    th.command(20.0)
    w.step(30000)
    assert th.temperature == pytest.approx(20.0, abs=0.01)
    assert th.color()[2] == pytest.approx(1.0)


def test_bad_input_keeps_the_target(phone, caplog):
    w, th = phone
    th.command(40.0)
    w.step(200)
    with caplog.at_level(logging.ERROR):
        assert not th.command(float('nan'))
        assert not th.command(500.0)
    w.step(200)
    assert th.target == 40.0
    lines = [r.getMessage() for r in caplog.records]
    assert any('nan' in l and 'libgazebo_ros_thermal_display.so' in l for l in lines)
    assert any('500' in l for l in lines)


def test_back_turns_red_when_heated_seen_from_below(phone):
    w, th = phone
    back = w.link_pose('mobile_device', 'mobile_back')
    cam = Pose.from_xyz_rpy(tuple(back.p - np.array([0, 0, 0.15])), (0, -math.pi / 2, 0))
    view = CameraView(64, 64, math.radians(40), cam, background=(0.7, 0.7, 0.75))
    r = w.renderer
    u, v = (int(round(x)) for x in view.project(back.p)[0])
    before = r.render(view)[v - 2:v + 3, u - 2:u + 3].reshape(-1, 3).astype(int)
    assert before.max() < 40                                # the black back
    th.command(45.0)
    w.step(15000)                                           # 5 tau
    after = r.render(view)[v - 2:v + 3, u - 2:u + 3].reshape(-1, 3).astype(int)
    assert np.all(after[:, 0] > 230) and np.all(after[:, 1:] < 30), after


def test_a_steady_colour_is_not_painted_again_and_a_change_is(phone, monkeypatch):
    """Painting waits for the renderer's frame in hand: at a steady temperature the thermal
    display's ticks leave the renderer alone; a command paints again, and so does a new
    renderer."""
    w, th = phone
    r = w.renderer
    calls = []
    real = r.set_link_color
    monkeypatch.setattr(r, 'set_link_color', lambda *a, **k: calls.append(a[2]) or real(*a, **k))
    w.step(1000)                                            # 1 s at neutral: 10 ticks
    assert calls == []
    th.command(45.0)
    w.step(1000)
    # warming: a new colour at every tick but the command's own (its step is the old target)
    assert len(calls) == 9 and len(set(calls)) == 9 and calls[-1][0] > calls[0][0]
    th._painted = (lambda: object(), th._painted[1])        # as if another renderer drew
    th.paint_link(th.color())
    assert len(calls) == 10
