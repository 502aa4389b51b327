"""libgazebo_ros_control.so (issue 48 part 4): gazebo_ros_control's plugin. It reads the
model's ``<transmission>`` elements (sim_world.control.robot_hw), holds a controller manager
(sim_world.control.controllers, the trajectory controllers in sim_world.control.trajectory)
and updates it every physics step (or every ``controlPeriod``) in sim time, inside the
world's step. With ROS, the manager's services and each controller's topics, services and
action are served in the plugin's robot namespace (sim_world.control.ros_api).

Parameters: ``robotNamespace``, ``controlPeriod`` (s; 0 or absent: every physics step),
``robotSimType`` (only ``gazebo_ros_control/DefaultRobotHWSim``), ``eStopTopic`` (a
std_msgs/Bool topic: true stops the robot as DefaultRobotHWSim's e-stop does, false releases
it and the running controllers are restarted; ``e_stop(active)`` does the same without ROS).
PID gains for position and velocity interfaces come from the parameters
``<ns>/gazebo_ros_control/pid_gains/<joint>`` (``p``, ``i``, ``d``, ``i_clamp``), read when the
plugin loads, as Gazebo does (``set_pid_gains`` without ROS). A model without a
transmission is one warning (the plugin runs with no joint, as Gazebo's); a bad
transmission is one error naming it, and the model stays without the plugin.
"""
from ..plugins import Plugin, PluginError, register
from ..plugins.params import Param
from .controllers import ControllerManager
from .robot_hw import RobotHWSim, TransmissionError, parse_transmissions

__all__ = ['GazeboRosControl']


@register('libgazebo_ros_control.so')
class GazeboRosControl(Plugin):
    PARAMS = [
        Param('controlPeriod', float, 0.0, check=lambda v: v >= 0,
              doc='s of sim time (0: every step)'),
        Param('robotSimType', str, 'gazebo_ros_control/DefaultRobotHWSim',
              check=lambda v: v == 'gazebo_ros_control/DefaultRobotHWSim',
              doc='only gazebo_ros_control/DefaultRobotHWSim'),
        Param('eStopTopic', str, '', doc='std_msgs/Bool topic of the e-stop (empty: none)'),
    ]

    def load(self):
        p = self.parse(self.PARAMS)
        try:
            trans = parse_transmissions(self.model.source_xml)
        except (TransmissionError, SyntaxError) as e:
            raise PluginError('%s: %s' % (self.label, e))
        if not trans:
            # Gazebo's plugin runs then with no joint to control: one warning, as it does
            self.world.log.warning('%s: model %r has no <transmission>: no joint to control',
                                   self.label, self.model.name)
        model, plugin_id = self.model.name, id(self)
        try:
            self.hw = self.world.shared('gazebo_ros_control/%s/%x' % (model, plugin_id),
                                        lambda w: RobotHWSim(w, model, trans))
        except TransmissionError as e:
            raise PluginError('%s: %s' % (self.label, e))
        self.manager = ControllerManager(self.hw, log=self.world.log)
        self.update_rate = 1.0 / p.controlPeriod if p.controlPeriod > 0 else 0.0
        self.last_time = None
        self.e_stop_topic = p.eStopTopic
        self._e_stop = self._last_e_stop = False
        self.ros = None
        if self.world.ros_enabled:
            from .ros_api import ControllerManagerRos
            self.ros = ControllerManagerRos(self)
            self.set_pid_gains(self.ros.get_param(self.resolve('gazebo_ros_control/pid_gains')))

    def set_pid_gains(self, gains):
        """PID gains per joint (see RobotHWSim.set_pid_gains); the joints that have them."""
        return self.hw.set_pid_gains(gains, where=self.resolve('gazebo_ros_control/pid_gains'),
                                     log=self.world.log)

    def e_stop(self, active):
        """The e-stop on (True) or off: takes effect at the next control update."""
        self._e_stop = bool(active)

    def ros_names(self):
        from .ros_api import SERVICES
        return set(self.resolve('controller_manager/' + s) for s in SERVICES)

    def update(self, sim_time):
        dt = self.world.step_size if self.last_time is None else sim_time - self.last_time
        self.last_time = sim_time
        active = self._e_stop
        reset = self._last_e_stop and not active       # released: controllers start again
        self._last_e_stop = active
        self.hw.e_stop = active
        self.manager.update(sim_time, dt, reset=reset)

    def spawn(self, name, params):
        """Load and start a controller now (the spawner's work)."""
        return self.manager.spawn(name, params, t=self.world.sim_time)

    def reset(self):
        self.last_time = None
        for c in self.manager.controllers.values():
            if c.running:
                c.starting(self.world.sim_time)

    def shutdown(self):
        self.manager.stop_all(self.world.sim_time)
        if self.ros is not None:
            self.ros.shutdown()
            self.ros = None
