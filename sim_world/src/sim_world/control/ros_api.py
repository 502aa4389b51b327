"""The ROS side of libgazebo_ros_control.so's controller manager (issue 48 part 4), as
controller_manager and ros_controllers serve it, in the plugin's robot namespace ``<ns>``:

Services (this package's copies of controller_manager_msgs, same md5sums):
  ``<ns>/controller_manager/load_controller``   loads ``name`` from the parameters under
      ``<ns>/<name>`` (``type``, ``joint``/``joints``, ``pid``, ``gains``, ``constraints``,
      ``publish_rate``...): ``ok: false`` and one error line naming a wrong or missing one
  ``.../unload_controller``, ``.../switch_controller`` (STRICT or BEST_EFFORT; 0 means
      BEST_EFFORT, as controller_manager does), ``.../list_controllers`` (state
      ``initialized``, ``running`` or ``stopped``; claimed resources per interface),
      ``.../list_controller_types``, ``.../reload_controller_libraries`` (nothing to reload:
      refused while controllers are loaded unless ``force_kill``, which stops and unloads them)

The plugin's ``eStopTopic`` (std_msgs/Bool), when it names one, is subscribed here.

Per controller, made when it loads and gone when it unloads:
  ``joint_state_controller/JointStateController``  publishes ``<ns>/joint_states``
  single-joint controllers  subscribe ``<ns>/<ctrl>/command`` (std_msgs/Float64)
  JointGroup controllers    subscribe ``<ns>/<ctrl>/command`` (std_msgs/Float64MultiArray)
  JointTrajectoryController ``<ns>/<ctrl>/command`` (trajectory_msgs/JointTrajectory),
      ``<ns>/<ctrl>/state`` (control_msgs/JointTrajectoryControllerState), the service
      ``<ns>/<ctrl>/query_state`` and the action ``<ns>/<ctrl>/follow_joint_trajectory``
      (control_msgs/FollowJointTrajectory through actionlib's ActionServer, the transport
      facade's named exception: its status, feedback and result are plain rospy topics)

Services and topics go through sim_world.transport. Every handler takes the world's lock
(a service never sees half a step). Trajectory goals and commands are queued and applied by
the controller at its next update, in the world's step: actionlib calls the goal callback
holding its own lock, which the step takes to answer goals, so nothing here waits for the
world's lock while holding actionlib's.
"""
import logging

from .controllers import BASE_CLASS, ControllerError, _IFACE_NAMES, controller_types
from .trajectory import JointTrajectoryController, Trajectory

__all__ = ['ControllerManagerRos', 'SERVICES']

SERVICES = ('load_controller', 'unload_controller', 'switch_controller', 'list_controllers',
            'list_controller_types', 'reload_controller_libraries')
log = logging.getLogger('sim_world.control')


def _ros_param(name):
    import rospy
    try:
        return rospy.get_param(name)
    except KeyError:
        return None


