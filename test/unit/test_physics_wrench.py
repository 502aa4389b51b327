"""External wrenches on both physics engines (apply_wrench / clear_wrench): the force
controller and the vibration motor of thesis 3.4.3 push bodies through them. No roscore."""
import numpy as np
import pytest

from sim_world.model import Collision, Geometry, Inertial, Link, Model, cuboid_inertia
from sim_world.physics import ENGINES, make_engine
from sim_world.transforms import Pose

DT = 0.001


@pytest.fixture(params=ENGINES)
def engine(request):
    e = make_engine(request.param, DT, (0.0, 0.0, -9.81))
    yield e
    e.close()


def floating_box(name='box', mass=0.5, size=(0.1, 0.1, 0.1)):
    ixx, iyy, izz = cuboid_inertia(mass, *size)
    return Model(name, {'base': Link('base', Inertial(mass, ixx=ixx, iyy=iyy, izz=izz),
                                     collisions=[Collision(Geometry('box', size=size))],
                                     gravity=False)}, pose=Pose((0, 0, 1)))


def test_force_for_n_steps_gives_the_impulse(engine):
    engine.add_model(floating_box(mass=0.5))
    engine.apply_wrench('box', (1.0, -2.0, 0.5), steps=10)
    engine.step(20)                        # 10 steps with the force, 10 without
    lin, ang = engine.model_twist('box')
    assert lin == pytest.approx(np.array([1.0, -2.0, 0.5]) * 10 * DT / 0.5, rel=1e-3,
                                abs=1e-9)
    assert np.allclose(ang, 0, atol=1e-9)


def test_persistent_until_replaced_and_keys_add_up(engine):
    engine.add_model(floating_box(mass=1.0))
    engine.apply_wrench('box', (1.0, 0, 0), steps=None, key='ctl')
    engine.apply_wrench('box', (0, 1.0, 0), steps=5, key='other')
    engine.step(100)
    lin, _ = engine.model_twist('box')
    assert lin == pytest.approx([0.1, 0.005, 0.0], rel=1e-3, abs=1e-9)
    engine.apply_wrench('box', (-1.0, 0, 0), steps=None, key='ctl')    # replaces
    engine.step(100)
    lin, _ = engine.model_twist('box')
    assert lin == pytest.approx([0.0, 0.005, 0.0], abs=1e-6)
    engine.clear_wrench('box')
    engine.step(10)
    assert engine.model_twist('box')[0] == pytest.approx([0.0, 0.005, 0.0], abs=1e-6)


def test_rows_one_per_step_zero_mean(engine):
    engine.add_model(floating_box(mass=1.0))
    rows = np.zeros((4, 3))
    rows[:2, 0], rows[2:, 0] = 2.0, -2.0
    engine.apply_wrench('box', rows)
    engine.step(2)
    assert engine.model_twist('box')[0][0] == pytest.approx(0.004, rel=1e-3)
    engine.step(10)
    assert engine.model_twist('box')[0][0] == pytest.approx(0.0, abs=1e-9)


def test_torque_spins_about_the_world_axis(engine):
    engine.add_model(floating_box(mass=0.6, size=(0.1, 0.1, 0.1)))
    izz = 0.6 * (0.01 + 0.01) / 12
    engine.apply_wrench('box', None, (0, 0, 0.01), steps=10)
    engine.step(10)
    _, ang = engine.model_twist('box')
    assert ang == pytest.approx([0, 0, 0.01 * 10 * DT / izz], rel=1e-2, abs=1e-6)


def test_bad_wrench_is_refused(engine):
    engine.add_model(floating_box())
    with pytest.raises(ValueError, match='force on model'):
        engine.apply_wrench('box', (float('nan'), 0, 0))
    with pytest.raises(ValueError, match='torque on model'):
        engine.apply_wrench('box', (0, 0, 0), (1, 2))
    with pytest.raises(KeyError):
        engine.apply_wrench('nobody', (1, 0, 0))
    engine.step(5)
    assert np.allclose(engine.model_twist('box')[0], 0)
