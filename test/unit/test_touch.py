"""The touch screen and buttons (thesis 3.3.6, snippet 3.3.3) on the real phone model and the
World, both engines, without ROS (bad parameters: test_sensor_contract.py)."""
import math

import pytest

from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf

from simsensors.touch import DOWN, MOVE, UP, PointerTracker, TouchScreen

import worlds

DEPTH = 0.01088                        # phone body thickness (xacro)
TOP = DEPTH / 2 + 0.00025              # display's front face above mobile_base_link
R = 0.004                              # finger tip radius
world = worlds.world_fixture(seed=7, phone=(0, 0, 1))


def finger(name):
    return worlds.finger(name, R)


def touch_of(world, name='mobile_device'):
    return worlds.plugin_of(world, TouchScreen, name)


def press(world, name, dx=0.0, dy=0.0, depth=0.0003):
    """A finger pressing ``depth`` into the display at (dx, dy) of mobile_base_link from
    the display's centre (base x 0.002)."""
    world.add_model(finger(name), pose=Pose((0.002 + dx, dy, 1 + TOP + R - depth)))


def test_centre_touch_reports_centre_pixel(world):
    t = touch_of(world)
    w, h = t.size
    assert (w, h) == (307, 512)          # the display's video texture (textvid, 512 px long)
    press(world, 'finger')
    world.step(9)
    downs = [e for e in t.events if e[1] == DOWN]
    assert len(downs) == 1
    _, _, pid, x, y, pressure, stage = downs[0]
    assert pid == 0
    assert x == pytest.approx(w / 2, abs=1.0) and y == pytest.approx(h / 2, abs=1.0)
    assert 0 < pressure <= 1
    msg = t.last_msg
    assert msg.width == 307 and msg.height == 512 and msg.source == 'finger::tip'
    world.set_state('finger', Pose((0.002, 0, 1.05)))
    world.step(9)
    assert [e[1] for e in t.events] == [DOWN] + [MOVE] * (len(t.events) - 2) + [UP]


def test_offset_touch_maps_to_android_axes(world):
    """10 mm towards the top (camera end, base +x) is 56 px up; 10 mm to the right (device
    +x = base -y) is 56 px right."""
    t = touch_of(world)
    press(world, 'finger', dx=0.010, dy=-0.010)
    world.step(9)
    _, _, _, x, y, _, _ = [e for e in t.events if e[1] == DOWN][0]
    assert x == pytest.approx(307 / 2 + 0.010 / 0.0545 * 307, abs=2.0)
    assert y == pytest.approx(256 - 0.010 / 0.0909 * 512, abs=2.0)


def test_two_fingers_two_pointers(world):
    t = touch_of(world)
    press(world, 'finger_a', dx=-0.02)
    press(world, 'finger_b', dx=0.02)
    world.step(9)
    downs = [e for e in t.events if e[1] == DOWN]
    assert sorted(e[2] for e in downs) == [0, 1]
    assert sorted(round(e[4]) for e in downs) == sorted(
        [round(256 + 0.02 / 0.0909 * 512), round(256 - 0.02 / 0.0909 * 512)])


def test_injected_tap_and_swipe(world):
    t = touch_of(world)
    ok, text, _ = t.inject_touch(100, 200, 0.05)
    assert ok, text
    world.step(100)
    ev = list(t.events)
    assert ev[0][1:5] == (DOWN, 0, 100, 200) and ev[-1][1] == UP
    assert 0.05 < ev[-1][0] <= 0.05 + 2 / 100.0 + 1e-9
    t.events.clear()
    ok, _, _ = t.inject_touch(50, 400, 0.1, 0.9, 250, 100)
    assert ok
    world.step(200)
    ev = list(t.events)
    assert ev[0][1] == DOWN and ev[-1][1] == UP
    assert len([e for e in ev if e[1] == MOVE]) >= 5
    assert ev[-1][3:5] == pytest.approx((250, 100), abs=1e-6)
    assert ev[0][5] == pytest.approx(0.9) and ev[0][6] == 2
    for bad in [(-1, 5, 0.1), (5, 5, 0), (5, 5, 0.1, 2.0), (5, 5, 0.1, 0.5, 999, 3)]:
        ok, text, _ = t.inject_touch(*bad)
        assert not ok and 'inject_touch' in text