class ControllerManagerRos(object):
    """The services and per-controller topics of ``plugin`` (a GazeboRosControl: its
    ``manager``, ``world``, ``resolve``). ``serve=False``: the handlers alone (unit tests),
    with ``get_param(name) -> value or None`` in place of the parameter server."""

    def __init__(self, plugin, serve=True, get_param=None):
        self.plugin = plugin
        self.manager = plugin.manager
        self.world = plugin.world
        self.serve = serve
        self.get_param = get_param or _ros_param
        self.handles = {}          # controller name -> [ROS objects to close]
        self.goals = {}            # goal id -> _GoalHandle (trajectory goals being run)
        self.services = []
        if serve:
            self._serve()

    def names(self):
        """The resolved service names (the world's clash check)."""
        return set(self.plugin.resolve('controller_manager/' + s) for s in SERVICES)

    def _serve(self):
        from mobile_device_sim import srv
        from .. import transport
        for s, typ in zip(SERVICES, (srv.LoadController, srv.UnloadController,
                                     srv.SwitchController, srv.ListControllers,
                                     srv.ListControllerTypes, srv.ReloadControllerLibraries)):
            self.services.append(transport.service(
                self.plugin.resolve('controller_manager/' + s), typ, getattr(self, s)))
        self.e_stop_sub = None
        topic = getattr(self.plugin, 'e_stop_topic', '')
        if topic:
            from std_msgs.msg import Bool
            self.e_stop_sub = transport.subscriber(self.plugin.resolve(topic), Bool,
                                                   lambda m: self.plugin.e_stop(m.data),
                                                   queue_size=1)

    # -- controller_manager's services --------------------------------------------------------
    def load_controller(self, req):
        from mobile_device_sim.srv import LoadControllerResponse
        name = (req.name or '').strip('/')
        params = self.get_param(self.plugin.resolve(name)) if name else None
        with self.world.lock:
            ok, msg = self.manager.load_controller(name, params)
            if ok:
                try:
                    self._open(name)
                except Exception as e:  # noqa: BLE001 - one line, the controller goes again
                    log.error('controller_manager: %s: cannot make its ROS interfaces: %s: %s',
                              name, type(e).__name__, e)
                    self._close(name)
                    self.manager.unload_controller(name)
                    ok = False
        return LoadControllerResponse(ok=ok)

    def unload_controller(self, req):
        from mobile_device_sim.srv import UnloadControllerResponse
        name = (req.name or '').strip('/')
        with self.world.lock:
            ok, _ = self.manager.unload_controller(name)
            if ok:
                self._close(name)
        return UnloadControllerResponse(ok=ok)

    def switch_controller(self, req):
        from mobile_device_sim.srv import SwitchControllerRequest, SwitchControllerResponse
        strict = req.strictness == SwitchControllerRequest.STRICT
        if req.strictness not in (0, SwitchControllerRequest.STRICT,
                                  SwitchControllerRequest.BEST_EFFORT):
            log.error('controller_manager: switch_controller: strictness %d is neither '
                      'BEST_EFFORT (1) nor STRICT (2)', req.strictness)
            return SwitchControllerResponse(ok=False)
        with self.world.lock:
            ok, _ = self.manager.switch_controller(
                start=[n.strip('/') for n in req.start_controllers],
                stop=[n.strip('/') for n in req.stop_controllers],
                t=self.world.sim_time, strict=strict)
        return SwitchControllerResponse(ok=ok)

    def list_controllers(self, req=None):
        from mobile_device_sim.msg import ControllerState, HardwareInterfaceResources
        from mobile_device_sim.srv import ListControllersResponse
        out = []
        with self.world.lock:
            for name, c in sorted(self.manager.controllers.items()):
                iface = 'hardware_interface::' + (_IFACE_NAMES[c.INTERFACE] if c.INTERFACE
                                                  else 'JointStateInterface')
                out.append(ControllerState(
                    name=name, state=c.state, type=c.TYPE,
                    claimed_resources=[HardwareInterfaceResources(
                        hardware_interface=iface, resources=list(c.claimed()))]))
        return ListControllersResponse(controller=out)

    def list_controller_types(self, req=None):
        from mobile_device_sim.srv import ListControllerTypesResponse
        types = sorted(controller_types())
        return ListControllerTypesResponse(types=types, base_classes=[BASE_CLASS] * len(types))

    def reload_controller_libraries(self, req):
        from mobile_device_sim.srv import ReloadControllerLibrariesResponse
        with self.world.lock:
            loaded = sorted(self.manager.controllers)
            if loaded and not req.force_kill:
                log.error('controller_manager: reload_controller_libraries: controllers are '
                          'still loaded (%s); call with force_kill: true to stop and unload '
                          'them', ', '.join(loaded))
                return ReloadControllerLibrariesResponse(ok=False)
            self.manager.switch_controller(stop=loaded, t=self.world.sim_time, strict=False)
            for n in loaded:
                self.manager.unload_controller(n)
                self._close(n)
        return ReloadControllerLibrariesResponse(ok=True)

    # -- per-controller interfaces ----------------------------------------------------------------
    def _open(self, name):
        c = self.manager.controllers[name]
        c.state = 'initialized'
        self.handles[name] = []
        if isinstance(c, JointTrajectoryController):
            c.on_state = lambda st, name=name: self.publish_state(name, st)
        elif c.TYPE == 'joint_state_controller/JointStateController':
            c.publish = lambda sample, name=name: self.publish_joint_states(name, sample)
        if not self.serve:
            return
        from .. import transport
        keep = self.handles[name]
        res = self.plugin.resolve
        if isinstance(c, JointTrajectoryController):
            import actionlib
            from mobile_device_sim.msg import (FollowJointTrajectoryAction,
                                               JointTrajectoryControllerState)
            from mobile_device_sim.srv import QueryTrajectoryState
            from trajectory_msgs.msg import JointTrajectory
            keep.append(transport.subscriber(res(name + '/command'), JointTrajectory,
                                             lambda m, name=name: self.trajectory_cb(name, m),
                                             queue_size=1))
            c.state_pub = transport.publisher(res(name + '/state'),
                                              JointTrajectoryControllerState, queue_size=1)
            keep.append(c.state_pub)
            keep.append(transport.service(res(name + '/query_state'), QueryTrajectoryState,
                                          lambda r, name=name: self.query_state(name, r)))
            server = actionlib.ActionServer(
                res(name + '/follow_joint_trajectory'), FollowJointTrajectoryAction,
                lambda gh, name=name: self.goal_cb(name, gh),
                lambda gh, name=name: self.cancel_cb(name, gh), auto_start=False)
            server.start()
            keep.append(server)
        elif c.TYPE == 'joint_state_controller/JointStateController':
            from sensor_msgs.msg import JointState
            c.pub = transport.publisher(res('joint_states'), JointState, queue_size=10)
            keep.append(c.pub)
        elif hasattr(c, 'set_command'):
            from std_msgs.msg import Float64, Float64MultiArray
            typ = Float64MultiArray if c.GROUP else Float64
            keep.append(transport.subscriber(res(name + '/command'), typ,
                                             lambda m, name=name: self.command_cb(name, m),
                                             queue_size=1))

    def _close(self, name):
        for h in self.handles.pop(name, []):
            try:
                if hasattr(h, 'stop') and hasattr(h, 'status_pub'):   # an ActionServer
                    h.stop()
                elif hasattr(h, 'unregister'):
                    h.unregister()
                elif hasattr(h, 'shutdown'):
                    h.shutdown()
            except Exception as e:  # noqa: BLE001 - closing must go on with the others
                log.warning('controller_manager: %s: closing %r: %s', name, h, e)
        for gid, g in list(self.goals.items()):
            if g.controller == name:
                del self.goals[gid]

    def shutdown(self):
        for name in list(self.handles):
            self._close(name)
        for s in self.services:
            s.shutdown()
        self.services = []
        if getattr(self, 'e_stop_sub', None) is not None:
            self.e_stop_sub.unregister()
            self.e_stop_sub = None

    # -- topics in -------------------------------------------------------------------------------
    def command_cb(self, name, msg):
        """std_msgs/Float64 or Float64MultiArray on <ctrl>/command."""
        with self.world.lock:
            self.manager.set_command(name, msg.data)

    def trajectory_cb(self, name, msg):
        c = self.manager.controllers.get(name)
        if c is not None:
            c.submit_command(Trajectory.from_msg(msg))

    # -- topics out --------------------------------------------------------------------------
    def publish_joint_states(self, name, sample):
        c = self.manager.controllers.get(name)
        pub = getattr(c, 'pub', None)
        if pub is None:
            return
        from sensor_msgs.msg import JointState
        t, names, pos, vel, eff = sample
        msg = JointState(name=names, position=pos, velocity=vel, effort=eff)
        msg.header.stamp = self.world.ros_now()
        pub.publish(msg)

    def publish_state(self, name, st):
        c = self.manager.controllers.get(name)
        pub = getattr(c, 'state_pub', None)
        if pub is None:
            return
        from mobile_device_sim.msg import JointTrajectoryControllerState
        msg = JointTrajectoryControllerState()
        msg.header.stamp = self.world.ros_now()
        _fill(msg, st)
        pub.publish(msg)

    # -- query_state and the action ----------------------------------------------------------
    def query_state(self, name, req):
        import rospy
        from mobile_device_sim.srv import QueryTrajectoryStateResponse
        with self.world.lock:
            c = self.manager.controllers.get(name)
            try:
                if c is None:
                    raise ControllerError('%s is not loaded' % name)
                names, p, v, a = c.query_state(req.time.to_sec())
            except ControllerError as e:
                log.error('controller_manager: query_state: %s', e)
                raise rospy.ServiceException(str(e))
        return QueryTrajectoryStateResponse(name=names, position=p, velocity=v, acceleration=a)

    def goal_cb(self, name, gh):
        """actionlib's goal callback (it holds actionlib's lock): queued for the controller."""
        c = self.manager.controllers.get(name)
        goal = gh.get_goal()
        handle = _GoalHandle(gh, name, self.world.ros_now)
        if c is None:
            handle.reject(-1, '%s is not loaded' % name)
            return
        self.goals[gh.get_goal_id().id] = handle
        tol = lambda entries: [(e.name, e.position, e.velocity, e.acceleration)  # noqa: E731
                               for e in entries]
        c.submit_goal(Trajectory.from_msg(goal.trajectory), handle,
                      tol(goal.path_tolerance), tol(goal.goal_tolerance),
                      goal.goal_time_tolerance.to_sec())

    def cancel_cb(self, name, gh):
        c = self.manager.controllers.get(name)
        handle = self.goals.get(gh.get_goal_id().id)
        if c is not None and handle is not None:
            c.submit_cancel(handle)


