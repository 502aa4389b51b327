"""The scenario's actions (timeline `action:` entries) as objects.

Each kind of action is a class: ``KINDS`` maps every action name of the scenario format to
it, ``action_of(ev)`` makes the object of one timeline entry, and ``apply(hands, t0)``
applies it at sim time t0 while the world is paused. An action acts only through its
``Hands``: the world's services (``call``), the input topics (``publish``), the models'
poses, the environment, spawning, and the agenda (``later``) for the steps of a motion
that come after t0. The runner holds one ``Hands`` per run and fires each due action.
"""
import subprocess
import threading

from ..scenario import motion
from ..scenario.results import RunError

__all__ = ['Action', 'Hands', 'KINDS', 'action_of']


def _set_field(msg, path, value):
    parts = path.split('.')
    obj = msg
    for p in parts[:-1]:
        obj = getattr(obj, p)
    setattr(obj, parts[-1], type(getattr(obj, parts[-1]))(value))



class _Connected(object):
    """rospy.SubscribeListener of an action's publisher: wakes ``wait`` when a subscriber
    connects (rospy calls peer_subscribe once the connection is added)."""

    def __init__(self):
        self._cv = threading.Condition()

    def peer_subscribe(self, _topic, _publish, _publish_single):
        with self._cv:
            self._cv.notify_all()

    def peer_unsubscribe(self, _topic, _num_peers):
        pass

    def wait(self, count, timeout):
        """Until count() > 0 (a subscriber is connected), at most ``timeout`` s."""
        with self._cv:
            return self._cv.wait_for(lambda: count() > 0, timeout)


