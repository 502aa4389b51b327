"""Models spawned after the studio started, in Chromium on the shared studio
(sim_studio/spawned.py, static/ext/spawned.js, sim_world's /gazebo/get_model_description): a
mesh model with an NFC tag spawned through /gazebo/spawn_sdf_model gets its description in
/api/scene (the mesh served as a shape, not the box of an unknown model), is drawn in the
3D view in its colour, its tag's icon is in world_info where the model is now (also after a
move), and once deleted it is gone from the scene and the view."""
import json
import subprocess
import sys
import urllib.request

import pytest

from fixtures.studio import until as _until, data_url, png_pixels, post, scene_names

pytestmark = pytest.mark.rostest

NAME = 'studio_late_crate'
AT = (4.2, -3.9, 0.0)
SDF = '''<sdf version="1.6"><model name="x"><static>true</static>
  <link name="body"><visual name="v"><geometry><mesh><uri>file://%s</uri></mesh></geometry>
    <material><diffuse>0.55 0.95 0.05 1</diffuse></material></visual></link>
  <plugin name="late_tag" filename="libgazebo_ros_nfc_tag.so"><data>T:late</data>
    <range>0.04</range></plugin>
</model></sdf>'''

# the test's own ROS client: spawns the model (its SDF on stdin up to a line 'END'), says
# the answer, then deletes it when it reads the next line
CLIENT = """
import sys, rospy
from geometry_msgs.msg import Pose
from mobile_device_sim.srv import DeleteModel, SpawnModel
name = sys.argv[1]
p = Pose()
p.position.x, p.position.y, p.position.z = %r
p.orientation.w = 1.0
rospy.wait_for_service('/gazebo/spawn_sdf_model', 30)
xml = ''.join(iter(sys.stdin.readline, 'END\\n'))
res = rospy.ServiceProxy('/gazebo/spawn_sdf_model', SpawnModel)(name, xml, '', p, '')
print(res.success, res.status_message, flush=True)
sys.stdin.readline()
res = rospy.ServiceProxy('/gazebo/delete_model', DeleteModel)(name)
print(res.success, res.status_message, flush=True)
""" % (AT,)


class Spawner(object):
    def __init__(self, studio, xml):
        self.p = subprocess.Popen([sys.executable, '-c', CLIENT, NAME], env=studio['env'],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.p.stdin.write(xml + '\nEND\n')
        self.p.stdin.flush()
        line = self.p.stdout.readline()
        assert line.startswith('True'), line

    def delete(self):
        self.p.stdin.write('delete\n')
        self.p.stdin.flush()
        line = self.p.stdout.readline()
        self.p.wait(30)
        assert line.startswith('True'), line


def scene_model(studio):
    with urllib.request.urlopen(studio['url'] + 'api/scene', timeout=30) as r:
        return next((m for m in json.loads(r.read())['models'] if m['name'] == NAME), None)


def shot(page):
    n = page.evaluate('studio.frames')
    page.wait_for_function('studio.frames > %d' % (n + 3), timeout=90000)
    return png_pixels(data_url(page, 'studio.renderer.domElement'))


def green(img, cx, cy, r=40):
    patch = img[max(0, cy - r):cy + r, max(0, cx - r):cx + r].reshape(-1, 3)
    return int(((patch[:, 1] > 120) & (patch[:, 1] > patch[:, 2] + 90) &
                (patch[:, 1] > patch[:, 0] + 20)).sum())


def test_a_spawned_mesh_model_is_described_drawn_and_removed(shared_studio, shared_page):
    page = shared_page
    # from inside the room, as test_studio looks at the pyramid
    page.evaluate("studio.setView('free'); studio.live = true; "
                  "studio.orbit.target.set(%f, %f, %f); "
                  "studio.camera.position.set(%f, %f, %f); studio.orbit.update()"
                  % (AT + (AT[0] - 1.2, AT[1] + 0.5, AT[2] + 0.6)))
    rect = page.evaluate('(() => { const r = studio.renderer.domElement.'
                         'getBoundingClientRect(); return [r.left, r.top]; })()')
    spawner = Spawner(shared_studio, SDF % (shared_studio['dir'] / 'pyramid.stl'))
    try:
        # the studio asked the world for its description: a shape (the served mesh), its colour
        m = _until(lambda: (lambda m: m if m and m['links'] else None)(
            scene_model(shared_studio)), what='its description in /api/scene')
        (v,) = m['links'][0]['visuals']
        assert v['geometry']['kind'] == 'shape' and v['geometry']['source'] == 'mesh', v
        assert v['rgba'] == pytest.approx([0.55, 0.95, 0.05, 1])
        # the page draws it from that description (not the magenta box) once its mesh came
        page.wait_for_function(
            "studio.models['%s'] && !studio.models['%s'].children.some((c) => c.isMesh) "
            "&& studio.shapes.some((s) => s.mesh && s.box.parent && "
            "studio.models['%s'].getObjectById(s.box.parent.id))" % (NAME, NAME, NAME),
            timeout=90000)
        p = page.evaluate("studio.screenPoint('%s')" % NAME)
        cx, cy = int(p['x'] - rect[0]), int(p['y'] - rect[1]) - 25
        after = shot(page)
        assert green(after, cx, cy) > 300, green(after, cx, cy)
        # its NFC tag's icon, where the model is now; the page has the icon on the model
        code, rep = post(shared_studio, json.dumps({'v': 1, 'op': 'world_info'}))
        tag = next(ic for ic in rep['icons'] if ic['model'] == NAME)
        assert tag['kind'] == 'nfc' and tag['data'] == 'T:late'
        assert tag['position'] == pytest.approx(AT, abs=1e-3)
        icon = "studio.moves.icons['nfc:%s']" % NAME       # a tag's id: its model's name
        page.wait_for_function("%s && %s.parent === studio.models['%s']" % (icon, icon, NAME),
                               timeout=90000)
        code, rep = post(shared_studio, json.dumps({
            'v': 1, 'op': 'set_pose', 'model': NAME, 'position': [AT[0], AT[1] + 0.5, 0]}))
        assert code == 200, rep
        tag = _until(lambda: (lambda t: t if abs(t['position'][1] - AT[1] - 0.5) < 1e-3
                              else None)(next(ic for ic in post(shared_studio, json.dumps(
                                  {'v': 1, 'op': 'world_info'}))[1]['icons']
                                  if ic['model'] == NAME)), what='the icon moved')
        assert tag['position'][0] == pytest.approx(AT[0], abs=1e-3)
    finally:
        spawner.delete()
    _until(lambda: NAME not in scene_names(shared_studio['url']), what='gone from the scene')
    page.wait_for_function("!studio.models['%s'] && !%s" % (NAME, icon), timeout=90000)
    gone = shot(page)                  # the same view without it: none of its green
    assert green(gone, cx, cy) < 20, green(gone, cx, cy)
    assert page.errors == [] and page.outside == []
    assert 'cannot be described' not in open(shared_studio['log']).read()
