"""Physics backends behind one interface: ODE (pyode) and Bullet (pybullet).

``make_engine('ode' | 'bullet', step_size, gravity)`` returns a
``sim_world.physics.base.PhysicsEngine``; its docstring (``base.py``) is the contract the
world relies on. ODE is the default (``~physics_engine:=ode``), as in Gazebo.
"""
from .base import PhysicsEngine, lump_model  # noqa: F401

__all__ = ['ENGINES', 'PhysicsEngine', 'make_engine', 'lump_model']

#: names accepted by make_engine (the ~physics_engine parameter)
ENGINES = ('ode', 'bullet')


def make_engine(name='ode', step_size=0.001, gravity=(0.0, 0.0, -9.81)):
    """A new, empty physics world. Raises ValueError naming the choices for an unknown
    engine name, or for a non-positive step size."""
    key = str(name).strip().lower()
    if key == 'ode':
        from .ode_engine import OdeEngine
        return OdeEngine(step_size, gravity)
    if key == 'bullet':
        from .bullet_engine import BulletEngine
        return BulletEngine(step_size, gravity)
    raise ValueError('unknown physics engine %r: use one of %s' % (name, ', '.join(ENGINES)))
