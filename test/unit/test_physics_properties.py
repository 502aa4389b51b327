"""/gazebo/{get,set}_physics_properties without ROS: sim_world.physics_api's check and
apply on a real World of each engine, and the run loop's pace changed while it runs."""
import math
import threading
import time

import pytest

from sim_world.physics_api import ODE_FIELDS, apply_physics, physics_properties, plan_physics
from sim_world.world import World

ZEROS = {k: 0 for k in ODE_FIELDS}


def _world(engine):
    return World(physics=engine, step_size=0.002)


@pytest.mark.parametrize('engine', ['ode', 'bullet'])
def test_get_gives_the_pace_as_gazebo_does(engine):
    w = _world(engine)
    p = physics_properties(w, 1.5, paused=True)
    assert p['time_step'] == 0.002 and p['pause'] is True
    assert p['max_update_rate'] == pytest.approx(750.0)      # 1.5 / 0.002
    assert physics_properties(w, 0.0, False)['max_update_rate'] == 0.0
    assert p['gravity'] == pytest.approx((0.0, 0.0, -9.81))
    if engine == 'ode':
        c = p['ode_config']
        assert set(c) == set(ODE_FIELDS)
        assert c['sor_pgs_iters'] == 20 and c['erp'] == pytest.approx(0.2)
    else:
        assert p['ode_config'] is None


@pytest.mark.parametrize('engine', ['ode', 'bullet'])
def test_set_pace_and_gravity(engine):
    w = _world(engine)
    rtf, g, config = plan_physics(w, 0.0, 250.0, (0.0, 0.0, -1.62), ZEROS)
    assert rtf == pytest.approx(0.5) and config is None
    apply_physics(w, (rtf, g, config))
    assert tuple(w.gravity) == pytest.approx((0.0, 0.0, -1.62))
    assert physics_properties(w, rtf, False)['gravity'] == pytest.approx((0.0, 0.0, -1.62))


def test_ode_solver_fields_are_set_and_the_fixed_ones_checked():
    w = _world('ode')
    config = dict(physics_properties(w, 1.0, False)['ode_config'])
    config.update(sor_pgs_iters=50, erp=0.5, cfm=1e-5)
    plan = plan_physics(w, 0.002, 500.0, (0, 0, -9.81), config)
    apply_physics(w, plan)
    got = physics_properties(w, plan[0], False)['ode_config']
    assert (got['sor_pgs_iters'], got['erp'], got['cfm']) == (50, 0.5, pytest.approx(1e-5))
    # a field of 0 keeps its value: a request changes only what it gives
    apply_physics(w, plan_physics(w, 0, 500.0, (0, 0, -9.81), dict(ZEROS, erp=0.3)))
    got = physics_properties(w, plan[0], False)['ode_config']
    assert (got['sor_pgs_iters'], got['erp'], got['cfm']) == (50, 0.3, pytest.approx(1e-5))
    bad = dict(config, max_contacts=3)
    with pytest.raises(ValueError, match='max_contacts is fixed'):
        apply_physics(w, plan_physics(w, 0, 500.0, (0, 0, -9.81), bad))
    with pytest.raises(ValueError, match='erp must be in'):
        apply_physics(w, plan_physics(w, 0, 500.0, (0, 0, -1.0), dict(config, erp=2.0)))
    # a refused solver field leaves the gravity as it was
    assert tuple(w.gravity) == pytest.approx((0.0, 0.0, -9.81))


@pytest.mark.parametrize('kw, match', [
    (dict(time_step=0.001), 'time_step is fixed at 0.002'),
    (dict(max_update_rate=-1.0), 'max_update_rate must be >= 0'),
    (dict(max_update_rate=math.nan), 'max_update_rate must be a finite'),
    (dict(gravity=(0.0, math.inf, 0.0)), 'gravity must be finite'),
])
def test_bad_requests_are_named(kw, match):
    w = _world('ode')
    args = dict(time_step=0.0, max_update_rate=500.0, gravity=(0, 0, -9.81), ode_config=ZEROS)
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        plan_physics(w, **args)


def test_bullet_refuses_an_ode_config():
    w = _world('bullet')
    with pytest.raises(ValueError, match='applies to the ode engine'):
        apply_physics(w, plan_physics(w, 0, 500.0, (0, 0, -9.81), dict(ZEROS, erp=0.2)))


class _Api(object):
    """What run_loop reads of GazeboRosApi."""
    def __init__(self):
        self.paused = False
        self.step_until = None
        self.reset_anchor = threading.Event()
        self.real_time_factor = None

    def publish(self):
        pass


def test_the_run_loop_takes_a_new_pace_while_it_runs():
    from sim_world.gazebo_api import run_loop
    w = _world('ode')
    api, stop = _Api(), threading.Event()
    t = threading.Thread(target=run_loop, args=(w, api), daemon=True,
                         kwargs=dict(real_time_factor=0.05, should_stop=stop.is_set))
    t.start()
    try:
        time.sleep(0.3)
        assert api.real_time_factor == 0.05
        slow = w.sim_time
        assert slow < 0.1                       # paced: 0.05 of 0.3 s is 0.015 s
        api.real_time_factor = 0.0              # as set_physics_properties does
        api.reset_anchor.set()
        t0 = w.sim_time
        time.sleep(0.3)
        assert w.sim_time - t0 > 0.1            # unpaced it runs far ahead
    finally:
        stop.set()
        t.join(5)
