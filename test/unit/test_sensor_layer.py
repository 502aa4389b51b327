"""The shared sensor layer (issue 9): declared parameters, the update timer, the error model,
the world's seeded generators, and a contract every registered plugin keeps."""
import logging
import math
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from sim_world import plugins
from sim_world.model import PluginSpec
from sim_world.plugins.error_models import ErrorModel, error_model_from, error_params
from sim_world.plugins.params import Param, parse_params
from sim_world.plugins.timer import UpdateTimer
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')


def spec_of(xml, sensor_xml=None):
    el = ET.fromstring(xml)
    sensor = ET.fromstring(sensor_xml) if sensor_xml else None
    return PluginSpec('libtest.so', 'p', el, sensor, None, None)


# -- parameters ------------------------------------------------------------------------------
ROWS = [
    Param('updateRate', float, 10.0, aliases=('update_rate',), unit='Hz', check='>=0'),
    Param('direction', ('omni', '+x', '-x', '+z', '-z'), 'omni'),
    Param('offsets', 'vec3', (0, 0, 0)),
    Param('count', int, 3, check=(1, 10)),
    Param('enabled', bool, True),
    Param('fov', float, 1.0, paths=[('camera', 'horizontal_fov')]),
]


def test_params_both_spellings_and_sdf_paths():
    v, errors = parse_params(spec_of('<plugin><update_rate>5</update_rate><direction>+z</direction>'
                                     '<offsets>1 2 3</offsets><count>4</count>'
                                     '<enabled>false</enabled></plugin>',
                                     '<sensor><camera><horizontal_fov>0.5</horizontal_fov>'
                                     '</camera></sensor>'), ROWS, 'plugin x of model m')
    assert errors == []
    assert v.updateRate == 5.0 and v.direction == '+z' and v.count == 4 and v.enabled is False
    assert list(v.offsets) == [1, 2, 3] and v.fov == 0.5
    assert v.given == {'updateRate', 'direction', 'offsets', 'count', 'enabled', 'fov'}


def test_params_defaults():
    v, errors = parse_params(spec_of('<plugin/>'), ROWS, 'plugin x of model m')
    assert errors == [] and v.updateRate == 10.0 and v.direction == 'omni' and v.given == set()


@pytest.mark.parametrize('xml, line', [
    ('<updateRate>-1</updateRate>',
     "plugin x of model m: updateRate must be a number >= 0, got '-1'"),
    ('<updateRate>fast</updateRate>', "plugin x of model m: updateRate must be a number >= 0, "
                                      "got 'fast'"),
    ('<direction>up</direction>',
     "plugin x of model m: direction must be one of omni, +x, -x, +z, -z, got 'up'"),
    ('<offsets>1 2</offsets>', "plugin x of model m: offsets must be three numbers, got '1 2'"),
    ('<count>11</count>', "plugin x of model m: count must be a whole number in [1, 10], got '11'"),
    ('<count>2.5</count>', "plugin x of model m: count must be a whole number in [1, 10], "
                           "got '2.5'"),
    ('<enabled>maybe</enabled>', "plugin x of model m: enabled must be true or false, "
                                 "got 'maybe'"),
])
def test_params_bad_value_one_line_and_default(xml, line, caplog):
    log = logging.getLogger('t')
    v, errors = parse_params(spec_of('<plugin>%s</plugin>' % xml), ROWS, 'plugin x of model m',
                             log)
    assert errors == [line]
    assert [r.getMessage() for r in caplog.records] == [line]
    row = next(r for r in ROWS if ('<%s>' % r.name) in xml)
    d = getattr(v, row.name)
    assert np.all(np.asarray(d) == np.asarray(row.default))


# -- timer -------------------------------------------------------------------------------------
def fire_times(timer, t0, t1, dt=0.001):
    n0, n1 = int(round(t0 / dt)), int(round(t1 / dt))
    return [k * dt for k in range(n0 + 1, n1 + 1) if timer.due(k * dt)]


