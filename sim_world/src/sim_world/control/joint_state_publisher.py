"""libgazebo_ros_joint_state_publisher.so: the named joints' positions and velocities on
``<ns>/joint_states`` (sensor_msgs/JointState) at ``updateRate`` Hz of sim time, stamped in
sim time, as gazebo_ros's plugin (issue 48). Debian's robot_state_publisher turns them into
the links' tf.

Parameters: ``jointName`` (comma-separated joint names, in the order they are published;
each must be a movable joint the world simulates), ``updateRate`` (Hz, default 100),
``robotNamespace``.
"""
from ..plugins import Plugin, PluginError, register
from ..plugins.params import Param

__all__ = ['JointStatePublisher']


@register('libgazebo_ros_joint_state_publisher.so')
class JointStatePublisher(Plugin):
    PARAMS = [
        Param('jointName', str, '', doc='comma-separated joints, in the published order'),
        Param('updateRate', float, 100.0, check=lambda v: v >= 0,
              doc='Hz of sim time (0: every step)'),
    ]

    def load(self):
        p = self.parse(self.PARAMS)
        self.joints = [n.strip() for n in (p.jointName or '').replace(',', ' ').split()
                       if n.strip()]
        if not self.joints:
            raise PluginError('%s: jointName names no joint' % self.label)
        have = self.world.joint_states(self.model.name)
        for n in self.joints:
            if n not in have:
                raise PluginError('%s: jointName %r is not a simulated joint of the model '
                                  '(joints: %s)' % (self.label, n, ', '.join(have) or 'none'))
        self.update_rate = p.updateRate
        self.topic = self.resolve('joint_states')
        self.pub = None
        self.last_msg = None
        if self.world.ros_enabled:
            from sensor_msgs.msg import JointState
            from .. import transport
            self.pub = transport.publisher(self.topic, JointState, queue_size=10)

    def ros_names(self):
        return {self.topic}

    def update(self, sim_time):
        from sensor_msgs.msg import JointState
        states = self.world.joint_states(self.model.name)
        msg = JointState()
        msg.header.stamp = self.world.ros_now()
        msg.name = list(self.joints)
        msg.position = [float(states[n][0]) for n in self.joints]
        msg.velocity = [float(states[n][1]) for n in self.joints]
        self.last_msg = msg
        if self.pub is not None:
            self.pub.publish(msg)

    def shutdown(self):
        if self.pub is not None:
            self.pub.unregister()
            self.pub = None
