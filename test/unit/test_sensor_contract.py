"""The sensor contract (issue 17), over every registered plugin:

* no sensor or actuator overrides ``update`` (the base owns it);
* every fault kind is either applied to every output the plugin publishes -- ``drop``: none
  publishes; ``freeze``: each sampled output repeats the message it had when the fault came,
  event outputs stop; ``noise`` x10: every output carrying a noisy value publishes other data
  than without it; a sensor's own fault (the GPS's ``no_fix``): every output changes -- or
  refused with a ValueError naming the plugin and the reason;
* every sensor and actuator loads in both URDF syntaxes (Gazebo classic ``<plugin>`` and the
  thesis's 2011 ``<controller:...>``), in the robot namespace given, and a bad parameter is
  one error line naming the plugin, the model and the parameter, while the plugin loads;
* each sensor's own bad parameters (``BAD``): one such line each, and the plugin works on
  the default, or does not load where it cannot work without the parameter (the sensor's
  own test file keeps what is particular to the sensor).

The fault runs: the office world and the phone just outside the office door (outdoors: a
GPS fix, the heart-rate belt in range), seeded; at T_FAULT every sensor gets the fault; a
touch, a button press, a thermal command follow, and at T_NFC the phone is held to the NFC
poster. Each run is compared with the same run without the fault.
"""
import logging
import os

import numpy as np
import pytest

from sim_world import plugins as registry
from sim_world.plugins.device import Actuator, Device
from sim_world.plugins.device import content as _content
from sim_world.plugins.sensor import FAULTS, Sensor, inject_fault
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file
from sim_world.world import World

from simsensors.touch import DOWN, UP

import worlds

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')
T_FAULT, T_NFC, T_END = 0.6, 1.695, 2.2     # T_NFC: 5 ms before an NFC tick
#: an articulated model beside the office (issue 48): a pendulum welded to the world, let go
#: at 0.5 rad, with the joint plugins (joint states at 50 Hz, ros_control's transmission)
PENDULUM = '''<robot name="pendulum"><link name="world"/>
<joint name="fix" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 2"/></joint>
<link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
<joint name="hinge" type="continuous"><parent link="base"/><child link="rod"/><axis xyz="0 1 0"/></joint>
<link name="rod"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
<inertia ixx="0.001" iyy="0.001" izz="0.001"/></inertial>
<collision><origin xyz="0 0 -0.5"/><geometry><sphere radius="0.05"/></geometry></collision></link>
<transmission name="t"><type>transmission_interface/SimpleTransmission</type>
<joint name="hinge"><hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface></joint>
<actuator name="m"><mechanicalReduction>1</mechanicalReduction></actuator></transmission>
<gazebo><plugin name="jsp" filename="libgazebo_ros_joint_state_publisher.so">
<jointName>hinge</jointName><updateRate>50</updateRate></plugin>
<plugin name="control" filename="libgazebo_ros_control.so"/></gazebo></robot>'''


def _add_pendulum(w):
    from sim_world.urdf import parse_urdf
    w.add_model(parse_urdf(PENDULUM), pose=Pose((12.0, 12.0, 0.0)))
    w.physics.set_joint_positions('pendulum', {'hinge': 0.5})
NOISE = 10.0

#: every plugin of the repository's plugin modules (not test doubles registered by tests)
CLASSES = sorted(set(c for c in (registry.lookup(n) for n in registry.registered_names())
                     if c.__module__ in registry.plugin_modules()), key=lambda c: c.__name__)
DEVICES = [c for c in CLASSES if issubclass(c, Device)]
OWN = sorted(set((c.__name__, f) for c in CLASSES if issubclass(c, Sensor)
                 for f in c.FAULTS_OWN))


def content(msg):
    """What a message says, header aside, comparable (NaN equals NaN)."""
    return repr(_content(msg))


