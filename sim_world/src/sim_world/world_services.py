"""ROS services of the sensor layer beside the Gazebo API (sim_world starts them):

  /gazebo/set_environment   (mobile_device_sim/SetEnvironment)  change environment values
  /gazebo/environment       (mobile_device_sim/Environment, latched) every value, on change
  /gazebo/set_sensor_fault  (mobile_device_sim/SetSensorFault)  drop / freeze / noise / ...

Bad requests answer ``success: false`` with a ``status_message`` naming the bad input, log
one line, and change nothing.
"""
import rospy

from mobile_device_sim.msg import Environment as EnvironmentMsg
from mobile_device_sim.msg import EnvironmentValue
from mobile_device_sim.srv import (SetEnvironment, SetEnvironmentResponse, SetSensorFault,
                                   SetSensorFaultResponse)

from . import srvcheck, transport
from .environment import EnvironmentError
from .plugins.sensor import inject_fault

__all__ = ['WorldServices', 'environment_msg']


def environment_msg(env, stamp):
    msg = EnvironmentMsg()
    msg.header.stamp = stamp
    msg.values = [EnvironmentValue(name=k, value=float(v)) for k, v in env.values().items()]
    return msg


class WorldServices(object):
    def __init__(self, world):
        self.env_pub = None
        self.attach(world)
        self.services = [
            transport.service('/gazebo/set_environment', SetEnvironment, self.set_environment),
            transport.service('/gazebo/set_sensor_fault', SetSensorFault, self.set_sensor_fault),
        ]

    def attach(self, world):
        """Serve ``world`` (a reloaded world: /gazebo/environment starts over, its header
        sequence numbers too, as in a fresh node)."""
        self.world = world
        if self.env_pub is not None:
            self.env_pub.unregister()
        self.env_pub = transport.publisher('/gazebo/environment', EnvironmentMsg, queue_size=10,
                                           latch=True)
        self.publish_environment()

    def publish_environment(self):
        with self.world.lock:
            msg = environment_msg(self.world.environment, self.world.ros_now())
        self.env_pub.publish(msg)

    @srvcheck.answers(SetEnvironmentResponse, 'SetEnvironment')
    def set_environment(self, req):
        res = SetEnvironmentResponse()
        with self.world.lock:
            try:
                self.world.environment.set_many([(v.name, v.value) for v in req.values])
            except EnvironmentError as e:
                res.success = False
                res.status_message = srvcheck.one_line('SetEnvironment: %s; nothing changed'
                                                       % e)
                rospy.logerr(res.status_message)
                return res
        res.success = True
        res.status_message = 'SetEnvironment: set %s' % ', '.join(
            '%s=%g' % (v.name, v.value) for v in req.values)
        self.publish_environment()
        return res

    @srvcheck.answers(SetSensorFaultResponse, 'SetSensorFault')
    def set_sensor_fault(self, req):
        # every fault takes the value (noise: the sigmas' multiplier; inf or 1e300 would
        # publish inf and NaN): a finite number of a sensible size, whatever the fault
        srvcheck.number(req.value, 'value', -srvcheck.MAX_SCALE, srvcheck.MAX_SCALE)
        res = SetSensorFaultResponse()
        with self.world.lock:
            if req.model_name not in self.world.models:
                res.status_message = 'SetSensorFault: no model named %r' % req.model_name
            else:
                found = self.world.find_plugins(req.model_name, req.sensor)
                if not found:
                    res.status_message = ('SetSensorFault: model %r has no sensor %r (give the '
                                          'plugin name, library file name or a topic)'
                                          % (req.model_name, req.sensor))
                else:
                    try:
                        inject_fault(found, req.fault or 'none', req.value)
                        res.success = True
                        res.status_message = 'SetSensorFault: %s of %s: %s %g' % (
                            req.sensor, req.model_name, req.fault or 'none', req.value)
                    except ValueError as e:
                        res.status_message = 'SetSensorFault: %s' % e
        if not res.success:
            res.status_message = srvcheck.one_line(res.status_message)
            rospy.logerr(res.status_message)
        else:
            rospy.loginfo(res.status_message)
        return res
