"""The studio's world pace: the real-time factor the world aims at, read and set through
Gazebo's own services (/gazebo/get_physics_properties, /gazebo/set_physics_properties;
sim_world.physics_api), as a Gazebo user changes it.

Op ``physics`` {real_time_factor (optional, >= 0; 0: as fast as the world can)}: without
the field it reads; with it, it sets ``max_update_rate = real_time_factor / time_step`` and
keeps the gravity and the solver. The reply: ``time_step`` s, ``real_time_factor`` (the
aim), ``max_update_rate``, ``gravity``, ``paused``. The pace changes nothing the scenario
judges (a run of the testing instance steps in lockstep), so it is not recorded; it acts on
the world everyone watches, so it needs control.

The page script (static/ext/physics.js) puts a field beside the measured real-time factor
in the header (``data-testid="rtf-aim"``): Enter sets it."""
import asyncio
import math

__all__ = ['OPS', 'handle', 'properties', 'set_pace']

OPS = {
    'physics': dict(required={}, optional={'real_time_factor': None},
                    kinds={'real_time_factor': 'num>=0'}, changes_world=False,
                    needs_control=True,
                    doc="read or set the real-time factor the world aims at (0: as fast as "
                        "it can) through /gazebo/set_physics_properties"),
}

GET, SET = '/gazebo/get_physics_properties', '/gazebo/set_physics_properties'


def _reply(r):
    step = r.time_step
    return {'time_step': step, 'max_update_rate': r.max_update_rate,
            'real_time_factor': r.max_update_rate * step if r.max_update_rate > 0 else 0.0,
            'gravity': [r.gravity.x, r.gravity.y, r.gravity.z], 'paused': bool(r.pause)}


def properties(world):
    """The world's physics properties now (RuntimeError when the service fails)."""
    from mobile_device_sim.srv import GetPhysicsProperties
    r = world.proxy(GET, GetPhysicsProperties)()
    if not r.success:
        raise RuntimeError(r.status_message)
    return r


def set_pace(world, rtf):
    """Sets the aim to ``rtf`` (>= 0, finite), keeping the world's gravity and solver;
    returns the properties after it. ValueError: the world refused (its message)."""
    from mobile_device_sim.msg import ODEPhysics
    from mobile_device_sim.srv import SetPhysicsProperties
    if not (isinstance(rtf, (int, float)) and math.isfinite(rtf) and rtf >= 0):
        raise ValueError('physics: real_time_factor must be a finite number >= 0, got %r'
                         % (rtf,))
    now = properties(world)
    res = world.proxy(SET, SetPhysicsProperties)(
        time_step=now.time_step, max_update_rate=rtf / now.time_step, gravity=now.gravity,
        ode_config=ODEPhysics())
    if not res.success:
        raise ValueError(res.status_message)
    return properties(world)


def _do(studio, fields):
    rtf = fields.get('real_time_factor')
    r = properties(studio.world) if rtf is None else set_pace(studio.world, rtf)
    return _reply(r)


async def handle(studio, cmd, client):
    return await asyncio.get_event_loop().run_in_executor(None, _do, studio, cmd.fields)