def _run(fault=None, value=0.0):
    """{(class, output key): [(sim time, content)] after T_FAULT}, {class: refusal text},
    {(class, output key): contents of its last tick's messages before T_FAULT},
    {class: outputs}."""
    w = World(physics='ode', seed=11)
    w.load_world_file(OFFICE)
    w.add_model(load_urdf_file(PHONE), pose=Pose((6.8, -3.0, 1.0)))
    _add_pendulum(w)
    for name, ps in w.plugins.items():        # video textures: not stepped here
        for p in ps:
            if not isinstance(p, Device):
                p.shutdown()
        w.plugins[name] = [p for p in ps if isinstance(p, Device)]
    every = [p for ps in w.plugins.values() for p in ps]
    for p in every:
        p.force = True
    by = dict((type(p).__name__, p) for p in every if p.model.name == 'mobile_device')
    try:
        w.step(int(round(T_FAULT / w.step_size)))
        before = dict(((type(p).__name__, o.key), [content(m) for m in o.batch])
                      for p in every for o in p.pubs if o.batch)
        counts = dict((id(o), o.count) for p in every for o in p.pubs)
        last = dict((id(o), o.last) for p in every for o in p.pubs)
        refused = {}
        if fault is not None:
            for p in every:
                if not isinstance(p, Sensor) or (fault not in FAULTS and
                                                  fault not in p.FAULTS_OWN):
                    continue
                try:
                    p.set_fault(fault, value)
                except ValueError as e:
                    refused[type(p).__name__] = str(e)
        seen = {}
        for p in every:
            for o in p.pubs:
                orig = o.publish

                def rec(msg, o=o, orig=orig, p=p):
                    # the tick a message belongs to: its stamp (a camera's frame is
                    # published by the renderer's thread, while the world steps on)
                    st = getattr(getattr(msg, 'header', None), 'stamp', None)
                    seen.setdefault((type(p).__name__, o.key), []).append(
                        (w.sim_time if st is None else round(st.to_sec(), 6), content(msg)))
                    orig(msg)
                o.publish = rec
        by['TouchScreen'].inject_touch(100, 200, 0.05)
        by['TouchScreen'].press_button('power', 0.03)
        by['ThermalDisplay'].command(40.0)
        w.step(int(round((T_NFC - T_FAULT) / w.step_size)))
        w.set_state('mobile_device', Pose((2.2, 0.97, 1.3), (-0.7071, 0, 0, 0.7071)))
        w.step(int(round((T_END - T_NFC) / w.step_size)))
        for p in every:                        # outputs declared after T_FAULT (devices)
            for o in p.pubs:
                if id(o) not in counts:
                    counts[id(o)] = 0
        outputs = dict((type(p).__name__, p.outputs) for p in every
                       if p.model.name == 'mobile_device' or type(p).__name__ not in by)
        return seen, refused, before, outputs
    finally:
        w.shutdown()


_RUNS = {}


def run(fault=None, value=0.0):
    key = (fault, value)
    if key not in _RUNS:
        _RUNS[key] = _run(fault, value)
    return _RUNS[key]


def _instances():
    """{class name: [output keys]} of the plugins in the fault runs (the phone, the office)."""
    w = World(physics='ode', seed=11)
    try:
        w.load_world_file(OFFICE)
        w.add_model(load_urdf_file(PHONE), pose=Pose((6.8, -3.0, 1.0)))
        _add_pendulum(w)
        out = {}
        for ps in w.plugins.values():
            for p in ps:
                out.setdefault(type(p).__name__, p)
        return dict((n, (type(p), getattr(p, 'outputs', {}), p)) for n, p in out.items())
    finally:
        w.shutdown()


INSTANCES = _instances()


def _outputs_of(name, seen):
    return dict((k, v) for (c, k), v in seen.items() if c == name)


# -- structure ----------------------------------------------------------------------------------
@pytest.mark.parametrize('cls', DEVICES, ids=lambda c: c.__name__)
def test_no_plugin_overrides_update(cls):
    base = Sensor if issubclass(cls, Sensor) else Actuator
    assert issubclass(cls, (Sensor, Actuator))
    for k in cls.__mro__[:cls.__mro__.index(base)]:
        assert 'update' not in vars(k), '%s overrides update()' % k.__name__


@pytest.mark.parametrize('cls', CLASSES, ids=lambda c: c.__name__)
def test_every_registered_plugin_is_in_the_fault_runs(cls):
    """A new plugin joins the fault contract by being in the phone, the office world or the
    pendulum beside it."""
    assert cls.__name__ in INSTANCES


