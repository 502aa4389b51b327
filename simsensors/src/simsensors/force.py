"""The thesis's force controller (section 3.4.3, code snippet 3.4.2): the 2011
``<controller:ros_force plugin="libros_force.so">`` and Gazebo classic's
``libgazebo_ros_force.so``.

A geometry_msgs/Wrench on ``topicName`` (default ``force`` in the robot namespace; the
thesis's snippet names ``/mobile_device/force``) is applied to ``bodyName`` (default the
model root; the force at the centre of mass, force and torque in the world frame, as
gazebo_ros_force does) during every physics step until the next message. The message is
taken at the plugin's next tick (``updateRate``, the thesis's 100 Hz: within 10 ms of sim
time) and handed to the physics engine as a persistent wrench (``apply_wrench`` with
``steps=None``), so no plugin pass runs per step. A zero wrench ends it. Bad input (NaN or
infinite components): one error line naming it; the last good wrench stays.
"""
import math

import numpy as np

from sim_world.plugins import register
from sim_world.plugins.device import Actuator

__all__ = ['ForceController']


@register('libgazebo_ros_force.so', 'libros_force.so')
class ForceController(Actuator):
    DEFAULT_TOPIC = 'force'
    DEFAULT_RATE = 100.0

    def setup(self):
        from geometry_msgs.msg import Wrench
        self.wrench = (np.zeros(3), np.zeros(3))
        self.key = ('force', self.spec.name or self.spec.filename)
        self.subscribe(self.topic, Wrench, self._on_msg)

    def _on_msg(self, m):
        self.set_wrench((m.force.x, m.force.y, m.force.z), (m.torque.x, m.torque.y, m.torque.z))

    def set_wrench(self, force, torque=(0.0, 0.0, 0.0)):
        """World-frame force (N) and torque (N m) from the next tick on (any thread)."""
        try:
            f = np.asarray(force, float).reshape(3)
            t = np.asarray(torque, float).reshape(3)
        except (TypeError, ValueError):
            f = t = np.array([math.nan] * 3)
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(t))):
            self.log_error('%s: wrench on %s must be finite numbers, got force %r torque %r; '
                           'the last good wrench stays' % (self.label, self.topic, force, torque))
            return False
        self.queue((f, t))
        return True

    def act(self, sim_time, commands):
        if not commands:
            return
        w = commands[-1]                 # the last message of the tick wins
        self.wrench = w
        self.last_value = w
        if np.any(w[0]) or np.any(w[1]):
            self.world.apply_wrench(self.model.name, w[0], w[1], steps=None, key=self.key)
        else:
            self.world.clear_wrench(self.model.name, self.key)

    def reset(self):
        Actuator.reset(self)
        self.wrench = (np.zeros(3), np.zeros(3))
        self.world.clear_wrench(self.model.name, self.key)

    def shutdown(self):
        self.world.clear_wrench(self.model.name, self.key)
        Actuator.shutdown(self)
