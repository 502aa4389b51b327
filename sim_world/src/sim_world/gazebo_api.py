"""The Gazebo-compatible ROS API of sim_world, and its run loop.

Services (gazebo_msgs-compatible types from this package, same md5sums):
  /gazebo/get_model_state  /gazebo/set_model_state  /gazebo/spawn_urdf_model
  /gazebo/spawn_sdf_model  /gazebo/delete_model     /gazebo/pause_physics
  /gazebo/unpause_physics  /gazebo/reset_world      /gazebo/reset_simulation
  /gazebo/step_world (mobile_device_sim/StepWorld: run until a sim time, then pause; the
  testing instance's lockstep)
  /gazebo/get_physics_properties  /gazebo/set_physics_properties (the pace as
  max_update_rate, gravity, ODE's solver: sim_world.physics_api)
  /gazebo/get_model_description (mobile_device_sim/GetModelDescription: the URDF or SDF a
  model was spawned from, or its world file's <model>; the studio draws late models by it)
Topics: /clock, /gazebo/model_states, /gazebo/set_model_state (subscriber), /tf, /tf_static.

Every service answers ``success: false`` with a ``status_message`` naming the bad input
and logs one line; the world keeps running with its models.
"""
from collections import OrderedDict
import math
import threading
import time

import rospy
from geometry_msgs.msg import Pose as PoseMsg
from geometry_msgs.msg import TransformStamped, Twist
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Empty, EmptyResponse
from tf2_msgs.msg import TFMessage

from mobile_device_sim.msg import ModelState, ModelStates
from mobile_device_sim.srv import (DeleteModel, DeleteModelResponse, GetModelDescription,
                                   GetModelDescriptionResponse, GetModelState,
                                   GetModelStateResponse, SetModelState, SetModelStateResponse,
                                   SpawnModel, SpawnModelResponse, StepWorld,
                                   StepWorldResponse)

from . import srvcheck, transport
from .model import ModelError
from .spawn import model_description, spawn_xml
from .transforms import InvalidPose

__all__ = ['GazeboRosApi', 'run_loop', 'tf_frame']


def _twist_msg(lin, ang):
    t = Twist()
    t.linear.x, t.linear.y, t.linear.z = (float(x) for x in lin)
    t.angular.x, t.angular.y, t.angular.z = (float(x) for x in ang)
    return t


def tf_frame(model, link):
    """tf frame of a link: the link name for URDF robots (prefixed with the robot namespace
    if spawned in one), '<model>/<link>' for world-file models."""
    prefix = model.tf_prefix
    if prefix is None:
        prefix = model.robot_namespace.strip('/')
    return '%s/%s' % (prefix, link) if prefix else link


def _transform(parent, child, pose, stamp):
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = \
        (float(v) for v in pose.p)
    (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
     t.transform.rotation.w) = (float(v) for v in pose.q)
    return t


