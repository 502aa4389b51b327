"""Gazebo's physics properties services, served next to sim_world.gazebo_api.

  /gazebo/get_physics_properties  time_step, pause, max_update_rate, gravity, ode_config
  /gazebo/set_physics_properties  max_update_rate (the pace), gravity, ode_config

(this package's copies of the gazebo_msgs definitions, same md5sums). As in Gazebo, the
pace is ``max_update_rate``, steps per wall second: the real-time factor the world aims at
is ``max_update_rate * time_step`` (0: as fast as it can; ``~real_time_factor`` at launch).
``time_step`` is fixed for the world's life (a world's sim time is its step count times it):
a request must give the world's own (or 0: keep), and ``/gazebo/reload_world`` takes another
through the world file. In ``ode_config`` a field of 0 keeps its value (the message's
default is all zeros, so a request changes only the fields it gives; an exact 0 for cfm or
the surface layer is not possible, 1e-12 is); on the ODE engine ``sor_pgs_iters``, ``erp``,
``cfm``, ``contact_surface_layer`` and ``contact_max_correcting_vel`` are set, and a field
the world keeps fixed must equal what get_physics_properties gives. A bad field answers
``success: false`` naming it, one log line, and nothing changes.
"""
import math

from mobile_device_sim.msg import ODEPhysics
from mobile_device_sim.srv import (GetPhysicsProperties, GetPhysicsPropertiesResponse,
                                   SetPhysicsProperties, SetPhysicsPropertiesResponse)

from . import srvcheck

__all__ = ['PhysicsRosApi', 'physics_properties', 'plan_physics', 'apply_physics']

ODE_FIELDS = ('auto_disable_bodies', 'sor_pgs_precon_iters', 'sor_pgs_iters', 'sor_pgs_w',
              'sor_pgs_rms_error_tol', 'contact_surface_layer', 'contact_max_correcting_vel',
              'cfm', 'erp', 'max_contacts')


def physics_properties(world, real_time_factor, paused):
    """{time_step, pause, max_update_rate, gravity (x, y, z), ode_config (dict or None)}."""
    step = world.step_size
    return {'time_step': step, 'pause': bool(paused),
            'max_update_rate': real_time_factor / step if real_time_factor > 0 else 0.0,
            'gravity': tuple(float(g) for g in world.gravity),
            'ode_config': world.physics.solver_config()}


def plan_physics(world, time_step, max_update_rate, gravity, ode_config):
    """What a set request asks for, checked before anything changes: (real_time_factor,
    gravity tuple, ode_config dict or None (keep)). ValueError names a bad field."""
    for name, v in (('time_step', time_step), ('max_update_rate', max_update_rate)):
        if not math.isfinite(v):
            raise ValueError('%s must be a finite number, got %r' % (name, v))
    if time_step != 0 and abs(time_step - world.step_size) > 1e-12:
        raise ValueError('time_step is fixed at %g s for the world\'s life (its sim time '
                         'counts steps), got %g: give %g or 0, or reload the world with '
                         'another max_step_size' % (world.step_size, time_step,
                                                    world.step_size))
    if max_update_rate < 0:
        raise ValueError('max_update_rate must be >= 0 (0: as fast as possible), got %g'
                         % max_update_rate)
    g = tuple(float(x) for x in gravity)
    if not all(math.isfinite(x) for x in g):
        raise ValueError('gravity must be finite, got %r' % (g,))
    rtf = max_update_rate * world.step_size
    config = None
    if ode_config is not None and any(ode_config[k] for k in ODE_FIELDS):
        config = {k: v for k, v in ode_config.items() if v}     # 0: keep
    return rtf, g, config


def apply_physics(world, plan):
    """Sets the gravity and the solver of a checked plan (the caller holds the world's lock
    and sets the pace); ValueError from the engine leaves the gravity as it was."""
    _rtf, g, config = plan
    if config is not None:
        world.physics.set_solver_config(**config)
    world.set_gravity(g)


class PhysicsRosApi(object):
    """The two services on the API object ``api`` (GazeboRosApi): its ``world``, ``paused``,
    ``real_time_factor`` (what the run loop paces to) and ``reset_anchor``."""

    def __init__(self, api):
        from . import transport
        self.api = api
        self.services = [
            transport.service('/gazebo/get_physics_properties', GetPhysicsProperties,
                              self.get_physics_properties),
            transport.service('/gazebo/set_physics_properties', SetPhysicsProperties,
                              self.set_physics_properties),
        ]

    @srvcheck.answers(GetPhysicsPropertiesResponse, 'GetPhysicsProperties')
    def get_physics_properties(self, _req):
        api = self.api
        with api.world.lock:
            p = physics_properties(api.world, api.real_time_factor, api.paused)
        r = GetPhysicsPropertiesResponse()
        r.time_step, r.pause, r.max_update_rate = p['time_step'], p['pause'], \
            p['max_update_rate']
        r.gravity.x, r.gravity.y, r.gravity.z = p['gravity']
        r.ode_config = ODEPhysics(**(p['ode_config'] or {}))
        r.success, r.status_message = True, 'GetPhysicsProperties: success'
        return r

    @srvcheck.answers(SetPhysicsPropertiesResponse, 'SetPhysicsProperties')
    def set_physics_properties(self, req):
        api = self.api
        ode = {k: getattr(req.ode_config, k) for k in ODE_FIELDS}
        try:
            with api.world.lock:
                plan = plan_physics(api.world, req.time_step, req.max_update_rate,
                                    (req.gravity.x, req.gravity.y, req.gravity.z), ode)
                apply_physics(api.world, plan)
        except ValueError as e:
            raise srvcheck.BadRequest('%s; nothing changed' % e)
        api.real_time_factor = plan[0]
        api.reset_anchor.set()           # the run loop paces from now on
        return SetPhysicsPropertiesResponse(
            True, 'SetPhysicsProperties: real-time factor %g (max_update_rate %g), gravity '
            '%s' % (plan[0], req.max_update_rate, list(plan[1])))
