"""Gazebo's ROS API for joints and links (issue 48), served next to sim_world.gazebo_api.

Services (this package's copies of the gazebo_msgs definitions, same md5sums):
  /gazebo/get_joint_properties   the real joint type (REVOLUTE, CONTINUOUS, PRISMATIC,
                                 FIXED), damping, position, rate
  /gazebo/set_joint_properties   ode_joint_config: damping[0] -> viscous damping,
                                 fmax[0] -> Coulomb friction (the velocity-0 motor's force);
                                 other fields refused by name
  /gazebo/apply_joint_effort     effort from start_time (past: now) for duration (< 0:
                                 until cleared; 0: nothing), through the joint's limits
  /gazebo/clear_joint_forces     (JointRequest) drops the efforts applied to a joint
  /gazebo/set_model_configuration  joint positions, velocities zero, root link kept
  /gazebo/get_model_properties   body (link), geom (collision) and simulated joint names
  /gazebo/get_link_state, /gazebo/set_link_state (the root link only: it moves the
                                 model), /gazebo/get_link_properties
Topic: /gazebo/link_states (every link of every model, world frame), published with
/gazebo/model_states while someone subscribes.

Joint names: ``model::joint`` or a joint name unique in the world. Bad input answers
``success: false`` with a ``status_message`` naming the joint, link or model, and logs one
line; the world keeps running.
"""
import rospy
from geometry_msgs.msg import Pose as PoseMsg

from mobile_device_sim.msg import LinkState, LinkStates
from mobile_device_sim.srv import (ApplyJointEffort, ApplyJointEffortResponse,
                                   GetJointProperties, GetJointPropertiesResponse,
                                   GetLinkProperties, GetLinkPropertiesResponse, GetLinkState,
                                   GetLinkStateResponse, GetModelProperties,
                                   GetModelPropertiesResponse, JointRequest,
                                   JointRequestResponse, SetJointProperties,
                                   SetJointPropertiesResponse, SetLinkState,
                                   SetLinkStateResponse, SetModelConfiguration,
                                   SetModelConfigurationResponse)

from . import srvcheck, transport
from .transforms import InvalidPose

__all__ = ['JointRosApi', 'find_joint', 'find_link']

JOINT_TYPES = {'revolute': GetJointPropertiesResponse.REVOLUTE,
               'continuous': GetJointPropertiesResponse.CONTINUOUS,
               'prismatic': GetJointPropertiesResponse.PRISMATIC,
               'fixed': GetJointPropertiesResponse.FIXED}
WORLD_FRAMES = ('', 'world', 'map')


def find_joint(world, name):
    """(model name, Joint) of ``model::joint`` or of a joint name unique in the world;
    KeyError with a sentence naming it otherwise."""
    name = (name or '').strip()
    if not name:
        raise KeyError('no joint name given')
    if '::' in name:
        mname, jname = name.split('::', 1)
        model = world.models.get(mname)
        if model is None:
            raise KeyError('joint %r: no model named %r' % (name, mname))
        for j in model.joints:
            if j.name == jname:
                return mname, j
        raise KeyError('model %r has no joint %r' % (mname, jname))
    owners = [(m.name, j) for m in world.models.values() for j in m.joints if j.name == name]
    if not owners:
        raise KeyError('no joint named %r in the world' % name)
    if len(owners) > 1:
        raise KeyError('joint name %r is ambiguous (models %s): use model::joint'
                       % (name, ', '.join(o[0] for o in owners)))
    return owners[0]


def find_link(world, name):
    """(model name, link name) of ``model::link`` or of a link name unique in the world."""
    name = (name or '').strip()
    if '::' in name:
        mname, lname = name.split('::', 1)
        model = world.models.get(mname)
        if model is None:
            raise KeyError('link %r: no model named %r' % (name, mname))
        if lname not in model.links:
            raise KeyError('model %r has no link %r' % (mname, lname))
        return mname, lname
    owners = [m.name for m in world.models.values() if name in m.links]
    if not owners:
        raise KeyError('no link named %r in the world' % name)
    if len(owners) > 1:
        raise KeyError('link name %r is ambiguous (models %s): use model::link'
                       % (name, ', '.join(owners)))
    return owners[0], name