class GazeboRosApi(object):
    def __init__(self, world, paused=False):
        # a client that connects and sends no header must not stall this node's other
        # connections (rospy reads headers in its accept loop; sim_world.transport.tcpros_guard)
        transport.guard_handshakes()
        self.world = world
        # messages without header stamps are timed by the sim time they went out at, for
        # step_world's callers (the testing instance times them by it, not by arrival)
        transport.set_sim_clock(lambda: self.world.sim_time)
        # before any subscriber connects: rospy hands each connection's receive thread the
        # subscriber's receive_callback as it is then (a bound method), so a gate installed
        # later would not hold the inputs of the connections made before
        transport.install_gate()
        self.paused = paused
        self.reset_anchor = threading.Event()   # tells the run loop to re-anchor pacing
        self.step_until = None                   # step_world: pause at this sim time
        self.real_time_factor = None             # the pace (run_loop's; set_physics_properties)
        self.step_done = threading.Event()
        self._get_seq = 0
        self._last_tf_stamp = None
        self._static_tf = {}
        # /clock goes out before every plugin tick: queued without rospy's per-message GIL
        # yield (sim_world.transport), which cost the world thread more than the message itself;
        # this node's own /clock subscriber (use_sim_time) is called directly
        self.clock_pub = transport.publisher('/clock', Clock, queue_size=10, inline_local=True)
        self.states_pub = transport.publisher('/gazebo/model_states', ModelStates, queue_size=1)
        self.tf_pub = transport.publisher('/tf', TFMessage, queue_size=100)
        self.tf_static_pub = transport.publisher('/tf_static', TFMessage, queue_size=100,
                                                 latch=True)
        self._last_clock = None
        self.spawned = OrderedDict()     # model name -> its SpawnModel request (reload_world)
        self.attach(world)
        self.services = [
            transport.service('/gazebo/get_model_state', GetModelState, self.get_model_state),
            transport.service('/gazebo/set_model_state', SetModelState, self.set_model_state),
            transport.service('/gazebo/spawn_urdf_model', SpawnModel, self.spawn_urdf_model),
            transport.service('/gazebo/spawn_sdf_model', SpawnModel, self.spawn_sdf_model),
            transport.service('/gazebo/delete_model', DeleteModel, self.delete_model),
            transport.service('/gazebo/get_model_description', GetModelDescription,
                              self.get_model_description),
            transport.service('/gazebo/pause_physics', Empty, self.pause),
            transport.service('/gazebo/unpause_physics', Empty, self.unpause),
            transport.service('/gazebo/reset_world', Empty, self.reset_world),
            transport.service('/gazebo/reset_simulation', Empty, self.reset_simulation),
            transport.service('/gazebo/step_world', StepWorld, self.step_world),
        ]
        self.set_sub = transport.subscriber('/gazebo/set_model_state', ModelState,
                                            self._set_state_topic, queue_size=100)
        from .joint_api import JointRosApi     # joint and link services (issue 48)
        self.joint_api = JointRosApi(self)
        from .attacher import LinkAttacher      # /gazebo/attach, /gazebo/detach
        self.attacher = LinkAttacher(self)
        from .physics_api import PhysicsRosApi  # /gazebo/{get,set}_physics_properties
        self.physics_api = PhysicsRosApi(self)

    def attach(self, world, spawned=None):
        """Serve ``world`` from now on (sim_world's /gazebo/reload_world swaps in a new one;
        the services and topics stay, the state kept for the old world goes). ``spawned``:
        the SpawnModel requests that made its spawned models."""
        self.world = world
        self.step_until = None
        self._last_clock = None
        self._last_tf_stamp = None
        self._static_tf = {}
        self.spawned = OrderedDict(spawned or ())
        # /clock goes out right before sensors publish, so a subscriber's rospy time is the
        # frame's stamp when the frame arrives (rostest's hztest measures rates that way)
        world.before_plugin_updates.append(lambda t: self.publish_clock())
        world.on_model_added.append(self._model_added)
        world.on_model_deleted.append(self._model_deleted)
        for m in world.models.values():
            self._model_added(m)

    # -- services --------------------------------------------------------------------------
    # Each handler checks its request's values with sim_world.srvcheck; srvcheck.answers
    # turns a refusal (and any bug) into success: false and one log line, never a traceback.
    @srvcheck.answers(GetModelStateResponse, 'GetModelState', log='warn')
    def get_model_state(self, req):
        res = GetModelStateResponse()
        self._get_seq += 1
        res.header.seq = self._get_seq
        res.header.frame_id = req.relative_entity_name
        with self.world.lock:
            res.header.stamp = self.world.ros_now()
            try:
                pose, lin, ang = self.world.get_state(req.model_name, req.relative_entity_name)
            except KeyError as e:
                res.success = False
                res.status_message = srvcheck.one_line('GetModelState: %s' % e.args[0])
                rospy.logwarn(res.status_message)
                return res
        res.pose = pose.to_msg()
        res.twist = _twist_msg(lin, ang)
        res.success = True
        res.status_message = 'GetModelState: got properties'
        return res

    def _apply_state(self, state):
        """(success, status message) of setting a ModelState (the service and the topic)."""
        try:
            # a pose beyond MAX_POSITION, a spin of 1e300 rad/s: ODE aborts the process
            pose = srvcheck.pose(state.pose, 'pose')
            lin, ang = srvcheck.twist(state.twist, 'twist')
        except srvcheck.BadRequest as e:
            return False, srvcheck.one_line('SetModelState: refusing state of model %r: %s'
                                            % (state.model_name, e))
        try:
            with self.world.lock:
                self.world.set_state(state.model_name, pose, lin, ang, state.reference_frame)
        except KeyError as e:
            return False, srvcheck.one_line('SetModelState: %s' % e.args[0])
        except (InvalidPose, ModelError) as e:
            return False, srvcheck.one_line('SetModelState: model %r: %s' % (state.model_name, e))
        return True, 'SetModelState: set model state done'

    @srvcheck.answers(SetModelStateResponse, 'SetModelState', log='warn')
    def set_model_state(self, req):
        ok, msg = self._apply_state(req.model_state)
        if not ok:
            rospy.logwarn(msg)
        return SetModelStateResponse(ok, msg)

    def _set_state_topic(self, state):
        try:
            ok, msg = self._apply_state(state)
        except Exception as e:  # noqa: BLE001 - a bug: one line, the subscriber goes on
            ok, msg = False, srvcheck.one_line('SetModelState: internal error: %s: %s'
                                               % (type(e).__name__, e))
        if not ok:
            rospy.logwarn(msg)

    def _spawn(self, req, kind):
        try:
            srvcheck.ros_namespace(req.robot_namespace)
        except srvcheck.BadRequest as e:
            raise srvcheck.BadRequest('model %r not spawned: %s' % (req.model_name, e))
        ok, msg = spawn_xml(self.world, kind, req.model_name, req.model_xml,
                            req.robot_namespace, req.initial_pose, req.reference_frame)
        if not ok:
            rospy.logerr(msg)
            return SpawnModelResponse(False, msg)
        model = self.world.models.get(req.model_name)
        self.spawned[req.model_name] = (kind, req)
        if model is not None:
            rospy.loginfo('spawned model %s (%d links, %d plugins)', model.name,
                          len(model.links), len(model.plugins))
        return SpawnModelResponse(True, msg)

    @srvcheck.answers(SpawnModelResponse, 'SpawnModel')
    def spawn_urdf_model(self, req):
        return self._spawn(req, 'urdf')

    @srvcheck.answers(SpawnModelResponse, 'SpawnModel')
    def spawn_sdf_model(self, req):
        return self._spawn(req, 'sdf')

    @srvcheck.answers(DeleteModelResponse, 'DeleteModel', log='warn')
    def delete_model(self, req):
        try:
            with self.world.lock:
                self.world.delete_model(req.model_name)
            self.spawned.pop(req.model_name, None)
        except KeyError as e:
            msg = srvcheck.one_line('DeleteModel: %s' % e.args[0])
            rospy.logwarn(msg)
            return DeleteModelResponse(False, msg)
        return DeleteModelResponse(True, 'DeleteModel: successfully deleted model')

    @srvcheck.answers(GetModelDescriptionResponse, 'GetModelDescription', log='warn')
    def get_model_description(self, req):
        """The description a model was made from (sim_world.spawn.model_description): a
        spawned model's request, a world-file model's <model> element."""
        res = GetModelDescriptionResponse(*model_description(self.world, req.model_name,
                                                             self.spawned))
        if not res.success:
            rospy.logwarn(res.status_message)
        return res

    @srvcheck.answers(EmptyResponse, 'pause_physics')
    def pause(self, _req):
        self.paused = True
        return EmptyResponse()

    @srvcheck.answers(EmptyResponse, 'unpause_physics')
    def unpause(self, _req):
        if transport.holding():             # a pipelined runner's last slice: the world runs
            transport.release(stop=True)
        self.paused = False
        self.reset_anchor.set()
        return EmptyResponse()

    @srvcheck.answers(StepWorldResponse, 'StepWorld',
                      fill=lambda self: dict(sim_time=self.world.sim_time))
    def step_world(self, req):
        """Run until sim time req.until (the first step at or after it), then pause."""
        if self.step_until is not None:
            raise srvcheck.BadRequest('another step_world call is running')
        # a step to 1e300 s would never end, and hold every other call to the world meanwhile
        until = srvcheck.sim_time(req.until, 'until')
        with self.world.lock:
            # a camera subscribed since the last step makes the renderer now, outside the
            # step: the runner's step to the current time before its timeline does it
            self.world.prepare_renderer()
        steps = until > self.world.sim_time + 0.5 * self.world.step_size
        if steps:
            # what other nodes send (an app's answer, a service call) waits for the step's
            # end: it lands at a slice boundary however fast the app is (the transport's gate)
            transport.close_gate()
        if getattr(req, 'pipeline', False):
            if steps:
                # the apps get the last slice now and work on it while this one runs
                transport.release()
                transport.hold(keep=(req.subscriber,) if req.subscriber else ())
        elif transport.holding():
            transport.release(stop=True)
        self.step_done.clear()
        self.step_until = until
        self.paused = False
        self.reset_anchor.set()
        try:
            while not self.step_done.wait(0.1):
                if rospy.is_shutdown():
                    break
        finally:
            transport.reopen_gate()
        self.step_until = None
        # the slice's messages to remote subscribers are in their sockets before the answer:
        # an app that looks idle then has answered (testing_instance.world.appwatch's evidence)
        counts, times = transport.slice_report(req.subscriber)
        topics = sorted(counts)
        timed = sorted(times)
        return StepWorldResponse(True, 'StepWorld: paused at %.6f' % self.world.sim_time,
                                 self.world.sim_time, topics, [counts[t][0] for t in topics],
                                 [counts[t][1] for t in topics], timed,
                                 [len(times[t]) for t in timed],
                                 [x for t in timed for x in times[t]])

    def _step_reached(self):
        """Run-loop side of step_world: pause once sim time reached the target."""
        until = self.step_until
        if until is not None and not self.step_done.is_set() and \
                self.world.sim_time + 0.5 * self.world.step_size >= until:
            self.world.flush()          # the slice's camera frames are out before it ends
            self.paused = True
            self.publish()
            self.step_done.set()
            return True
        return False

    @srvcheck.answers(EmptyResponse, 'reset_world')
    def reset_world(self, _req):
        self.world.reset(time=False)
        self.reset_anchor.set()
        return EmptyResponse()

    @srvcheck.answers(EmptyResponse, 'reset_simulation')
    def reset_simulation(self, _req):
        self.world.reset(time=True)
        self.reset_anchor.set()
        return EmptyResponse()

    # -- topics ----------------------------------------------------------------------------
    def _model_added(self, model):
        if model.tf_prefix is None and model.static:
            model.tf_prefix = model.name
        stamp = self.world.ros_now()
        for j in model.joints:
            if j.movable and not model.static:
                continue     # movable joints: joint_states + robot_state_publisher
            self._static_tf[(model.name, j.child)] = _transform(
                tf_frame(model, j.parent), tf_frame(model, j.child), j.origin, stamp)
        if model.static:
            self._static_tf[(model.name, model.root_link)] = _transform(
                'world', tf_frame(model, model.root_link), model.pose, stamp)
        self.tf_static_pub.publish(TFMessage(list(self._static_tf.values())))

    def _model_deleted(self, name):
        for k in [k for k in self._static_tf if k[0] == name]:
            del self._static_tf[k]
        self.tf_static_pub.publish(TFMessage(list(self._static_tf.values())))

    def publish_clock(self, stamp=None, repeat=False):
        """Publish /clock; ``repeat`` sends it even when sim time has not moved (paused)."""
        stamp = stamp if stamp is not None else self.world.ros_now()
        if repeat or stamp != self._last_clock:
            self._last_clock = stamp
            self.clock_pub.publish(Clock(stamp))

    def publish(self):
        """Publish /clock, /gazebo/model_states and /tf of the dynamic models' roots. The
        states and transforms are only gathered while someone subscribes to them; /clock is
        repeated unchanged only while paused (it goes out with every plugin tick anyway)."""
        w = self.world
        want_states = self.states_pub.get_num_connections() > 0
        want_tf = self.tf_pub.get_num_connections() > 0
        with w.lock:
            stamp = w.ros_now()
            states = ModelStates()
            tfs = []
            if want_states or (want_tf and stamp != self._last_tf_stamp):
                for name, model in w.models.items():
                    pose, lin, ang = w.model_state(name)
                    if want_states:
                        states.name.append(name)
                        states.pose.append(pose.to_msg(PoseMsg()))
                        states.twist.append(_twist_msg(lin, ang))
                    if want_tf and not model.static and \
                            tf_frame(model, model.root_link) != 'world':   # welded robots
                        tfs.append(_transform('world', tf_frame(model, model.root_link), pose,
                                              stamp))
        self.publish_clock(stamp, repeat=bool(self.paused))
        if want_states:
            self.states_pub.publish(states)
        if tfs and stamp != self._last_tf_stamp:   # tf2 rejects repeated stamps (paused)
            self._last_tf_stamp = stamp
            self.tf_pub.publish(TFMessage(tfs))
        self.joint_api.publish()