class Hands(object):
    """What the actions act through, one per run. ``world``: the run's WorldSide (its
    service proxies and types, its log); ``later(t, fn, what)``: the run's agenda;
    ``check_world()``: raises the run's error when a process of the run is gone.

    What the run reads back: ``pubs`` (the input publishers, {(topic, type): publisher}),
    ``inputs_sent`` (an action published since the last step: the next step lets the
    world take it first), ``spawned`` (a model was spawned since the last look at the
    master's topics), ``env_values`` (the environment as last set or seen, where a ramp
    starts)."""

    def __init__(self, sc, world, later, say=print, check_world=lambda: None):
        self.sc = sc
        self.world = world
        self.later = later
        self.say = say
        self.check_world = check_world
        self.pubs = {}
        self.inputs_sent = False
        self.spawned = False
        self.env_values = {}

    def ns(self, ev):
        return '/' + ev.get('ns', self.sc.phones[0]['ns']).strip('/')

    def call(self, ev, name, kind, *args):
        """Call the world's service ``name`` (its type: the world's ``srv_types[kind]``, or
        ``kind`` itself when it is a service class); an error of the run naming the action
        when it fails or answers success false (ok false: the link attacher)."""
        typ = kind if isinstance(kind, type) else self.world.srv_types[kind]
        try:
            res = self.world.proxy(name, typ)(*args)
        except Exception as e:  # noqa: BLE001 - service missing or the world died
            self.check_world()
            raise RunError('%s (%s): service %s failed: %s' % (ev['id'], ev['action'], name, e),
                           self.world.log_tail())
        if hasattr(res, 'success') and not res.success:
            raise RunError('%s (%s): %s' % (ev['id'], ev['action'], res.status_message))
        if hasattr(res, 'ok') and not res.ok:
            raise RunError('%s (%s): %s refused it (the world\'s log says why)'
                           % (ev['id'], ev['action'], name), self.world.log_tail())
        return res

    def model_state(self, ev, model):
        res = self.call(ev, '/gazebo/get_model_state', 'get', model, '')
        p, q = res.pose.position, res.pose.orientation
        return [p.x, p.y, p.z], [q.x, q.y, q.z, q.w]

    def set_pose(self, ev, model, pos, quat, lin=(0, 0, 0), ang=(0, 0, 0), frame=''):
        from mobile_device_sim.msg import ModelState
        s = ModelState()
        s.model_name = model
        s.pose.position.x, s.pose.position.y, s.pose.position.z = (float(v) for v in pos)
        (s.pose.orientation.x, s.pose.orientation.y, s.pose.orientation.z,
         s.pose.orientation.w) = (float(v) for v in quat)
        s.twist.linear.x, s.twist.linear.y, s.twist.linear.z = (float(v) for v in lin)
        s.twist.angular.x, s.twist.angular.y, s.twist.angular.z = (float(v) for v in ang)
        s.reference_frame = frame
        self.call(ev, '/gazebo/set_model_state', 'set', s)

    def set_env(self, ev, values):
        from mobile_device_sim.msg import EnvironmentValue
        self.call(ev, '/gazebo/set_environment', 'env',
                  [EnvironmentValue(name=k, value=float(v)) for k, v in sorted(values.items())])
        self.env_values.update(values)

    def publisher(self, topic, cls, latch=True):
        """The action publisher of ``topic``: synchronous (no queue_size), so that when
        publish() returns the message's bytes are in every subscriber's socket. A queued
        publisher's own thread could write them after the next step request: the world
        then took the input a slice late (a radio switched off at sim time 0 was still on
        in the first step's messages, under load)."""
        import warnings
        import rospy
        key = (topic, cls._type)
        if key not in self.pubs:
            connected = _Connected()
            with warnings.catch_warnings():
                # rospy warns about a publisher without a queue_size: here it is the point
                warnings.simplefilter('ignore', SyntaxWarning)
                self.pubs[key] = rospy.Publisher(topic, cls, queue_size=None, latch=latch,
                                                 subscriber_listener=connected)
            self.pubs[key].connected = connected
        return self.pubs[key]

    def publish(self, topic, msg):
        """Publish once a subscriber (an app) is connected, at most 5 s of wall time later:
        woken by rospy's SubscribeListener as it connects, not by polling. The next step
        lets the world take it first (WorldClock.step: an embedded world's receive threads
        settle; a world node's step request waits for them, sim_world.transport's gate)."""
        pub = self.publisher(topic, type(msg))
        pub.connected.wait(pub.get_num_connections, 5.0)
        pub.publish(msg)
        self.inputs_sent = True

    def msg_class(self, typ):
        import roslib.message
        return roslib.message.get_message_class(typ)

    def stamp(self, t):
        """A header stamp of sim time t."""
        import rospy
        return rospy.Time.from_sec(t)

    def spawn(self, name, path, pos, rpy, namespace='', args=None, ev=None):
        ev = ev or {'id': 'phones', 'action': 'spawn_model'}
        from geometry_msgs.msg import Pose
        if path.endswith('.xacro') or path.endswith('.urdf'):
            cmd = ['xacro', path] + ['%s:=%s' % kv for kv in (args or {}).items()]
            try:
                xml = subprocess.run(cmd, check=True, capture_output=True, text=True,
                                     timeout=60).stdout
            except (subprocess.CalledProcessError, OSError, subprocess.TimeoutExpired) as e:
                raise RunError('%s: xacro %s failed: %s' % (ev['id'], path,
                                                            getattr(e, 'stderr', e)))
            srv = '/gazebo/spawn_urdf_model'
        else:
            try:
                xml = open(path).read()
            except OSError as e:
                raise RunError('%s: cannot read %s: %s' % (ev['id'], path, e.strerror))
            srv = '/gazebo/spawn_sdf_model'
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = pos
        q = motion.quat_from_rpy(*rpy)
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = q
        self.call(ev, srv, 'spawn_urdf', name, xml, namespace, pose, '')
        self.spawned = True            # its sensors' topics: subscribe at the next slice


class Action(object):
    """One timeline entry ``ev`` of action kind ``name``."""
    name = None

    def __init__(self, ev):
        self.ev = ev

    def apply(self, hands, t0):
        """Act at sim time t0 (the world paused) through ``hands``."""
        raise NotImplementedError


class SetModelState(Action):
    name = 'set_model_state'

    def apply(self, h, t0):
        ev = self.ev
        pos, quat = h.model_state(ev, ev['model'])
        if 'position' in ev:
            pos = ev['position']
        if 'rpy' in ev:
            quat = motion.quat_from_rpy(*ev['rpy'])
        h.set_pose(ev, ev['model'], pos, quat, frame=ev.get('reference_frame', ''))