def _simulated(world, mname, jname):
    return jname in world.physics.joint_names(mname) if world.physics.has_model(mname) \
        else False


def _twist_msg(msg, lin, ang):
    msg.linear.x, msg.linear.y, msg.linear.z = (float(x) for x in lin)
    msg.angular.x, msg.angular.y, msg.angular.z = (float(x) for x in ang)
    return msg


class JointRosApi(object):
    """The joint and link services and /gazebo/link_states of ``api`` (a GazeboRosApi:
    its ``world`` is read at each call, so /gazebo/reload_world's new world is served)."""

    def __init__(self, api, serve=True):
        self.api = api
        self.services = []
        self.link_states_pub = None
        if serve:       # serve=False: the handlers alone (unit tests)
            self._serve()

    def _serve(self):
        self.link_states_pub = transport.publisher('/gazebo/link_states', LinkStates,
                                                   queue_size=1)
        self.services = [
            transport.service('/gazebo/get_joint_properties', GetJointProperties,
                              self.get_joint_properties),
            transport.service('/gazebo/set_joint_properties', SetJointProperties,
                              self.set_joint_properties),
            transport.service('/gazebo/apply_joint_effort', ApplyJointEffort,
                              self.apply_joint_effort),
            transport.service('/gazebo/clear_joint_forces', JointRequest,
                              self.clear_joint_forces),
            transport.service('/gazebo/set_model_configuration', SetModelConfiguration,
                              self.set_model_configuration),
            transport.service('/gazebo/get_model_properties', GetModelProperties,
                              self.get_model_properties),
            transport.service('/gazebo/get_link_state', GetLinkState, self.get_link_state),
            transport.service('/gazebo/set_link_state', SetLinkState, self.set_link_state),
            transport.service('/gazebo/get_link_properties', GetLinkProperties,
                              self.get_link_properties),
        ]

    @property
    def world(self):
        return self.api.world

    @staticmethod
    def _fail(res, what, text):
        res.success = False
        res.status_message = srvcheck.one_line('%s: %s' % (what, text))
        rospy.logwarn(res.status_message)
        return res

    # -- joints ----------------------------------------------------------------------------
    @srvcheck.answers(GetJointPropertiesResponse, 'GetJointProperties', log='warn')
    def get_joint_properties(self, req):
        res = GetJointPropertiesResponse()
        w = self.world
        with w.lock:
            try:
                mname, j = find_joint(w, req.joint_name)
            except KeyError as e:
                return self._fail(res, 'GetJointProperties', e.args[0])
            res.type = JOINT_TYPES.get(j.type, GetJointPropertiesResponse.FIXED)
            if j.movable:
                damping = j.damping
                pos, vel = 0.0, 0.0
                if _simulated(w, mname, j.name):
                    pos, vel = w.physics.joint_state(mname, j.name)
                    damping = w.physics._joint_of(mname, j.name)[1].damping
                res.damping = [float(damping)]
                res.position = [float(pos)]
                res.rate = [float(vel)]
        res.success = True
        res.status_message = 'GetJointProperties: got properties'
        return res

    @srvcheck.answers(SetJointPropertiesResponse, 'SetJointProperties', log='warn')
    def set_joint_properties(self, req):
        res = SetJointPropertiesResponse()
        c = req.ode_joint_config
        w = self.world
        with w.lock:
            try:
                mname, j = find_joint(w, req.joint_name)
            except KeyError as e:
                return self._fail(res, 'SetJointProperties', e.args[0])
            if not _simulated(w, mname, j.name) or not j.movable:
                return self._fail(res, 'SetJointProperties', 'joint %r of model %r is not a '
                                  'simulated movable joint' % (j.name, mname))
            for field in ('hiStop', 'loStop', 'erp', 'cfm', 'stop_erp', 'stop_cfm',
                          'fudge_factor', 'vel'):
                if len(getattr(c, field)):
                    return self._fail(res, 'SetJointProperties', 'joint %r: %s is not '
                                      'supported (damping and fmax are)' % (j.name, field))
            try:
                w.physics.set_joint_dynamics(
                    mname, j.name, damping=c.damping[0] if len(c.damping) else None,
                    friction=c.fmax[0] if len(c.fmax) else None)
            except (KeyError, ValueError) as e:
                return self._fail(res, 'SetJointProperties', str(e.args[0]))
        res.success = True
        res.status_message = 'SetJointProperties: properties set'
        return res

    @srvcheck.answers(ApplyJointEffortResponse, 'ApplyJointEffort', log='warn')
    def apply_joint_effort(self, req):
        res = ApplyJointEffortResponse()
        w = self.world
        with w.lock:
            try:
                mname, j = find_joint(w, req.joint_name)
            except KeyError as e:
                return self._fail(res, 'ApplyJointEffort', e.args[0])
            if not j.movable or not _simulated(w, mname, j.name):
                return self._fail(res, 'ApplyJointEffort', 'joint %r of model %r is not a '
                                  'simulated movable joint' % (j.name, mname))
            # 1e300 N m on a joint without an effort limit aborted ODE (the body flew off)
            try:
                srvcheck.number(req.effort, 'effort', -srvcheck.MAX_EFFORT,
                                srvcheck.MAX_EFFORT, 'N or N m')
            except srvcheck.BadRequest as e:
                return self._fail(res, 'ApplyJointEffort', 'joint %r: %s' % (j.name, e))
            dt = w.physics.step_size
            duration = req.duration.to_sec()
            if duration == 0:
                res.success = True
                res.status_message = 'ApplyJointEffort: duration 0, nothing applied'
                return res
            now = w.sim_time
            start = req.start_time.to_sec()
            delay = max(0, int(round((start - now) / dt))) if start > now else 0
            steps = None if duration < 0 else max(1, int(round(duration / dt)))
            w.physics.apply_joint_effort(mname, j.name, req.effort, steps=steps, delay=delay)
        res.success = True
        res.status_message = 'ApplyJointEffort: effort set'
        return res

    @srvcheck.answers(JointRequestResponse, 'ClearJointForces', log='warn')
    def clear_joint_forces(self, req):
        w = self.world
        with w.lock:
            try:
                mname, j = find_joint(w, req.joint_name)
            except KeyError as e:
                rospy.logwarn('ClearJointForces: %s', e.args[0])
                return JointRequestResponse()
            if w.physics.has_model(mname):
                w.physics.clear_joint_efforts(mname, j.name)
        return JointRequestResponse()

    @srvcheck.answers(SetModelConfigurationResponse, 'SetModelConfiguration', log='warn')
    def set_model_configuration(self, req):
        res = SetModelConfigurationResponse()
        w = self.world
        if len(req.joint_names) != len(req.joint_positions):
            return self._fail(res, 'SetModelConfiguration', 'model %r: %d joint names but %d '
                              'positions' % (req.model_name, len(req.joint_names),
                                             len(req.joint_positions)))
        with w.lock:
            if req.model_name not in w.models:
                return self._fail(res, 'SetModelConfiguration', 'no model named %r'
                                  % req.model_name)
            try:
                w.physics.set_joint_positions(req.model_name,
                                              dict(zip(req.joint_names, req.joint_positions)))
            except (KeyError, ValueError) as e:
                return self._fail(res, 'SetModelConfiguration', str(e.args[0]))
            if w.pass_states:
                w.pass_states.clear()
        res.success = True
        res.status_message = 'SetModelConfiguration: success'
        return res

    @srvcheck.answers(GetModelPropertiesResponse, 'GetModelProperties', log='warn')
    def get_model_properties(self, req):
        res = GetModelPropertiesResponse()
        w = self.world
        with w.lock:
            model = w.models.get(req.model_name)
            if model is None:
                return self._fail(res, 'GetModelProperties', 'no model named %r'
                                  % req.model_name)
            res.canonical_body_name = model.root_link
            res.body_names = list(model.links)
            res.geom_names = [c.name or '%s_collision_%d' % (ln, i)
                              for ln, link in model.links.items()
                              for i, c in enumerate(link.collisions)]
            res.joint_names = w.physics.joint_names(model.name) \
                if w.physics.has_model(model.name) else []
            res.is_static = bool(model.static)
        res.success = True
        res.status_message = 'GetModelProperties: got properties'
        return res

    # -- links -----------------------------------------------------------------------------
    def _link_state(self, mname, lname, reference):
        w = self.world
        pose, lin, ang = w.entity_state('%s::%s' % (mname, lname))
        if reference in WORLD_FRAMES:
            return pose, lin, ang
        fpose, flin, fang = w.entity_state(reference)
        rinv = fpose.inverse()
        return rinv * pose, rinv.rotate(lin - flin), rinv.rotate(ang - fang)

    @srvcheck.answers(GetLinkStateResponse, 'GetLinkState', log='warn')
    def get_link_state(self, req):
        res = GetLinkStateResponse()
        w = self.world
        with w.lock:
            try:
                mname, lname = find_link(w, req.link_name)
                pose, lin, ang = self._link_state(mname, lname, req.reference_frame)
            except KeyError as e:
                return self._fail(res, 'GetLinkState', e.args[0])
        res.link_state = LinkState(link_name=req.link_name, reference_frame=req.reference_frame)
        res.link_state.pose = pose.to_msg(PoseMsg())
        _twist_msg(res.link_state.twist, lin, ang)
        res.success = True
        res.status_message = 'GetLinkState: got state'
        return res

    @srvcheck.answers(SetLinkStateResponse, 'SetLinkState', log='warn')
    def set_link_state(self, req):
        res = SetLinkStateResponse()
        st = req.link_state
        w = self.world
        try:
            # as set_model_state: a spin of 1e300 rad/s aborts ODE
            pose = srvcheck.pose(st.pose, 'pose')
            lin, ang = srvcheck.twist(st.twist, 'twist')
        except srvcheck.BadRequest as e:
            return self._fail(res, 'SetLinkState', 'link %r: %s' % (st.link_name, e))
        with w.lock:
            try:
                mname, lname = find_link(w, st.link_name)
            except KeyError as e:
                return self._fail(res, 'SetLinkState', e.args[0])
            model = w.models[mname]
            if lname != model.root_link:
                return self._fail(res, 'SetLinkState', 'link %r of model %r is not its root '
                                  'link %r: set the root link, or the joints with '
                                  'set_model_configuration' % (lname, mname, model.root_link))
            try:
                w.set_state(mname, pose, lin, ang, st.reference_frame)
            except (KeyError, InvalidPose, ValueError) as e:
                return self._fail(res, 'SetLinkState', 'link %r: %s'
                                  % (st.link_name, e.args[0] if e.args else e))
        res.success = True
        res.status_message = 'SetLinkState: success'
        return res

    @srvcheck.answers(GetLinkPropertiesResponse, 'GetLinkProperties', log='warn')
    def get_link_properties(self, req):
        res = GetLinkPropertiesResponse()
        w = self.world
        with w.lock:
            try:
                mname, lname = find_link(w, req.link_name)
            except KeyError as e:
                return self._fail(res, 'GetLinkProperties', e.args[0])
            link = w.models[mname].links[lname]
            res.gravity_mode = bool(link.gravity)
            if link.inertial is not None:
                ine = link.inertial
                res.com = ine.origin.to_msg(PoseMsg())
                res.mass = float(ine.mass)
                t = ine.inertia
                res.ixx, res.ixy, res.ixz = float(t[0, 0]), float(t[0, 1]), float(t[0, 2])
                res.iyy, res.iyz, res.izz = float(t[1, 1]), float(t[1, 2]), float(t[2, 2])
            else:
                res.com.orientation.w = 1.0
        res.success = True
        res.status_message = 'GetLinkProperties: got properties'
        return res

    # -- topic -----------------------------------------------------------------------------
    def publish(self):
        """/gazebo/link_states, only while someone subscribes (call with the world lock
        free: it takes it)."""
        if self.link_states_pub is None or self.link_states_pub.get_num_connections() == 0:
            return
        w = self.world
        msg = LinkStates()
        with w.lock:
            for mname, model in w.models.items():
                for lname in model.links:
                    try:
                        pose, lin, ang = w.entity_state('%s::%s' % (mname, lname))
                    except KeyError:
                        continue
                    msg.name.append('%s::%s' % (mname, lname))
                    msg.pose.append(pose.to_msg(PoseMsg()))
                    tw = LinkState().twist
                    msg.twist.append(_twist_msg(tw, lin, ang))
        self.link_states_pub.publish(msg)
