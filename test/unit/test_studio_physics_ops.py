"""sim_studio.physics without ROS: the op reads the pace and sets it through the two Gazebo
services with the world's own step and gravity, and a refusal of the world is the error."""
import types

import pytest

from sim_studio import physics


class _World(object):
    """What physics uses of WorldLink: proxy(name, type) -> a callable service."""
    def __init__(self, refuse=None):
        self.rate, self.sent, self.refuse = 1000.0, [], refuse

    def proxy(self, name, _typ):
        def get():
            return types.SimpleNamespace(success=True, status_message='', time_step=0.001,
                                         max_update_rate=self.rate, pause=False,
                                         gravity=types.SimpleNamespace(x=0.0, y=0.0, z=-9.81))

        def set_(**kw):
            self.sent.append(kw)
            if self.refuse:
                return types.SimpleNamespace(success=False, status_message=self.refuse)
            self.rate = kw['max_update_rate']
            return types.SimpleNamespace(success=True, status_message='')
        return get if name == physics.GET else set_


def test_read_and_set_the_pace():
    w = _World()
    studio = types.SimpleNamespace(world=w)
    assert physics._do(studio, {})['real_time_factor'] == pytest.approx(1.0)
    rep = physics._do(studio, {'real_time_factor': 2.5})
    assert rep['real_time_factor'] == pytest.approx(2.5) and rep['max_update_rate'] == 2500.0
    sent = w.sent[-1]
    assert sent['time_step'] == 0.001 and sent['gravity'].z == -9.81
    assert physics._do(studio, {'real_time_factor': 0})['real_time_factor'] == 0.0


def test_bad_values_and_refusals_are_errors():
    with pytest.raises(ValueError, match='real_time_factor'):
        physics.set_pace(_World(), float('nan'))
    w = _World(refuse='SetPhysicsProperties: no')
    with pytest.raises(ValueError, match='SetPhysicsProperties: no'):
        physics.set_pace(w, 2.0)
    assert w.rate == 1000.0


def test_the_op_is_declared_like_the_core_ones():
    spec = physics.OPS['physics']
    assert spec['kinds'] == {'real_time_factor': 'num>=0'} and spec['needs_control']
    assert not spec['changes_world']          # the pace is not a timeline action