def test_timer_rate_in_sim_time_and_offset():
    t = UpdateTimer(rate=10, offset=0.05)
    assert fire_times(t, 0, 1.0) == pytest.approx([0.05 + 0.1 * k for k in range(10)])
    assert UpdateTimer(period=0.25).rate == 4.0


def test_timer_rate_change_at_once_and_reset():
    t = UpdateTimer(rate=0.5)
    assert fire_times(t, 0, 0.1) == [pytest.approx(0.001)]
    t.set_rate(30, now=0.1)
    assert len(fire_times(t, 0.1, 0.2)) == 4      # not only after t = 2 s
    t.reset(now=0.5)
    assert fire_times(t, 0.5, 0.6)[0] == pytest.approx(0.501)
    with pytest.raises(ValueError):
        t.set_rate(-1, now=0.6)
    t0 = UpdateTimer(rate=0)
    assert len(fire_times(t0, 0, 0.01)) == 10      # every step


# -- error model -------------------------------------------------------------------------------
def test_error_model_identity_with_zero_parameters():
    m = ErrorModel(dims=3, rng=np.random.default_rng(1))
    x = np.array([1.0, -2.0, 3.0])
    for _ in range(10):
        assert np.array_equal(m(x, 0.01), x)
    assert m.variance.tolist() == [0, 0, 0]


def test_error_model_noise_offset_scale_statistics():
    m = ErrorModel(dims=2, gaussian_noise=[0.1, 0.5], offset=1.0, scale_error=1.1,
                   rng=np.random.default_rng(2))
    ys = np.array([m(np.array([2.0, 2.0]), 0.01) for _ in range(20000)])
    assert ys.mean(axis=0) == pytest.approx([3.2, 3.2], abs=0.02)
    assert ys.std(axis=0) == pytest.approx([0.1, 0.5], rel=0.03)
    assert m.variance == pytest.approx([0.01, 0.25])


def test_error_model_quantisation():
    m = ErrorModel(quantization=0.25, rng=np.random.default_rng(3))
    assert m(1.1, 0.01) == 1.0 and m(1.2, 0.01) == 1.25


def test_gauss_markov_drift_holds_sigma_and_time_constant_for_any_step():
    """Drift sigma 0.2 with correlation time 2 s: stationary sigma 0.2 and autocorrelation
    exp(-lag/2), the same whether it is stepped at 100 Hz or at 7 Hz."""
    for dt in (0.01, 1.0 / 7):
        m = ErrorModel(drift=0.2, drift_frequency=0.5, rng=np.random.default_rng(4))
        n = 60000
        xs = np.array([m(0.0, dt) for _ in range(n)])
        assert xs.std() == pytest.approx(0.2, rel=0.1)
        lag = int(round(2.0 / dt))
        r = np.corrcoef(xs[:-lag], xs[lag:])[0, 1]
        assert r == pytest.approx(math.exp(-1), abs=0.08)


def test_reset_redraws_bias():
    m = ErrorModel(bias_mean=0.5, bias_stddev=0.1, rng=np.random.default_rng(5))
    biases = set()
    for _ in range(20):
        m.reset()
        biases.add(round(float(m.bias[0]), 9))
        assert 0.1 < abs(m.bias[0]) < 1.0
    assert len(biases) == 20
    assert {b > 0 for b in biases} == {True, False}      # random sign, as Gazebo does


