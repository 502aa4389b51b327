"""sim_world.srvcheck: the shared checks of service request values and the handler wrapper
that answers a refusal (or a bug) with success: false and one log line (issue 45 part 5;
the same requests through ROS: test/test_service_bad_input.py)."""
import io
import math

import pytest
from geometry_msgs.msg import Pose as PoseMsg
from geometry_msgs.msg import Twist
from std_srvs.srv import EmptyResponse

from mobile_device_sim.srv import (SetSensorFaultResponse, SpawnModelResponse,
                                   StepWorldResponse)
from sim_world import srvcheck
from sim_world.srvcheck import BadRequest

NAN, INF = float('nan'), float('inf')


@pytest.mark.parametrize('value,kw,named', [
    (NAN, {}, 'nan'), (INF, {}, 'inf'), (-INF, {}, '-inf'), ('abc', {}, "'abc'"),
    (None, {}, 'None'), (-1.0, dict(lo=0), '-1.0'), (7.0, dict(lo=0, hi=1), '7.0'),
    (0.0, dict(lo=0, hi=1, lo_open=True), '0.0'), (1e300, dict(hi=1e6), '1e+300'),
])
def test_number_refuses_naming_field_and_value(value, kw, named):
    with pytest.raises(BadRequest) as e:
        srvcheck.number(value, 'speed', unit='m/s', **kw)
    text = str(e.value)
    assert text.startswith('speed must be a finite number') and text.endswith('got ' + named)
    assert '\n' not in text


def test_number_accepts_and_converts():
    assert srvcheck.number(3, 'x') == 3.0 and type(srvcheck.number(3, 'x')) is float
    assert srvcheck.number('2.5', 'x', 0, 3) == 2.5
    assert srvcheck.number(0.0, 'x', 0, 1) == 0.0          # closed interval
    assert srvcheck.number(1.0, 'x', 0, 1, lo_open=True) == 1.0


@pytest.mark.parametrize('bad', [0.0, -1.0, NAN, INF, -INF, 1e300, srvcheck.MAX_TIME * 2])
def test_duration(bad):
    with pytest.raises(BadRequest, match=r'^duration must be .*\(0, 1e\+09\] s'):
        srvcheck.duration(bad)
    assert srvcheck.duration(0.25) == 0.25


@pytest.mark.parametrize('bad', [-1.0, -1e-9, NAN, INF, -INF, 1e300])
def test_sim_time(bad):
    with pytest.raises(BadRequest, match=r'^until must be .*\[0, 1e\+09\] s, got '):
        srvcheck.sim_time(bad, 'until')
    assert srvcheck.sim_time(0.0, 'until') == 0.0
    assert srvcheck.sim_time(12.5, 'until') == 12.5


def test_name():
    assert srvcheck.name('power', 'button', ['power', 'volume_up']) == 'power'
    with pytest.raises(BadRequest, match=r"^button must be a name, got ''$"):
        srvcheck.name('', 'button')
    with pytest.raises(BadRequest, match=r"^button must be a name, got None$"):
        srvcheck.name(None, 'button')
    with pytest.raises(BadRequest) as e:
        srvcheck.name('home', 'button', ['volume_up', 'power'], kind='button of phone')
    assert str(e.value) == "no button of phone named 'home' (known: power, volume_up)"


@pytest.mark.parametrize('ns,ok', [
    ('', True), ('/', True), ('mobile_device', True), ('/mobile_device/', True),
    ('lab/phone_1', True), ('bad name!', False), ('a//b', False), ('~mine', False),
    ('a-b', False), ('a\nb', False)])
def test_ros_namespace(ns, ok):
    if ok:
        assert srvcheck.ros_namespace(ns) == ns
    else:
        with pytest.raises(BadRequest, match=r'^robot_namespace must be a ROS name'):
            srvcheck.ros_namespace(ns)


def test_choice():
    assert srvcheck.choice(2, 'action', (0, 1, 2)) == 2
    with pytest.raises(BadRequest, match=r"^fault must be one of drop, freeze, got 'melt'$"):
        srvcheck.choice('melt', 'fault', ('drop', 'freeze'))


def _pose(x=0.0, y=0.0, z=0.0, q=(0.0, 0.0, 0.0, 1.0)):
    m = PoseMsg()
    m.position.x, m.position.y, m.position.z = x, y, z
    m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w = q
    return m


