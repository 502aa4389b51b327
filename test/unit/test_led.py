"""Notification LED (simsensors.led, libgazebo_ros_led.so) on the phone: colour, blink
timing on the sim-time clock, power, bad input, and what a camera sees. No roscore."""
import logging
import math
import os

import numpy as np
import pytest

from simsensors.led import Led, LedPattern, argb_rgb, parse_color
from sim_world.render import CameraView
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')


@pytest.fixture
def phone():
    w = World(physics='ode', seed=1, gravity=(0, 0, 0))
    w.add_model(load_urdf_file(PHONE), pose=Pose((0, 0, 1)))
    led = next(p for p in w.plugins['mobile_device'] if isinstance(p, Led))
    yield w, led
    w.shutdown()


def test_colour_parsing():
    assert parse_color('red') == 0xff0000 and parse_color('#00FF00') == 0x00ff00
    assert parse_color('#80123456') == 0x123456
    assert argb_rgb(0xff0000ff) == (0.0, 0.0, 1.0)
    for bad in ('reddish', '#12345', '#gg0000'):
        with pytest.raises(ValueError):
            parse_color(bad)
    p = LedPattern.from_command(0xff00ff00, 300, 200)
    assert p.color_at(0.0) == (0, 1, 0) and p.color_at(0.299) == (0, 1, 0)
    assert p.color_at(0.3) is None and p.color_at(0.499) is None and p.color_at(0.5) == (0, 1, 0)
    assert LedPattern.from_command(0, 300, 200).color_at(0) is None       # argb 0: off
    assert LedPattern.from_command(0xffffffff, 0, 200).color_at(0) is None  # on_ms 0: off
    assert LedPattern.from_command(0xffffffff, 10, 0).color_at(123.4) == (1, 1, 1)  # steady


def test_blink_timing_on_sim_time_and_power(phone):
    w, led = phone
    assert led.body == 'mobile_led' and led.update_rate == 100.0
    w.step(5)
    assert led.command(color='blue', on_ms=300, off_ms=200)
    w.step(5)                                    # taken at the next 100 Hz tick
    t0 = led.t0
    assert t0 == pytest.approx(0.01)
    w.step(2000)
    edges = [(t - t0, rgb) for t, rgb in led.transitions if t >= t0]
    # lit at 0, dark at 0.3, lit at 0.5, dark at 0.8, ... (sim time, 10 ms ticks)
    expect = []
    for k in range(4):
        expect += [(0.5 * k, (0.0, 0.0, 1.0)), (0.5 * k + 0.3, None)]
    assert [round(t, 3) for t, _ in edges[:8]] == [round(t, 3) for t, _ in expect]
    assert [c for _, c in edges[:8]] == [c for _, c in expect]
    # state message and battery draw follow
    on = led.last_msg.a == 1.0
    assert w.power.draws('mobile_device')['led'] == (pytest.approx(0.02) if on else 0.0)
    led.command(argb=0xffff0000, on_ms=100, off_ms=0)          # steady red
    w.step(20)
    assert (led.last_msg.r, led.last_msg.g, led.last_msg.b, led.last_msg.a) == (1, 0, 0, 1)
    assert w.power.draws('mobile_device')['led'] == pytest.approx(0.02)
    led.command(argb=0)                                       # off
    w.step(20)
    assert led.last_msg.a == 0 and w.power.draws('mobile_device')['led'] == 0.0


def test_bad_input_one_line_and_last_state_kept(phone, caplog):
    w, led = phone
    led.command(color='green', on_ms=1000, off_ms=0)
    w.step(20)
    with caplog.at_level(logging.ERROR):
        assert not led.command(color='octarine', on_ms=100)
        assert not led.command(color='octarine', on_ms=100)
        assert not led.command(argb=0xffffffff, on_ms=-5, off_ms=10)
    w.step(50)
    lines = [r.getMessage() for r in caplog.records]
    assert len([l for l in lines if 'octarine' in l]) == 1
    assert any('on_ms must be >= 0' in l and 'libgazebo_ros_led.so' in l for l in lines)
    assert led.shown == (0.0, 1.0, 0.0)


def _camera_over_led(w):
    """A camera 6 cm over the LED looking down at the phone's top end."""
    led_pose = w.link_pose('mobile_device', 'mobile_led')
    cam = Pose.from_xyz_rpy(tuple(led_pose.p + np.array([0, 0, 0.06])), (0, math.pi / 2, 0))
    return CameraView(128, 128, math.radians(60), cam, background=(0.7, 0.7, 0.75)), led_pose


def test_camera_sees_the_led_colour_where_it_is_and_not_when_off(phone):
    w, led = phone
    r = w.renderer
    view, led_pose = _camera_over_led(w)
    u, v = view.project(led_pose.p + np.array([0, 0, 0.00025]))[0]
    u, v = int(round(u)), int(round(v))
    patch = lambda img: img[v - 1:v + 2, u - 1:u + 2].reshape(-1, 3)
    dark = r.render(view)
    assert not np.any((patch(dark)[:, 1] > 200) & (patch(dark)[:, 0] < 80))
    led.command(color='#00ff00', on_ms=1000, off_ms=1000)
    w.step(20)
    lit = r.render(view)
    g = patch(lit)
    assert np.all((g[:, 1] > 230) & (g[:, 0] < 30) & (g[:, 2] < 30)), g   # 3x3 px = 1.6 mm
    # only there: the green area is the LED's 2 mm square, not the whole picture
    green = (lit[:, :, 1] > 230) & (lit[:, :, 0] < 30)
    assert 4 <= green.sum() < 0.05 * green.size
    w.step(1000)                                  # the off phase of the blink
    assert led.shown is None
    off = r.render(view)
    assert not np.any((patch(off)[:, 1] > 200) & (patch(off)[:, 0] < 80))