# -- faults -------------------------------------------------------------------------------------
PAIRS = [(c.__name__, f) for c in CLASSES for f in ('drop', 'freeze', 'noise')]


def _accepted_or_refused(name, fault, refused):
    """True when the fault was applied; a refusal must say which plugin and why."""
    cls, _, plugin = INSTANCES[name]
    if not issubclass(cls, Sensor):
        # not on the sensor layer: the fault service refuses it
        with pytest.raises(ValueError) as e:
            inject_fault([plugin], fault, NOISE)
        assert name in str(e.value) and 'not a sensor' in str(e.value)
        return False
    if name in refused:
        text = refused[name]
        assert name in text and ('no noise' in text or 'publishes no topic' in text), text
        return False
    return True


@pytest.mark.parametrize('name, fault', PAIRS)
def test_fault_applied_to_every_output_or_refused(name, fault):
    base, _, before, outs = run()
    got, refused, _, _ = run(fault, NOISE if fault == 'noise' else 0.0)
    if not _accepted_or_refused(name, fault, refused):
        return
    outputs = outs[name]
    assert outputs, '%s has no outputs but took fault %s' % (name, fault)
    b, g = _outputs_of(name, base), _outputs_of(name, got)
    assert b, 'the fault runs do not exercise %s: nothing published after the fault time' % name
    for key, seq in b.items():
        out = outputs.get(key)
        after = g.get(key, [])
        if fault == 'drop':
            assert after == [], '%s %s published under drop' % (name, key)
        elif fault == 'freeze':
            if out is not None and out.event:
                assert after == [], '%s %s: events under freeze' % (name, key)
            else:
                assert after, '%s %s stopped under freeze' % (name, key)
                ticks = {}
                for t, c in after:
                    ticks.setdefault(t, []).append(c)
                held = before.get((name, key)) or ticks[min(ticks)]
                assert all(cs == held for cs in ticks.values()), \
                    '%s %s moved under freeze' % (name, key)
        else:
            if out is not None and not out.noisy:
                continue
            assert [c for _, c in after] != [c for _, c in seq], \
                '%s %s: noise x%g changed nothing' % (name, key, NOISE)


@pytest.mark.parametrize('name, fault', OWN)
def test_own_fault_changes_every_output(name, fault):
    base = run()[0]
    got, refused = run(fault)[:2]
    assert name not in refused
    b, g = _outputs_of(name, base), _outputs_of(name, got)
    assert b
    for key, seq in b.items():
        assert [c for _, c in g.get(key, [])] != [c for _, c in seq], \
            '%s %s: fault %s changed nothing' % (name, key, fault)


def test_a_name_matching_a_sensor_and_an_output_device_faults_the_sensor():
    """``temperature`` names the ambient sensor's topic and the thermal display's command
    topic (.../thermal_display/temperature): the fault goes to the sensor."""
    w = World(physics='ode', seed=1)
    try:
        w.add_model(load_urdf_file(PHONE), pose=Pose((0, 0, 1)))
        found = w.find_plugins('mobile_device', 'temperature')
        assert sorted(type(p).__name__ for p in found) == ['Ambient', 'ThermalDisplay']
        inject_fault(found, 'drop')
        assert [p.fault for p in found if isinstance(p, Sensor)] == ['drop']
        led = w.find_plugins('mobile_device', 'led')
        with pytest.raises(ValueError) as e:
            inject_fault(led, 'drop')
        assert 'Led' in str(e.value) and 'not a sensor' in str(e.value)
    finally:
        w.shutdown()


def test_unknown_fault_is_refused_with_the_known_ones():
    cls = INSTANCES['ImuPlugin'][0]
    w = World(physics='ode', seed=1)
    try:
        w.add_model(load_urdf_file(PHONE), pose=Pose((0, 0, 1)))
        imu = next(p for p in w.plugins['mobile_device'] if isinstance(p, cls))
        with pytest.raises(ValueError) as e:
            inject_fault([imu], 'smoke')
        assert "'smoke'" in str(e.value) and 'drop, freeze, noise' in str(e.value)
        with pytest.raises(ValueError):
            inject_fault([imu], 'noise', -1)
        assert imu.fault == 'none'
    finally:
        w.shutdown()


