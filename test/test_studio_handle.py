"""The rotate handle of the studio's 3D view (studio.js: three.js TransformControls, key
``r``) in Chromium on the shared studio, with real mouse events: a drag along the blue (z)
ring turns the phone about the vertical, and /gazebo/get_model_state then has the yaw the
handle showed, with roll, pitch and position unchanged; once while the world plays, once
while it is paused. The phone, the handle's mode and the world's state are left as found."""
import json
import math
import time

import pytest
from sim_world.transforms import rpy_from_quat

from fixtures.studio import post
from test_studio import model_state

pytestmark = pytest.mark.rostest

# a point of the handle's z ring on the screen, found with the handle's own picker: from the
# handle's middle outwards through where the ring's circle (radius 1 in the gizmo's scale,
# as studio.handlePoint computes it for the arrows) is at an angle, pixel by pixel, the
# middle of the longest run of whole pixels (a mouse event's clientX, clientY) where the
# picker meets the z ring first (not where the x or y ring crosses it, nor the trackball
# sphere)
RING_POINT = """(() => {
  const h = studio.handle, cam = studio.camera, gizmo = h.children[0];
  h.updateMatrixWorld();          // the gizmo for the camera as it is now (not at the last frame)
  const pos = h.object.getWorldPosition(new THREE.Vector3());
  const f = pos.distanceTo(cam.position) *
    Math.min(1.9 * Math.tan(Math.PI * cam.fov / 360) / cam.zoom, 7) * h.size / 7;
  const rect = studio.renderer.domElement.getBoundingClientRect();
  const rc = new THREE.Raycaster();
  // what the handle's picker meets first at a pixel (a mouse event's clientX, clientY are
  // whole pixels)
  const first = (x, y) => {
    rc.setFromCamera({x: (x - rect.left) / rect.width * 2 - 1,
                      y: -(y - rect.top) / rect.height * 2 + 1}, cam);
    const hit = rc.intersectObjects(gizmo.picker.rotate.children, true)[0];
    return hit ? hit.object.name : null;
  };
  const screen = (v) => { const n = v.clone().project(cam);
    return [rect.left + (n.x + 1) / 2 * rect.width, rect.top + (1 - n.y) / 2 * rect.height]; };
  const c = screen(pos);
  const tried = [];
  for (const deg of [-45, -135, -60, -120, -30, -150]) {
    // from the middle outwards through the ring's point at this angle, pixel by pixel: the
    // middle of the longest run of pixels where the z ring is what the picker meets first
    const a = deg * Math.PI / 180;
    const e = screen(pos.clone().add(new THREE.Vector3(Math.cos(a), Math.sin(a), 0)
      .multiplyScalar(f)));
    const len = Math.hypot(e[0] - c[0], e[1] - c[1]);
    let run = [], best = [];
    for (let k = Math.floor(0.6 * len); k <= 1.4 * len; k++) {
      const x = Math.floor(c[0] + (e[0] - c[0]) * k / len);
      const y = Math.floor(c[1] + (e[1] - c[1]) * k / len);
      if (first(x, y) === 'Z') { run.push([x, y]); if (run.length > best.length) best = run; }
      else run = [];
    }
    tried.push([deg, best.length]);
    if (best.length >= 3) {
      const m = best[Math.floor(best.length / 2)];
      return {x: m[0], y: m[1], deg: deg, run: best.length, top: rect.top};
    }
  }
  return {tried: tried};
})()"""


VIEW_TOP = 'studio.renderer.domElement.getBoundingClientRect().top'


def yaw_of(q):
    return float(rpy_from_quat(q)[2])


def tilt_of(q):
    """(roll, pitch) of a quaternion [x, y, z, w]."""
    r, p, _y = rpy_from_quat(q)
    return float(r), float(p)


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