def _point(pos, vel=None, acc=None):
    from trajectory_msgs.msg import JointTrajectoryPoint
    return JointTrajectoryPoint(positions=list(pos), velocities=list(vel or []),
                                accelerations=list(acc or []))


def _fill(msg, st):
    """A JointTrajectoryControllerState / FollowJointTrajectoryFeedback from a state dict."""
    msg.joint_names = list(st['joint_names'])
    msg.desired = _point(*st['desired'])
    msg.actual = _point(*st['actual'])
    msg.error = _point(*st['error'])
    return msg


class _GoalHandle(object):
    """The trajectory controller's goal handle over actionlib's ServerGoalHandle."""

    def __init__(self, gh, controller, stamp=None):
        self.gh, self.controller = gh, controller
        self.stamp = stamp

    def _result(self, code, text):
        from mobile_device_sim.msg import FollowJointTrajectoryResult
        return FollowJointTrajectoryResult(error_code=code, error_string=text)

    def accept(self):
        self.gh.set_accepted()

    def reject(self, code, text):
        self.gh.set_rejected(self._result(code, text), text)

    def succeed(self, code, text):
        self.gh.set_succeeded(self._result(code, text), text)

    def abort(self, code, text):
        self.gh.set_aborted(self._result(code, text), text)

    def cancel(self):
        self.gh.set_canceled(self._result(0, ''), 'canceled')

    def feedback(self, st):
        from mobile_device_sim.msg import FollowJointTrajectoryFeedback
        fb = _fill(FollowJointTrajectoryFeedback(), st)
        fb.header.stamp = self.stamp()
        self.gh.publish_feedback(fb)