def test_hector_prefixed_and_sdf_noise_names():
    rows = error_params('accel', 3)
    names = {r.name for r in rows}
    assert {'accelOffset', 'accelDrift', 'accelDriftFrequency', 'accelGaussianNoise',
            'accelScaleError'} <= names
    spec = spec_of('<plugin><accelGaussianNoise>0.1 0.2 0.3</accelGaussianNoise>'
                   '<accelDrift>0.5</accelDrift></plugin>')
    v, errors = parse_params(spec, rows, 'plugin x of model m')
    assert errors == []
    m = error_model_from(v, 'accel', 3, rng=np.random.default_rng(0))
    assert list(m.gaussian_noise) == [0.1, 0.2, 0.3]
    assert list(m.drift_frequency) == pytest.approx([1 / 3600.0] * 3)   # hector's default
    sdf = spec_of('<plugin/>', '<sensor><noise type="gaussian_quantized"><mean>0.1</mean>'
                  '<stddev>0.2</stddev><bias_mean>0.3</bias_mean><bias_stddev>0.01</bias_stddev>'
                  '<dynamic_bias_stddev>0.05</dynamic_bias_stddev>'
                  '<dynamic_bias_correlation_time>10</dynamic_bias_correlation_time>'
                  '<precision>0.5</precision></noise></sensor>')
    rows = error_params('', 1)
    v, _ = parse_params(sdf, rows, 'plugin x of model m')
    m = error_model_from(v, '', 1, rng=np.random.default_rng(0), spec=sdf, sdf_paths=[('noise',)])
    assert (m.offset[0], m.gaussian_noise[0], m.bias_mean[0], m.bias_stddev[0], m.drift[0],
            m.drift_frequency[0], m.quantization[0]) == pytest.approx(
        (0.1, 0.2, 0.3, 0.01, 0.05, 0.1, 0.5))


@pytest.mark.parametrize('noise, line', [
    ('<stddev>abc</stddev>', "<stddev> must be a number >= 0, got 'abc'"),
    ('<stddev>-1</stddev>', "<stddev> must be a number >= 0, got '-1'"),
    ('<mean>nan</mean>', "<mean> must be a number, got 'nan'"),
])
def test_bad_sdf_noise_is_one_clear_line(noise, line):
    from sim_world.plugins.error_models import _sdf_noise
    from sim_world.plugins.params import ParamError
    with pytest.raises(ParamError) as e:
        _sdf_noise(ET.fromstring('<noise type="gaussian">%s</noise>' % noise), 1)
    assert str(e.value) == line


def test_sdf_1_4_noise_with_a_type_element():
    """Gazebo's camera and ray <noise> give the type as a child element (SDF 1.4+)."""
    from sim_world.plugins.error_models import _sdf_noise
    from sim_world.plugins.params import ParamError
    kw = _sdf_noise(ET.fromstring('<noise><type>gaussian</type><mean>0.1</mean>'
                                  '<stddev>0.007</stddev></noise>'), 1)
    assert kw['offset'] == 0.1 and kw['gaussian_noise'] == 0.007
    assert _sdf_noise(ET.fromstring('<noise><type>none</type><stddev>1</stddev></noise>'), 1) \
        == {}
    with pytest.raises(ParamError) as e:
        _sdf_noise(ET.fromstring('<noise><type>pink</type></noise>'), 1)
    assert "got 'pink'" in str(e.value)


def test_field_noise_identity_keeps_the_array_and_draws_per_pixel():
    from sim_world.plugins.error_models import FieldNoise
    img = np.full((40, 30, 3), 100, np.uint8)
    assert FieldNoise(ErrorModel()).apply_uint8(img) is img
    m = ErrorModel(gaussian_noise=0.05, offset=0.1)
    a, b = FieldNoise(m, seed=3).apply_uint8(img), FieldNoise(m, seed=3).apply_uint8(img)
    assert np.array_equal(a, b) and not np.array_equal(a, FieldNoise(m, 4).apply_uint8(img))
    d = a.astype(float) / 255 - 100 / 255.0
    assert abs(d.mean() - 0.1) < 0.01 and abs(d.std() - 0.05) < 0.01
    m.noise_scale = 0.0                                   # a 'noise' fault of 0: the offset
    assert np.all(FieldNoise(m, 3).apply_uint8(img) == 126)


SLOW = """<robot name="r"><link name="base">
  <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
  <gazebo reference="base"><turnGravityOff>true</turnGravityOff>
    <sensor type="imu" name="s">%s
      <plugin name="p" filename="libgazebo_ros_imu.so"><bodyName>base</bodyName>%s</plugin>
    </sensor></gazebo></robot>"""