# -- both syntaxes, one line per bad parameter ---------------------------------------------------
@pytest.mark.parametrize('syntax', ['2011', 'classic'])
@pytest.mark.parametrize('cls', DEVICES, ids=lambda c: c.__name__)
def test_loads_in_both_syntaxes_and_a_bad_parameter_is_one_line(cls, syntax, caplog):
    lib = cls.names[0]
    with worlds.opened('ode', seed=1) as w:
        with caplog.at_level(logging.ERROR):
            w.add_model(worlds.one_link(worlds.plugin_xml(
                lib, '<updateRate>7</updateRate><updateOffset>-1</updateOffset>'
                '<robotNamespace>/phone</robotNamespace><data>U:http://x</data>', syntax),
                box=(0.1, 0.06, 0.01), visual=True), pose=Pose((0, 0, 1)))
        lines = worlds.error_lines(caplog)
        assert len(lines) == 1, lines
        assert "updateOffset must be a number >= 0, got '-1'" in lines[0]
        assert lib in lines[0] and 'model r' in lines[0]
        (p,) = w.plugins['r']
        assert isinstance(p, cls) and p.p.updateRate == 7.0 and p.timer.offset == 0.0
        for o in p.pubs:
            assert o.topic.startswith('/phone/')
        w.step(200)                            # and it runs


class Bad(object):
    """A plugin's own bad parameters, ``cases`` [(parameters, words of the error line[,
    False: the plugin cannot work without it and does not load])], on a one-link model
    (``robot``: sensor_robot's keywords) at ``at`` in a world (``world``: make_world's
    keywords) on each of ``engines``; after ``poke(plugin)`` and ``steps`` steps,
    ``runs(plugin)`` says it works on the parameter's default (None: not run)."""

    def __init__(self, lib, cases, steps=0, runs=None, poke=None, at=(0, 0, 1),
                 engines=('ode',), world=None, **robot):
        self.lib, self.cases, self.steps, self.runs, self.poke = lib, cases, steps, runs, poke
        self.at, self.engines, self.world, self.robot = at, engines, world or {}, robot

    def params(self):
        for case in self.cases:
            params, words, loads = (case + (True,))[:3]
            for engine in self.engines:
                tag, value = params[1:].split('<')[0].split('>')
                yield pytest.param(self, params, words, loads, engine, id='%s-%s=%s-%s' % (
                    self.lib[3:-3], tag, value, engine))