class MoveModel(Action):
    name = 'move_model'

    def apply(self, h, t0):
        ev = self.ev
        pos, quat = h.model_state(ev, ev['model'])
        if 'rpy' in ev:
            quat = motion.quat_from_rpy(*ev['rpy'])
        pts = motion.path_points(pos, ev['waypoints'], ev.get('speed', 0.5),
                                 ev.get('interval', 0.02))
        for dt, p, v in pts:
            h.later(t0 + dt, lambda tt, p=p, v=v: h.set_pose(ev, ev['model'], p, quat, v),
                    ev['id'])


class Walk(Action):
    name = 'walk'

    def apply(self, h, t0):
        ev = self.ev
        pos, quat = h.model_state(ev, ev['model'])
        base = motion.quat_from_rpy(*ev.get('rpy', [0, 0, 0])) if 'rpy' in ev else quat
        pts = motion.walk_points(pos, ev['waypoints'], ev.get('speed', 1.2),
                                 ev.get('step_frequency', 1.8), ev.get('bounce', 0.02),
                                 ev.get('interval', 0.04))
        face = ev.get('heading', True)
        last_yaw = [None]

        def setp(tt, p, v, yaw):
            q = base
            if face:
                if yaw is None:
                    yaw = last_yaw[0]
                last_yaw[0] = yaw
                if yaw is not None:
                    q = motion.quat_mul(motion.quat_from_rpy(0, 0, yaw), base)
            h.set_pose(ev, ev['model'], p, q, v)
        for dt, p, v, yaw in pts:
            h.later(t0 + dt, lambda tt, p=p, v=v, y=yaw: setp(tt, p, v, y), ev['id'])


class Rotate(Action):
    name = 'rotate'

    def apply(self, h, t0):
        ev = self.ev
        pos, quat = h.model_state(ev, ev['model'])
        for dt, q in motion.rotate_points(quat, ev['rpy'], ev.get('duration', 0.0),
                                          ev.get('interval', 0.02)):
            h.later(t0 + dt, lambda tt, q=q: h.set_pose(ev, ev['model'], pos, q), ev['id'])


class SetEnvironment(Action):
    name = 'set_environment'

    def apply(self, h, t0):
        ev = self.ev
        start = {k: h.env_values.get(k, v) for k, v in ev['values'].items()}
        for dt, vals in motion.ramp_points(start, ev['values'], ev.get('ramp', 0.0),
                                           ev.get('interval', 0.1)):
            if dt == 0:
                h.set_env(ev, vals)
            else:
                h.later(t0 + dt, lambda tt, v=vals: h.set_env(ev, v), ev['id'])


class Playback(Action):
    name = 'playback'

    def apply(self, h, t0):
        ev = self.ev
        for dt, v in motion.series_points(ev['series']):
            if 'name' in ev:
                fn = (lambda tt, v=v: h.set_env(ev, {ev['name']: v}))
            else:
                cls = h.msg_class(ev['type'])
                if cls is None:
                    raise RunError('%s: unknown message type %r' % (ev['id'], ev['type']))

                def fn(tt, v=v, cls=cls):
                    m = cls()
                    _set_field(m, ev['field'], v)
                    if hasattr(m, 'header'):
                        m.header.stamp = h.stamp(tt)
                    h.publish(ev['topic'], m)
            if dt <= 0:
                fn(t0)
            else:
                h.later(t0 + dt, fn, ev['id'])


class Charger(Action):
    name = 'charger'

    def apply(self, h, t0):
        from std_msgs.msg import Bool
        h.publish(h.ns(self.ev) + '/charger', Bool(self.ev['plugged']))


class Radio(Action):
    name = 'radio'

    def apply(self, h, t0):
        from std_msgs.msg import Bool
        ev = self.ev
        h.publish('%s/%s/enable' % (h.ns(ev), ev['radio']), Bool(ev['enabled']))


class PressButton(Action):
    name = 'press_button'

    def apply(self, h, t0):
        ev = self.ev
        h.call(ev, h.ns(ev) + '/press_button', 'button', ev['button'], ev.get('duration', 0.1))