@pytest.mark.parametrize('msg,named', [
    (_pose(x=NAN), 'nan'), (_pose(y=INF), 'inf'), (_pose(z=-1e300), '-1e+300'),
    (_pose(x=2e6), '2000000.0'), (_pose(q=(0, 0, 0, 0)), '[0.0, 0.0, 0.0, 0.0]'),
    (_pose(q=(NAN, 0, 0, 1)), 'nan'), (_pose(q=(0, 0, 0, 1e300)), '1e+300')])
def test_pose_refused(msg, named):
    with pytest.raises(BadRequest) as e:
        srvcheck.pose(msg, 'initial_pose')
    assert str(e.value).startswith('initial_pose') and named in str(e.value)


def test_pose_normalised():
    p = srvcheck.pose(_pose(1.0, 2.0, 3.0, (0.0, 0.0, 0.0, 2.0)))
    assert list(p.p) == [1.0, 2.0, 3.0] and list(p.q) == [0.0, 0.0, 0.0, 1.0]


def test_twist_bounds():
    t = Twist()
    t.linear.x, t.angular.z = 3.0, -2.0
    assert srvcheck.twist(t) == ([3.0, 0.0, 0.0], [0.0, 0.0, -2.0])
    for field, v, named in (('linear', NAN, 'nan'), ('linear', 1e300, '1e+300'),
                            ('angular', 1e9, '1000000000.0'), ('angular', -INF, '-inf')):
        t = Twist()
        getattr(t, field).y = v
        with pytest.raises(BadRequest) as e:
            srvcheck.twist(t)
        assert str(e.value).startswith('twist %s must be three finite numbers within' % field)
        assert named in str(e.value)


def _serialized(res):
    buff = io.BytesIO()
    res.serialize(buff)          # genpy raises on a field it cannot write
    return buff.getvalue()


def test_answers_a_refusal_with_every_field():
    lines = []

    class Api(object):
        sim_time = 4.5

        @srvcheck.answers(StepWorldResponse, 'StepWorld', log=lines.append,
                          fill=lambda self: dict(sim_time=self.sim_time))
        def step(self, req):
            srvcheck.sim_time(req, 'until')
            return StepWorldResponse(success=True, status_message='ran', sim_time=req)

    res = Api().step(NAN)
    assert isinstance(res, StepWorldResponse) and res.success is False
    assert res.status_message == 'StepWorld: until must be a finite number in [0, 1e+09] s, ' \
        'got nan'
    assert res.sim_time == 4.5 and res.topics == [] and res.times == []
    assert _serialized(res)
    assert lines == [res.status_message]
    ok = Api().step(2.0)                  # good input: the handler's own answer, no log line
    assert ok.success and ok.status_message == 'ran' and lines == [res.status_message]


def test_answers_a_bug_in_one_line():
    lines = []

    @srvcheck.answers(SpawnModelResponse, 'SpawnModel', log=lines.append)
    def spawn(req):
        return {}['missing\nkey']

    res = spawn(object())
    assert res.success is False
    assert res.status_message.startswith("SpawnModel: internal error: KeyError: 'missing\\nkey'")
    assert 'test_srvcheck.py:' in res.status_message and '\n' not in res.status_message
    assert lines == [res.status_message]


def test_answers_a_type_without_success_field():
    lines = []

    @srvcheck.answers(EmptyResponse, 'reset_world', log=lines.append)
    def reset(req):
        raise RuntimeError('the world is gone')

    assert isinstance(reset(None), EmptyResponse)
    assert len(lines) == 1 and lines[0].startswith('reset_world: internal error: RuntimeError')


def test_answers_names_a_newline_in_one_line():
    lines = []

    @srvcheck.answers(SetSensorFaultResponse, 'SetSensorFault', log=lines.append)
    def fault(req):
        srvcheck.name(req, 'sensor', ['imu'])

    res = fault('a\nb')
    assert res.status_message == "SetSensorFault: no sensor named 'a\\nb' (known: imu)"
    assert lines == [res.status_message]


def test_bounds_are_finite_and_far():
    assert srvcheck.MAX_POSITION == 1e6 and srvcheck.MAX_TIME < 2 ** 32
    assert all(math.isfinite(v) for v in (srvcheck.MAX_SPEED, srvcheck.MAX_SPIN,
                                          srvcheck.MAX_SCALE))