OFFICE_ENV = dict(office='environment', seed=2)
BAD = [
    Bad('libgazebo_ros_ambient.so', [
        ('<temperatureGaussianNoise>-1</temperatureGaussianNoise>',
         'temperatureGaussianNoise must be'),
        ('<onChangeOnly>maybe</onChangeOnly>', 'onChangeOnly must be'),
    ], 1500, lambda p: abs(p.last_value[0] - 21) < 1, at=(3, -2, 1), world=OFFICE_ENV),
    Bad('libhector_gazebo_ros_magnetic.so', [
        ('<magnitude>1.0</magnitude>', 'magnitude must be'),
        ('<inclination>120</inclination>', 'inclination must be'),
        ('<updateRate>-5</updateRate>', 'updateRate must be'),
        ('<gaussianNoise>loud</gaussianNoise>', 'gaussianNoise must be'),
    ], 100, lambda p: np.linalg.norm(p.last_value) > 40e-6, world=OFFICE_ENV),
    Bad('libgazebo_ros_air_pressure.so', [
        ('<noiseModel>pink</noiseModel>', 'noiseModel must be'),
        ('<stepMaximum>-1</stepMaximum>', 'stepMaximum must be'),
    ], 300, lambda p: 95000 < p.last_value < 95400, world=OFFICE_ENV),
    Bad('libgazebo_ros_gps.so', [
        ('<LatLon>95 11</LatLon>',
         'LatLon must be two numbers "latitude longitude" in degrees, latitude in [-90, 90]'),
        ('<referenceLatitude>-91</referenceLatitude>', 'referenceLatitude must be'),
        ('<coldStartTime>soon</coldStartTime>', 'coldStartTime must be'),
    ], 2000, lambda p: p.last_value[1] and p.timer.rate == 1.0,        # a fix outdoors
        at=(20, 20, 1), world=dict(office='environment', seed=3)),
    Bad('libgazebo_ros_device_clock.so', [
        ('<driftPpm>fast</driftPpm>', 'driftPpm must be'),
        ('<offset>-3</offset>', 'offset must be'),
    ], 3000, lambda p: p.last_value == pytest.approx(3.0)),
    Bad('libgazebo_ros_proximity.so', [
        ('<maxRange>-1</maxRange>', 'maxRange must be a number > 0'),
        ('<mode>sonar</mode>', 'mode must be one of binary, distance'),
        ('<minRange>0.1</minRange>', 'minRange must be below maxRange'),
        ('<direction>0 0 0</direction>', 'direction must be a non-zero vector'),
    ], 200, lambda p: p.last_value == 0.05, body=None),
    Bad('libgazebo_ros_power_monitor.so', [
        ('<fullChargeCapacity>-1</fullChargeCapacity>', 'fullChargeCapacity must be a number > 0'),
        ('<powerStateRate>abc</powerStateRate>', 'powerStateRate must be a number'),
        ('<initialCharge>1.5</initialCharge>', 'initialCharge'),
        ('<displayPower>-0.2</displayPower>', 'displayPower'),
    ], 150, lambda p: p.model_b.charge > 0, engines=worlds.ENGINES,
        world=dict(step_size=0.01, seed=5), body=None, mass=0.129, box=(0.12, 0.06, 0.01)),
    Bad('libgazebo_ros_light_sensor.so', [
        ('<candelaPerUnit>-5</candelaPerUnit>', 'candelaPerUnit must be a number >= 0'),
        ('<skyFraction>2</skyFraction>', 'skyFraction'),
        ('<updateRate>fast</updateRate>', 'updateRate must be a number'),
    ], 500, lambda p: p.last_value[0] > 100, at=(3.32, -2.10, 1.0),   # over the office desk
        world=dict(office='world'), body=None),
    Bad('libgazebo_ros_touch.so', [
        ('<pressureStages>0</pressureStages>', 'pressureStages must be'),
        ('<pressureDepth>-1</pressureDepth>', 'pressureDepth must be a number > 0'),
        ('<buttons>power</buttons>', 'buttons must be name:link pairs'),
        ('<buttons>power:ghost</buttons>', "'ghost' is not a link"),
        ('<face>side</face>', 'face must be one of front, back'),
    ], 30, lambda p: [e[1] for e in p.events] == [DOWN, UP],
        poke=lambda p: p.inject_touch(10, 10, 0.01), link='screen', box=(0.1, 0.05, 0.001),
        visual=True),
    Bad('libgazebo_ros_imu.so', [
        ('<bodyName>ghost</bodyName>', 'ghost', False),
        ('<updateRate>-3</updateRate>', 'updateRate must be a number >= 0'),
        ('<rpyOffsets>1 2</rpyOffsets>', 'rpyOffsets must be three numbers'),
        ('<xyzOffsets>0 0 0.1</xyzOffsets>', 'xyzOffsets must be three numbers zero'),
        ('<accelGaussianNoise>-1</accelGaussianNoise>', 'accelGaussianNoise'),
    ], engines=worlds.ENGINES, world=dict(seed=None), mass=0.129, box=(0.12, 0.06, 0.01)),
]


@pytest.mark.parametrize('bad, params, words, loads, engine',
                         [p for b in BAD for p in b.params()])
def test_a_bad_parameter_is_one_line_and_the_plugin_runs_on_the_default(
        bad, params, words, loads, engine, caplog):
    with worlds.opened(engine, **bad.world) as w:
        caplog.clear()                         # what loading the world said
        with caplog.at_level(logging.ERROR):
            w.add_model(worlds.sensor_robot(bad.lib, params, **bad.robot), pose=Pose(bad.at))
        lines = worlds.error_lines(caplog)
        assert len(lines) == 1, lines
        assert words in lines[0] and bad.lib in lines[0] and 'model r' in lines[0]
        assert 'r' in w.models and len(w.plugins['r']) == int(loads)
        if not loads or bad.runs is None:
            return
        (p,) = w.plugins['r']
        if bad.poke:
            bad.poke(p)
        w.step(bad.steps)
        assert bad.runs(p)