class Touch(Action):
    name = 'touch'

    def apply(self, h, t0):
        ev = self.ev
        h.call(ev, h.ns(ev) + '/inject_touch', 'touch', ev['x'], ev['y'],
               ev.get('duration', 0.1), ev.get('pressure', 0.5), ev.get('x_end', -1.0),
               ev.get('y_end', -1.0))


class ShowImage(Action):
    name = 'show_image'

    def apply(self, h, t0):
        from std_msgs.msg import String
        ev = self.ev
        path = h.sc.resolve(ev['file'])
        h.publish(ev.get('topic', h.ns(ev) + '/load_image_file'), String(path))


class SpawnModel(Action):
    name = 'spawn_model'

    def apply(self, h, t0):
        ev = self.ev
        h.spawn(ev['name'], h.sc.resolve(ev['file']), ev.get('position', [0, 0, 0]),
                ev.get('rpy', [0, 0, 0]), ev.get('namespace', ''), ev.get('args'), ev)


class DeleteModel(Action):
    name = 'delete_model'

    def apply(self, h, t0):
        h.call(self.ev, '/gazebo/delete_model', 'delete', self.ev['name'])


class Fault(Action):
    name = 'fault'

    def apply(self, h, t0):
        ev = self.ev
        h.call(ev, '/gazebo/set_sensor_fault', 'fault', ev.get('model', h.sc.phones[0]['ns']),
               ev['sensor'], ev['fault'], float(ev.get('value', 0.0)))


class Publish(Action):
    name = 'publish'

    def apply(self, h, t0):
        ev = self.ev
        cls = h.msg_class(ev['type'])
        if cls is None:
            raise RunError('%s: unknown message type %r' % (ev['id'], ev['type']))
        m = cls()
        try:
            from genpy.message import fill_message_args
            fill_message_args(m, [dict(ev.get('msg') or {})])
        except Exception as e:  # noqa: BLE001 - genpy raises several kinds
            raise RunError('%s: cannot fill a %s from %r: %s' % (ev['id'], ev['type'],
                                                                 ev.get('msg'), e))
        h.publish(ev['topic'], m)


class SetJoints(Action):
    """Joints at positions, at rest (Gazebo's set_model_configuration); with a duration, a
    linear move from where they are, one configuration every interval."""
    name = 'set_joints'

    def apply(self, h, t0):
        from mobile_device_sim.srv import GetJointProperties, SetModelConfiguration
        ev = self.ev
        names = sorted(ev['positions'])
        goal = [float(ev['positions'][n]) for n in names]

        def put(values):
            h.call(ev, '/gazebo/set_model_configuration', SetModelConfiguration, ev['model'],
                   '', names, list(values))
        duration = float(ev.get('duration', 0.0))
        if duration <= 0:
            put(goal)
            return
        start = []
        for n in names:
            res = h.call(ev, '/gazebo/get_joint_properties', GetJointProperties,
                         '%s::%s' % (ev['model'], n))
            start.append(res.position[0] if len(res.position) else 0.0)
        interval = float(ev.get('interval', 0.02))
        steps = max(1, int(round(duration / interval)))
        for k in range(1, steps + 1):
            f = k / float(steps)
            vals = [a + (b - a) * f for a, b in zip(start, goal)]
            h.later(t0 + duration * f, lambda tt, v=vals: put(v), ev['id'])


class Door(Action):
    """A door on its hinge open or closed: set_joints on the door's model (the office's
    east_door by default: its hinge 1.5 rad open, 0 closed)."""
    name = 'door'
    OPEN, CLOSED = 1.5, 0.0

    def apply(self, h, t0):
        from mobile_device_sim.srv import SetModelConfiguration
        ev = self.ev
        q = ev.get('position', self.OPEN if ev['open'] else self.CLOSED)
        h.call(ev, '/gazebo/set_model_configuration', SetModelConfiguration,
               ev.get('model', 'east_door'), '', [ev.get('joint', 'hinge')], [float(q)])


class JointEffort(Action):
    """An effort on a joint for a duration (Gazebo's apply_joint_effort)."""
    name = 'joint_effort'

    def apply(self, h, t0):
        import rospy
        from mobile_device_sim.srv import ApplyJointEffort
        ev = self.ev
        d = float(ev.get('duration', 1.0))
        h.call(ev, '/gazebo/apply_joint_effort', ApplyJointEffort, ev['joint'],
               float(ev['effort']), rospy.Time(0), rospy.Duration.from_sec(d))