@pytest.fixture
def page(shared_studio, shared_page):
    pg = shared_page
    post(shared_studio, json.dumps({'v': 1, 'op': 'play'}))
    pg.evaluate("studio.setView('free'); studio.live = true; studio.select('mobile_device')")
    start, quat = model_state(shared_studio)
    yield pg
    pg.evaluate("studio.handle.setMode('translate')")
    post(shared_studio, json.dumps({'v': 1, 'op': 'set_pose', 'model': 'mobile_device',
                                    'position': start,
                                    'rpy': list(tilt_of(quat)) + [yaw_of(quat)]}))
    post(shared_studio, json.dumps({'v': 1, 'op': 'play'}))


def _drag_ring(studio, page, dx, paused):
    """Drag the z ring by dx px to the right; (yaw before, yaw after, the handle's angle)."""
    before, q0 = model_state(studio)
    # the page shows the world's pose now (the handle turns the object from where it is)
    page.wait_for_function(
        "(() => { const o = studio.models.mobile_device.quaternion; "
        "return Math.abs(Math.atan2(2 * (o.w * o.z + o.x * o.y), 1 - 2 * (o.y * o.y + "
        "o.z * o.z)) - %r) < 1e-3; })()" % yaw_of(q0), timeout=30000)
    page.evaluate("studio.lookAt('mobile_device')")
    # the header's status line empty (a message there can change the header's height, and
    # the view would move under the mouse when a reply clears it), the layout settled
    page.evaluate("studio.showError(null); new Promise((r) => requestAnimationFrame(() => "
                  "requestAnimationFrame(r)))")
    p = page.evaluate(RING_POINT)
    assert 'x' in p, ('no point of the z ring on the screen', p)
    page.mouse.move(p['x'], p['y'])               # hover: the handle takes the z axis
    assert page.evaluate('studio.handle.axis') == 'Z', p
    page.mouse.down()
    assert page.evaluate('[studio.dragging, studio.handle.axis]') == [True, 'Z'], p
    page.mouse.move(p['x'] + dx / 2, p['y'])
    page.mouse.move(p['x'] + dx, p['y'])
    page.mouse.up()
    assert page.evaluate(VIEW_TOP) == p['top'], ('the view moved during the drag', p)
    angle = page.evaluate('studio.handle.rotationAngle')
    want = wrap(yaw_of(q0) + angle)
    deadline = time.monotonic() + 30
    while True:
        pos, q = model_state(studio)
        if abs(wrap(yaw_of(q) - want)) < 2e-3 or time.monotonic() > deadline:
            break
        time.sleep(0.1)
    assert abs(wrap(yaw_of(q) - want)) < 2e-3, (yaw_of(q0), angle, q, paused, p)
    assert max(abs(a - b) for a, b in zip(pos, before)) < 2e-3, (before, pos)
    assert max(abs(v) for v in tilt_of(q)) < 2e-3, tilt_of(q)
    return yaw_of(q0), yaw_of(q), angle


def test_the_rotate_handle_turns_the_phone_playing_and_paused(shared_studio, page):
    start, _q = model_state(shared_studio)
    post(shared_studio, json.dumps({'v': 1, 'op': 'set_pose', 'model': 'mobile_device',
                                    'position': start, 'rpy': [0, 0, 0.3]}))
    page.evaluate("document.activeElement && document.activeElement.blur()")
    page.keyboard.press('r')
    assert page.evaluate('studio.handle.mode') == 'rotate'
    # to the right on the screen: counter-clockwise seen from above (the camera looks from
    # -y and above): the yaw grows, by a plausible part of a turn
    y0, y1, angle = _drag_ring(shared_studio, page, 16, paused=False)
    assert 0.1 < wrap(y1 - y0) < 2.5 and angle > 0, (y0, y1, angle)
    # paused: the handle still sets the pose; to the left, the yaw shrinks
    post(shared_studio, json.dumps({'v': 1, 'op': 'pause'}))
    y2, y3, angle = _drag_ring(shared_studio, page, -16, paused=True)
    assert -2.5 < wrap(y3 - y2) < -0.1 and angle < 0, (y2, y3, angle)