def run_loop(world, api, real_time_factor=1.0, publish_rate=100.0, batch_seconds=0.005,
             should_stop=None):
    """Step the world until ROS shuts down, paced to ``real_time_factor`` (0 = as fast as
    possible; ``api.real_time_factor`` from then on, which /gazebo/set_physics_properties
    changes), publishing the API's topics at ``publish_rate`` Hz of wall time."""
    should_stop = should_stop or rospy.is_shutdown
    mono = time.monotonic
    rtf = api.real_time_factor = float(real_time_factor)
    wall0, sim0 = mono(), world.sim_time
    next_pub = wall0
    pub_period = 1.0 / publish_rate if publish_rate > 0 else math.inf
    while not should_stop():
        now = mono()
        if api.reset_anchor.is_set():
            api.reset_anchor.clear()
            wall0, sim0 = now, world.sim_time
            rtf = api.real_time_factor
        if api.step_until is not None and api._step_reached():
            continue
        if api.paused:
            world.flush()
            if now >= next_pub:
                api.publish()
                next_pub = now + max(pub_period, 0.1)
            # step_world, unpause and a reload wake it at once; otherwise it sleeps until the
            # next paused publish (no 10 ms ticks: the app watch counts a world node's thread
            # that ran between two looks as busy)
            api.reset_anchor.wait(min(0.1, max(0.0, next_pub - mono())))
            wall0, sim0 = mono(), world.sim_time
            continue
        stop = api.step_until
        stop = math.inf if stop is None else stop - 0.5 * world.step_size
        with world.lock:
            end = now + batch_seconds
            if rtf > 0:
                target_sim = min(sim0 + (end - wall0) * rtf, stop)
                while world.sim_time < target_sim and mono() < end:
                    world.step(wait=False)
            else:
                while world.sim_time < stop and mono() < end:
                    world.step(wait=False)
        now = mono()
        if now >= next_pub:
            api.publish()
            next_pub = max(next_pub + pub_period, now)
        if rtf > 0:
            ahead = (world.sim_time - sim0) / rtf - (now - wall0)
            if ahead > 0:
                time.sleep(min(ahead, 0.02))
            elif ahead < -1.0:
                wall0, sim0 = now, world.sim_time   # fell far behind: do not try to catch up
