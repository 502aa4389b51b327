"""The office's east door on its hinge (issue 48 part 5): limits [0, 1.5] rad hold under
20 N m, its friction holds under half of it and gives under twice it (both engines); open
by default, clear of the doorway; closed, the radio path through the doorway crosses it and
loses a wooden door's loss (the WiFi plugin's budget: radio_budget.budget_to over
world.segment_intervals, whose ray caster now follows the links of articulated models).
"""
import logging

import numpy as np
import pytest

from simsensors import radio_budget as rb
from sim_world.physics import ENGINES, make_engine
from sim_world.sdf import load_world_file

import worlds

INSIDE, OUTSIDE = (5.0, -3.0, 1.0), (7.5, -3.0, 1.0)     # through the doorway, head-on


def door_model():
    return next(m for m in load_world_file(worlds.OFFICE).models if m.name == 'east_door')


@pytest.fixture(params=ENGINES)
def engine(request):
    e = make_engine(request.param)
    e.add_model(door_model())
    yield e
    e.close()


def q(e):
    return e.joint_state('east_door', 'hinge')[0]


def test_the_door_is_open_by_default_and_read_from_sdf():
    m = door_model()
    j = m.joint('hinge')
    assert (j.type, j.lower, j.upper, j.initial, j.friction, j.damping) == \
        ('revolute', 0.0, 1.5, 1.5, 2.0, 0.0)
    assert m.root_link == 'world'            # <parent>world</parent>: welded


def test_limits_hold_within_a_hundredth_under_20_nm(engine):
    assert q(engine) == pytest.approx(1.5, abs=1e-9)
    engine.apply_joint_effort('east_door', 'hinge', 20.0, steps=1500)
    engine.step(1500)
    assert abs(q(engine) - 1.5) < 0.01
    engine.apply_joint_effort('east_door', 'hinge', -20.0, steps=3000)
    engine.step(3000)
    assert abs(q(engine)) < 0.01
    engine.apply_joint_effort('east_door', 'hinge', -20.0, steps=1000)
    engine.step(1000)
    assert abs(q(engine)) < 0.01


def test_friction_holds_under_half_and_gives_under_twice(engine):
    f = engine.joint('east_door', 'hinge').friction
    engine.set_joint_positions('east_door', {'hinge': 0.75})
    engine.apply_joint_effort('east_door', 'hinge', 0.5 * f, steps=500)
    engine.step(500)
    assert abs(q(engine) - 0.75) < 1e-3
    engine.apply_joint_effort('east_door', 'hinge', 2 * f, steps=500)
    engine.step(500)
    assert q(engine) - 0.75 > 0.02


@pytest.mark.parametrize('physics', ENGINES)
def test_closing_the_door_attenuates_the_radio_through_it(physics, caplog):
    caplog.set_level(logging.ERROR)
    with worlds.opened(physics, office='world') as w:
        tx = rb.Transmitter('wifi', '00:00:00:00:00:01', 'test', 2437, 20, 0, 0,
                            lambda: np.array(INSIDE))

        def budget():
            return rb.budget_to(tx, OUTSIDE, segment_intervals=w.segment_intervals)[1]['l_ob']

        w.step(10)
        assert w.physics.joint_state('east_door', 'hinge')[0] == pytest.approx(1.5, abs=1e-3)
        assert [iv[2] for iv in w.segment_intervals(INSIDE, OUTSIDE)] == []
        assert budget() == 0.0                        # open: as the doorway always was
        w.physics.set_joint_positions('east_door', {'hinge': 0.0})
        w.step(10)
        ivs = w.segment_intervals(INSIDE, OUTSIDE, incidence=True)
        assert [(iv[2], iv[3], iv[4]) for iv in ivs] == [('east_door', 'leaf', 'door')]
        assert budget() == pytest.approx(rb.WALL_LOSS['door'], rel=1e-6)
        w.reset()                                     # reset_world: open again
        w.step(1)
        assert budget() == 0.0