@pytest.mark.parametrize('sensor, plugin, hz', [
    ('<update_rate>30</update_rate>', '<updateRate>100</updateRate>', 30.0),
    ('<update_rate>100</update_rate>', '<updateRate>30</updateRate>', 30.0),
    ('<update_rate>30</update_rate>', '<updateRate>0</updateRate>', 30.0),
    ('<update_rate>0</update_rate>', '<updateRate>0</updateRate>', 0.0),
    ('', '<updateRate>7</updateRate>', 7.0),
    ('<update_rate>-3</update_rate>', '<updateRate>20</updateRate>', 20.0),
    ('<update_rate>30</update_rate>', '<updatePeriod>0.5</updatePeriod>', 2.0),
])
def test_a_plugin_in_a_sensor_runs_at_the_slowest_rate_given(sensor, plugin, hz, caplog):
    """Gazebo's sensor plugins: the sensor updates at its rate, the plugin publishes at most
    at its own; the base's timer takes the slowest positive one (each bad one: a line)."""
    w = World(seed=1)
    try:
        with caplog.at_level(logging.ERROR):
            w.add_model(parse_urdf(SLOW % (sensor, plugin)), pose=Pose((0, 0, 1)))
        (p,) = w.plugins['r']
        assert p.timer.rate == hz
        bad = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
        assert len(bad) == ('-3' in sensor)
        if bad:
            assert "updateRate must be a number >= 0, got '-3'" in bad[0]
    finally:
        w.shutdown()


# -- seeds --------------------------------------------------------------------------------------
def test_world_generators_depend_on_seed_and_names_only():
    a, b, c = World(seed=7), World(seed=7), World(seed=8)
    try:
        x = a.rng('phone', 'imu').standard_normal(5)
        assert np.array_equal(x, b.rng('phone', 'imu').standard_normal(5))
        assert not np.array_equal(x, c.rng('phone', 'imu').standard_normal(5))
        assert not np.array_equal(x, a.rng('phone', 'gps').standard_normal(5))
    finally:
        for w in (a, b, c):
            w.shutdown()


def test_no_seed_is_random_and_logged(caplog):
    caplog.set_level(logging.INFO)
    w1, w2 = World(), World()
    assert w1.seed != w2.seed
    assert any('world seed %d' % w1.seed in r.getMessage() for r in caplog.records)
    with pytest.raises(ValueError):
        World(seed=-1)


def _phone_world(seed, physics='ode', extra_models=()):
    w = World(physics=physics, seed=seed)
    w.load_world_file(os.path.join(ROOT, 'sim_world', 'worlds', 'office.world'))
    w.add_model(load_urdf_file(PHONE, name='mobile_device'), pose=Pose((3.288, -2.11, 1.0)))
    return w


def _imu_stream(seed, physics='ode', steps=1000, subscribe_others=False):
    w = _phone_world(seed, physics)
    try:
        imu = [p for p in w.plugins['mobile_device']
               if p.spec.filename == 'libgazebo_ros_imu.so'][0]
        out = []
        orig = imu.to_msg

        def keep(value, stamp):
            m = orig(value, stamp)
            out.append(m)
            return m
        imu.to_msg = keep
        w.step(steps)
        return [(m.header.stamp.to_nsec(), m.linear_acceleration.x, m.linear_acceleration.z,
                 m.angular_velocity.y) for m in out]
    finally:
        w.shutdown()


@pytest.mark.parametrize('physics', ['ode', 'bullet'])
def test_same_seed_same_imu_messages(physics):
    a = _imu_stream(11, physics)
    b = _imu_stream(11, physics)
    c = _imu_stream(12, physics)
    assert len(a) == 101 and a == b       # t = 0.001, 0.01, ..., 1.0
    assert a != c