def test_buttons_by_contact_and_by_service(world):
    t = touch_of(world)
    assert [n for n, _ in t.button_links] == ['power', 'volume_up', 'volume_down']
    ok, text = t.press_button('power', 0.02)
    assert ok, text
    world.step(50)
    assert [(b, s) for _, b, s in t.button_events] == [('power', 1), ('power', 0)]
    ok, text = t.press_button('home', 0.1)
    assert not ok and 'home' in text
    # a body pressing the volume-up button on the phone's left side (base +y), placed one
    # step before the next sample (both float: the contact pushes them apart within ms)
    while world.sim_time + 0.001 < t.timer.next_time - 1e-9:
        world.step(1)
    world.add_model(finger('thumb'), pose=Pose((0.036, 0.0315 + 0.001 + R - 0.0003, 1)))
    world.step(1)
    assert ('volume_up', 1) in [(b, s) for _, b, s in t.button_events]
    assert not [e for e in t.events if e[1] == DOWN]       # the side is not the screen


def test_face_down_on_desk_is_no_touch(world):
    """A capacitive screen does not react to the desk: contacts yes, touches no."""
    desk = parse_urdf('''<robot name="desk"><link name="top">
      <collision><geometry><box size="1 1 0.03"/></geometry></collision></link></robot>''')
    desk.static = True
    world.add_model(desk, pose=Pose((0, 0, 0.5)))
    world.set_state("mobile_device", Pose.from_xyz_rpy((0, 0, 0.515 + TOP - 0.0002), (math.pi, 0, 0)))
    t = touch_of(world)
    t.force = True
    seen = []
    publish = t.contacts_pub.publish
    t.contacts_pub.publish = lambda m: (seen.append(m), publish(m))
    # sample now, in the pose just set (both float: ODE pushes them apart within a step)
    t.update(world.sim_time)
    world.step(25)
    assert not t.events
    names = set(s.collision2_name for m in seen for s in m.states)
    assert 'desk::top' in names
    assert set(s.collision1_name for m in seen for s in m.states) == {'mobile_device::mobile_display'}


def test_pointer_tracker_ids():
    tr = PointerTracker(0.5)
    ev = tr.update({'a': (1, 1, 0, 'a'), 'b': (5, 5, 0, 'b')})
    assert [(e[0], e[1]) for e in ev] == [(DOWN, 0), (DOWN, 1)]
    ev = tr.update({'b': (5, 6, 0, 'b')})
    assert [(e[0], e[1]) for e in ev] == [(UP, 0), (MOVE, 1)]
    ev = tr.update({'b': (5, 6.1, 0, 'b'), 'c': (0, 0, 0, 'c')})
    assert [(e[0], e[1]) for e in ev] == [(DOWN, 0)]       # lowest free id, no tiny move


def test_same_seed_same_events():
    def run(physics):
        with worlds.opened(physics, 3, phone=(0, 0, 1)) as w:
            press(w, 'finger', dx=0.01)
            t = touch_of(w)
            t.inject_touch(20, 30, 0.03, 0.2, 60, 90)
            w.step(100)
            return list(t.events)
    for physics in ('ode', 'bullet'):
        assert run(physics) == run(physics)


@pytest.mark.parametrize('syntax', ['classic', '2011'])
def test_both_syntaxes(syntax):
    with worlds.opened('ode', 1) as w:
        w.add_model(worlds.sensor_robot(
            'libgazebo_ros_touch.so', '<bodyName>screen</bodyName><displayWidth>100</displayWidth>'
            '<displayHeight>200</displayHeight>', syntax=syntax, plugin='t', body=None,
            link='screen', box=(0.1, 0.05, 0.001), visual=True))
        t = touch_of(w, 'r')
        assert t.size == (100, 200) and t.body == 'screen'
        t.inject_touch(50, 100, 0.01)
        w.step(30)
        assert [e[1] for e in t.events] == [DOWN, UP]
