"""The world's pace in the studio's header (sim_studio/physics.py, static/ext/physics.js) in
Chromium on the shared studio: a value typed in the aim field and Enter sets the world's
real-time factor, as /gazebo/get_physics_properties then gives it, the field shows the
world's answer, and the world runs no faster than it; a negative one is refused by the op
and the world keeps its pace. The pace is given back at the end."""
import json
import re
import subprocess
import time

import pytest

from fixtures.studio import post

pytestmark = pytest.mark.rostest


def _rate(studio):
    """max_update_rate and time_step of the world, from rosservice as a user asks."""
    out = subprocess.run(['rosservice', 'call', '/gazebo/get_physics_properties'],
                         env=studio['env'], stdout=subprocess.PIPE, text=True,
                         timeout=60).stdout
    step = float(re.search(r'^time_step: (\S+)', out, re.M).group(1))
    return float(re.search(r'^max_update_rate: (\S+)', out, re.M).group(1)), step


def _read(studio):
    """The studio's read of the pace (op physics: /gazebo/get_physics_properties)."""
    _status, rep = post(studio, json.dumps({'v': 1, 'op': 'physics'}))
    assert rep['ok'], rep
    return rep


@pytest.fixture(scope='module')
def page(shared_studio, shared_page):
    post(shared_studio, json.dumps({'v': 1, 'op': 'play'}))
    before = _read(shared_studio)['real_time_factor']
    yield shared_page
    post(shared_studio, json.dumps({'v': 1, 'op': 'physics', 'real_time_factor': before}))


def test_the_aim_typed_in_the_header_paces_the_world(shared_studio, page):
    aim = page.get_by_test_id('rtf-aim')
    aim.fill('0.25')
    aim.press('Enter')
    # the page shows what the world answered (the op's reply: get_physics_properties)
    page.wait_for_function("parseFloat(document.querySelector('[data-testid=rtf-aim]')"
                           ".value) === 0.25", timeout=90000)
    rate, step = _rate(shared_studio)            # as a user reads it: rosservice
    assert rate == pytest.approx(0.25 / step)
    # paced: in 2 s of wall time the world's sim time moves at most about 0.25 of it
    t0, w0 = float(page.get_by_test_id('sim-time').inner_text()), time.monotonic()
    time.sleep(2.0)
    t1, w1 = float(page.get_by_test_id('sim-time').inner_text()), time.monotonic()
    assert 0 < t1 - t0 < 0.5 * (w1 - w0) + 0.1, (t0, t1, w1 - w0)
    # bad: a negative value is refused by the op (one error) and the pace stays
    _status, rep = post(shared_studio, json.dumps({'v': 1, 'op': 'physics',
                                                   'real_time_factor': -1}))
    assert not rep['ok'] and 'real_time_factor' in rep['error'], rep
    assert _read(shared_studio)['real_time_factor'] == pytest.approx(0.25)
    _status, rep = post(shared_studio, json.dumps({'v': 1, 'op': 'physics',
                                                   'real_time_factor': 1.0}))
    assert rep['ok'] and rep['real_time_factor'] == pytest.approx(1.0), rep
