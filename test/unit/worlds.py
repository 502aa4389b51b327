"""Worlds the unit tests share (issue 17, "shared test fixtures"), without ROS:

* ``one_link``: a model of one link (gravity off) carrying plugins, and ``plugin_xml``: a
  plugin element in today's syntax (``<plugin filename=>``) or the thesis's 2011 one
  (``<controller:... plugin=>``); ``sensor_robot`` puts the two together; ``finger``: a
  finger tip (a small ball);
* ``make_world`` / ``opened`` / ``world_fixture``: a World on one engine or on each, bare,
  with the office's environment only, or with the whole office world; with the real phone;
* ``needs_raycast``: skips a test while world.raycast is not in the tree;
* ``plugin_of``: the plugin of a class in a model; ``sample``: step and read N times;
  ``error_lines``: the error lines a test's log caught.

Test modules in this folder import it as ``import worlds`` (pytest puts the folder on the path).
"""
import contextlib
import importlib.util
import logging
import os

import pytest

from sim_world.sdf import load_world_file
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')
ENGINES = ['ode', 'bullet']
CONTROLLER = 'http://playerstage.sourceforge.net/gazebo/xmlschema/#controller'

#: the ray caster (sim_world.raycast, world.raycast) is another helper's work; until it is in
#: the tree the tests that need it are skipped, and run as soon as it lands
needs_raycast = pytest.mark.skipif(
    importlib.util.find_spec('sim_world.raycast') is None and not hasattr(World, 'raycast'),
    reason='world.raycast (sim_world.raycast) is not in the tree yet')


def plugin_xml(lib, params='', syntax='classic', name='p'):
    """A plugin element naming the library ``lib``: ``classic`` (Gazebo's ``<plugin>``) or
    ``2011`` (the thesis's ``<controller:gazebo_ros_x plugin="libgazebo_ros_x.so">``)."""
    if syntax == '2011':
        tag = 'controller:' + lib[len('lib'):-len('.so')]
        return '<%s name="%s" plugin="%s">%s</%s>' % (tag, name, lib, params, tag)
    assert syntax == 'classic', syntax
    return '<plugin name="%s" filename="%s">%s</plugin>' % (name, lib, params)


def one_link(plugins='', name='r', link='base', mass=0.1, box=None, visual=False):
    """A model ``name`` of one link ``link`` (mass ``mass``, gravity off) with the plugin
    elements ``plugins``; ``box``: the link's collision box size (and its visual, with
    ``visual``)."""
    geometry = ''
    if box is not None:
        shape = '<geometry><box size="%g %g %g"/></geometry>' % tuple(box)
        geometry = ('<visual>%s</visual>' % shape if visual else '') + \
            '<collision>%s</collision>' % shape
    return parse_urdf('''<robot name="%s" xmlns:controller="%s"><link name="%s">
      <inertial><mass value="%g"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial>%s</link>
      <gazebo reference="%s"><turnGravityOff>true</turnGravityOff></gazebo>
      <gazebo>%s</gazebo></robot>''' % (name, CONTROLLER, link, mass, geometry, link, plugins))


def finger(name='finger', radius=0.005):
    """A finger tip: a ball (link ``tip``, 10 g, gravity off) of ``radius``."""
    return parse_urdf('''<robot name="%s"><link name="tip">
      <inertial><mass value="0.01"/><inertia ixx="1e-7" iyy="1e-7" izz="1e-7"/></inertial>
      <collision><geometry><sphere radius="%g"/></geometry></collision></link>
      <gazebo reference="tip"><turnGravityOff>true</turnGravityOff></gazebo></robot>'''
                      % (name, radius))


def sensor_robot(lib, params='', name='r', syntax='classic', plugin='p', body='', **link):
    """``one_link`` carrying one plugin of library ``lib``; ``body``: its ``<bodyName>``, the
    first parameter (by default the link in the classic syntax unless ``params`` name one,
    none in the 2011 syntax, as in the thesis's files; None: none)."""
    if body == '':
        body = link.get('link', 'base') if syntax == 'classic' and '<bodyName>' not in params \
            else None
    if body is not None:
        params = '<bodyName>%s</bodyName>%s' % (body, params)
    return one_link(plugin_xml(lib, params, syntax, plugin), name, **link)


def make_world(engine='ode', seed=1, office=None, phone=None, static_phone=False, **kw):
    """A World on ``engine``; ``office``: 'environment' takes office.world's environment
    only (Munich, 519 m, the office's volume, no models), 'world' loads all of it;
    ``phone``: the real phone (model mobile_device) at that position."""
    w = World(physics=engine, seed=seed, **kw)
    if office == 'environment':
        w.environment = load_world_file(OFFICE).environment
    elif office == 'world':
        w.load_world_file(OFFICE)
    else:
        assert office is None, office
    if phone is not None:
        m = load_urdf_file(PHONE)
        m.static = static_phone
        w.add_model(m, pose=Pose(tuple(phone)))
    return w


@contextlib.contextmanager
def opened(engine='ode', seed=1, **kw):
    """``make_world`` as a context: the world is shut down after."""
    w = make_world(engine, seed, **kw)
    try:
        yield w
    finally:
        w.shutdown()


def world_fixture(seed=1, **kw):
    """A pytest fixture ``world``: ``make_world`` on each engine, shut down after the test."""
    @pytest.fixture(params=ENGINES)
    def world(request):
        with opened(request.param, seed, **kw) as w:
            yield w
    return world


def plugin_of(world, cls, model='r'):
    """The (first) plugin of class ``cls`` in ``model``."""
    return [p for p in world.plugins[model] if isinstance(p, cls)][0]


def sample(world, steps, n, read):
    """Step ``steps`` ``n`` times; ``read()`` after each: the list of what it gave."""
    out = []
    for _ in range(n):
        world.step(steps)
        out.append(read())
    return out


def error_lines(caplog):
    """The text of every ERROR record the test's log caught."""
    return [r.getMessage() for r in caplog.records if r.levelno == logging.ERROR]