# -- the device frame --------------------------------------------------------------------------
@pytest.mark.parametrize('rpy, axis', [
    ((0, 0, 0), 2),                      # face up: +z
    ((0, -math.pi / 2, 0), 1),           # upright, top (+x of the body) up: +y
    ((-math.pi / 2, 0, 0), 0),           # on its long side, -y of the body (Android +x) up
    ((0, 0, 1.0), 2),                    # yaw does not matter
])
def test_android_device_frame_gravity(rpy, axis):
    w = World(seed=1)
    try:
        urdf = open(PHONE).read()
        from sim_world.urdf import process_xacro
        m = parse_urdf(process_xacro(PHONE), name='phone')
        for p in m.plugins:
            if p.filename == 'libgazebo_ros_imu.so':
                for tag in ('accelGaussianNoise', 'rateGaussianNoise'):
                    ET.SubElement(p.element, tag).text = '0'
        w.add_model(m, pose=Pose.from_xyz_rpy((0, 0, 1), rpy))
        w.step(50)
        imu = [p for p in w.plugins['phone'] if p.spec.filename == 'libgazebo_ros_imu.so'][0]
        assert imu.frame_id == 'mobile_device_frame'
        force = imu.last[2]
        expect = np.zeros(3)
        expect[axis] = 9.81
        assert force == pytest.approx(expect, abs=1e-6), urdf[:0]
    finally:
        w.shutdown()


# -- the contract of every registered plugin --------------------------------------------------
def _all_plugin_classes():
    names = plugins.registered_names()
    seen = {}
    for n in names:
        cls = plugins.lookup(n)
        seen.setdefault(cls, n)
    return sorted(seen.items(), key=lambda kv: kv[1])


def _robot_with(filename, rate):
    # a link on a hinge too, for the plugins that need a joint (the joint state publisher)
    joint = ('<jointName>j</jointName>'
             if filename == 'libgazebo_ros_joint_state_publisher.so' else '')
    return parse_urdf('''<robot name="r"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial>
      <visual><geometry><box size="0.12 0.06 0.01"/></geometry></visual>
      <collision><geometry><box size="0.12 0.06 0.01"/></geometry></collision></link>
      <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
        <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <link name="arm"><inertial><origin xyz="0.05 0 0"/><mass value="0.01"/>
        <inertia ixx="1e-5" iyy="1e-5" izz="1e-5"/></inertial></link>
      <gazebo reference="base"><turnGravityOff>true</turnGravityOff>
        <sensor type="camera" name="s"><update_rate>%g</update_rate>
          <camera><image><width>8</width><height>8</height></image></camera>
          <plugin name="p" filename="%s"><updateRate>%g</updateRate><bodyName>base</bodyName>
          %s</plugin></sensor></gazebo>
      <gazebo reference="arm"><turnGravityOff>true</turnGravityOff></gazebo></robot>''' % (
        rate, filename, rate, joint))


def test_every_plugin_module_is_found():
    names = plugins.registered_names()
    for expected in ('libgazebo_ros_camera.so', 'libgazebo_ros_imu.so', 'libgazebo_ros_video.so'):
        assert expected in names


@pytest.mark.parametrize('physics', ['ode', 'bullet'])
@pytest.mark.parametrize('cls, filename', _all_plugin_classes(),
                         ids=[n for _, n in _all_plugin_classes()])
def test_plugin_contract(cls, filename, physics):
    """Loads from defaults on the real World; keeps 20 Hz in sim time; a rate change to
    50 Hz applies at once; reset restarts the schedule; shutdown is clean."""
    w = World(physics=physics, seed=3)
    try:
        w.add_model(_robot_with(filename, 20.0), pose=Pose((0, 0, 1)))
        ps = w.plugins['r']
        assert len(ps) == 1 and isinstance(ps[0], cls), 'did not load from defaults'
        p = ps[0]
        calls = []
        orig = p.update

        def count(t):
            calls.append(t)
            return orig(t)
        p.update = count
        w.step(1000)
        if p.update_rate == 0:
            pytest.skip('%s runs on events, not on a rate' % filename)
        assert p.update_rate == 20.0
        assert len(calls) in (20, 21)
        p.set_update_rate_now(50.0)
        n = len(calls)
        w.step(100)
        assert len(calls) - n in (5, 6)
        w.reset(time=True)                 # the schedule restarts at t = 0, at 50 Hz
        n = len(calls)
        w.step(100)
        assert len(calls) - n in (5, 6)
        assert calls[n] == pytest.approx(0.001)
        w.delete_model('r')
        assert 'r' not in w.plugins
    finally:
        w.shutdown()