def trajectory_class(h):
    """trajectory_msgs/JointTrajectory, or this package's copy of it (same md5sum)."""
    for typ in ('trajectory_msgs/JointTrajectory', 'mobile_device_sim/JointTrajectory'):
        try:
            cls = h.msg_class(typ)
        except Exception:  # noqa: BLE001 - roslib raises several kinds for a missing package
            cls = None
        if cls is not None:
            return cls
    return None


def trajectory_msg(cls, ev):
    """The JointTrajectory of a trajectory action (header stamp 0: start at once)."""
    import roslib.message
    import rospy
    m = cls()
    m.joint_names = list(ev['joints'])
    point_type = dict(zip(cls.__slots__, cls._slot_types))['points'].rstrip('[]')
    pcls = roslib.message.get_message_class(point_type)
    for pt in ev['points']:
        p = pcls()
        p.positions = [float(x) for x in pt['positions']]
        for k in ('velocities', 'accelerations', 'effort'):
            if k in pt:
                setattr(p, k, [float(x) for x in pt[k]])
        p.time_from_start = rospy.Duration.from_sec(float(pt['time_from_start']))
        m.points.append(p)
    return m


class Trajectory(Action):
    """A trajectory_msgs/JointTrajectory to a joint trajectory controller's command topic."""
    name = 'trajectory'

    def apply(self, h, t0):
        ev = self.ev
        cls = trajectory_class(h)
        if cls is None:
            raise RunError('%s (trajectory): no trajectory_msgs/JointTrajectory message '
                           'type here' % ev['id'])
        topic = '/' + ev['controller'].strip('/') + '/command'
        h.publish(topic, trajectory_msg(cls, ev))


def link_of(h, ev, text):
    """(model, link) of 'model::link' (a model alone: its root link)."""
    from mobile_device_sim.srv import GetModelProperties
    model, sep, link = text.partition('::')
    if not sep:
        link = h.call(ev, '/gazebo/get_model_properties', GetModelProperties,
                      model).canonical_body_name
    return model, link


class Attach(Action):
    """``holder`` holds ``held`` where they are now (gazebo_ros_link_attacher's attach)."""
    name = 'attach'
    service = '/gazebo/attach'

    def apply(self, h, t0):
        from mobile_device_sim.srv import Attach as AttachSrv
        ev = self.ev
        m1, l1 = link_of(h, ev, ev['holder'])
        m2, l2 = link_of(h, ev, ev['held'])
        h.call(ev, self.service, AttachSrv, m1, l1, m2, l2)


class Detach(Attach):
    name = 'detach'
    service = '/gazebo/detach'


def e_stop_topic(ev):
    """The e-stop topic of an e_stop action: ``topic`` (default ``e_stop``) in the robot's
    namespace ``ns``, or ``topic`` itself when it is absolute."""
    topic = ev.get('topic', 'e_stop')
    if topic.startswith('/'):
        return topic
    return '/' + '/'.join(x for x in (ev['ns'].strip('/'), topic.strip('/')) if x)


class EStop(Action):
    """A robot's e-stop (gazebo_ros_control's ``eStopTopic``, std_msgs/Bool, latched): active,
    its position-commanded joints hold where they are, velocities and efforts are 0, whatever
    its controllers command; not active, released (its running controllers start again)."""
    name = 'e_stop'

    def apply(self, h, t0):
        from std_msgs.msg import Bool
        h.publish(e_stop_topic(self.ev), Bool(data=bool(self.ev['active'])))


class Log(Action):
    name = 'log'

    def apply(self, h, t0):
        h.say('  t=%.3f s: %s' % (t0, self.ev['text']))


KINDS = {cls.name: cls for cls in (
    SetModelState, MoveModel, Walk, Rotate, SetEnvironment, Playback, Charger, Radio,
    PressButton, Touch, ShowImage, SpawnModel, DeleteModel, Fault, Publish, Log, SetJoints,
    Door, JointEffort, Trajectory, Attach, Detach, EStop)}


def action_of(ev):
    """The action object of timeline entry ``ev``."""
    return KINDS[ev['action']](ev)
