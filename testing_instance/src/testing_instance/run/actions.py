"""The scenario's actions (timeline `action:` entries), a part of the Runner.

Each ``_act_<name>(ev, t0)`` applies one action at sim time t0 while the world is paused,
through the world's services (``self._call``) or topics (``self._publish``); motion actions
push their steps on the runner's agenda. Mixed into ``Runner``, which provides the service
proxies, publishers and agenda.
"""
import subprocess
import threading

from ..scenario import motion
from ..scenario.results import RunError

__all__ = ['Actions']


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


class Actions(object):
    # -- actions ---------------------------------------------------------------------------
    def _ns(self, ev):
        return '/' + ev.get('ns', self.sc.phones[0]['ns']).strip('/')

    def _call(self, ev, name, typ, *args):
        try:
            res = self.proxy(name, typ)(*args)
        except Exception as e:  # noqa: BLE001 - service missing or the world died
            self.check_world()
            raise RunError('%s (%s): service %s failed: %s' % (ev['id'], ev['action'], name, e),
                           self.world_log())
        if hasattr(res, 'success') and not res.success:
            raise RunError('%s (%s): %s' % (ev['id'], ev['action'], res.status_message))
        return res

    def _model_state(self, ev, model):
        res = self._call(ev, '/gazebo/get_model_state', self.srv_types['get'], model, '')
        p, q = res.pose.position, res.pose.orientation
        return [p.x, p.y, p.z], [q.x, q.y, q.z, q.w]

    def _set_pose(self, ev, model, pos, quat, lin=(0, 0, 0), ang=(0, 0, 0), frame=''):
        from mobile_device_sim.msg import ModelState
        s = ModelState()
        s.model_name = model
        s.pose.position.x, s.pose.position.y, s.pose.position.z = (float(v) for v in pos)
        (s.pose.orientation.x, s.pose.orientation.y, s.pose.orientation.z,
         s.pose.orientation.w) = (float(v) for v in quat)
        s.twist.linear.x, s.twist.linear.y, s.twist.linear.z = (float(v) for v in lin)
        s.twist.angular.x, s.twist.angular.y, s.twist.angular.z = (float(v) for v in ang)
        s.reference_frame = frame
        self._call(ev, '/gazebo/set_model_state', self.srv_types['set'], s)

    def _set_env(self, ev, values):
        from mobile_device_sim.msg import EnvironmentValue
        self._call(ev, '/gazebo/set_environment', self.srv_types['env'],
                   [EnvironmentValue(name=k, value=float(v)) for k, v in sorted(values.items())])
        self.env_values.update(values)

    def _publisher(self, topic, cls, latch=True):
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

    def _publish(self, topic, msg):
        """Publish once a subscriber (an app) is connected, at most 5 s of wall time later:
        woken by rospy's SubscribeListener as it connects, not by polling. The next step
        lets the world take it first (Runner._step: an embedded world's receive threads
        settle; a world node's step request waits for them, sim_world.transport's gate)."""
        pub = self._publisher(topic, type(msg))
        pub.connected.wait(pub.get_num_connections, 5.0)
        pub.publish(msg)
        self.inputs_sent = True

    def _spawn(self, name, path, pos, rpy, namespace='', args=None, ev=None):
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
        self._call(ev, srv, self.srv_types['spawn_urdf'], name, xml, namespace, pose, '')
        self.topics_dirty = True            # its sensors' topics: subscribe at the next slice

    def _do_action(self, ev, t0):
        a = ev['action']
        fn = getattr(self, '_act_' + a)
        fn(ev, t0)

    def _act_set_model_state(self, ev, t0):
        pos, quat = self._model_state(ev, ev['model'])
        if 'position' in ev:
            pos = ev['position']
        if 'rpy' in ev:
            quat = motion.quat_from_rpy(*ev['rpy'])
        self._set_pose(ev, ev['model'], pos, quat, frame=ev.get('reference_frame', ''))

    def _act_move_model(self, ev, t0):
        pos, quat = self._model_state(ev, ev['model'])
        if 'rpy' in ev:
            quat = motion.quat_from_rpy(*ev['rpy'])
        pts = motion.path_points(pos, ev['waypoints'], ev.get('speed', 0.5),
                                 ev.get('interval', 0.02))
        for dt, p, v in pts:
            self._push(t0 + dt, lambda tt, p=p, v=v: self._set_pose(ev, ev['model'], p, quat, v),
                       ev['id'])

    def _act_walk(self, ev, t0):
        pos, quat = self._model_state(ev, ev['model'])
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
            self._set_pose(ev, ev['model'], p, q, v)
        for dt, p, v, yaw in pts:
            self._push(t0 + dt, lambda tt, p=p, v=v, y=yaw: setp(tt, p, v, y), ev['id'])

    def _act_rotate(self, ev, t0):
        pos, quat = self._model_state(ev, ev['model'])
        for dt, q in motion.rotate_points(quat, ev['rpy'], ev.get('duration', 0.0),
                                          ev.get('interval', 0.02)):
            self._push(t0 + dt, lambda tt, q=q: self._set_pose(ev, ev['model'], pos, q),
                       ev['id'])

    def _act_set_environment(self, ev, t0):
        start = {k: self.env_values.get(k, v) for k, v in ev['values'].items()}
        for dt, vals in motion.ramp_points(start, ev['values'], ev.get('ramp', 0.0),
                                           ev.get('interval', 0.1)):
            if dt == 0:
                self._set_env(ev, vals)
            else:
                self._push(t0 + dt, lambda tt, v=vals: self._set_env(ev, v), ev['id'])

    def _act_playback(self, ev, t0):
        for dt, v in motion.series_points(ev['series']):
            if 'name' in ev:
                fn = (lambda tt, v=v: self._set_env(ev, {ev['name']: v}))
            else:
                cls = self._msg_class(ev['type'])
                if cls is None:
                    raise RunError('%s: unknown message type %r' % (ev['id'], ev['type']))

                def fn(tt, v=v, cls=cls):
                    m = cls()
                    _set_field(m, ev['field'], v)
                    if hasattr(m, 'header'):
                        m.header.stamp = self.rospy.Time.from_sec(tt)
                    self._publish(ev['topic'], m)
            if dt <= 0:
                fn(t0)
            else:
                self._push(t0 + dt, fn, ev['id'])

    def _act_charger(self, ev, t0):
        from std_msgs.msg import Bool
        self._publish(self._ns(ev) + '/charger', Bool(ev['plugged']))

    def _act_radio(self, ev, t0):
        from std_msgs.msg import Bool
        self._publish('%s/%s/enable' % (self._ns(ev), ev['radio']), Bool(ev['enabled']))

    def _act_press_button(self, ev, t0):
        self._call(ev, self._ns(ev) + '/press_button', self.srv_types['button'], ev['button'],
                   ev.get('duration', 0.1))

    def _act_touch(self, ev, t0):
        self._call(ev, self._ns(ev) + '/inject_touch', self.srv_types['touch'], ev['x'],
                   ev['y'], ev.get('duration', 0.1), ev.get('pressure', 0.5),
                   ev.get('x_end', -1.0), ev.get('y_end', -1.0))

    def _act_show_image(self, ev, t0):
        from std_msgs.msg import String
        path = self.sc.resolve(ev['file'])
        self._publish(ev.get('topic', self._ns(ev) + '/load_image_file'), String(path))

    def _act_spawn_model(self, ev, t0):
        self._spawn(ev['name'], self.sc.resolve(ev['file']), ev.get('position', [0, 0, 0]),
                    ev.get('rpy', [0, 0, 0]), ev.get('namespace', ''), ev.get('args'), ev)

    def _act_delete_model(self, ev, t0):
        self._call(ev, '/gazebo/delete_model', self.srv_types['delete'], ev['name'])

    def _act_fault(self, ev, t0):
        self._call(ev, '/gazebo/set_sensor_fault', self.srv_types['fault'],
                   ev.get('model', self.sc.phones[0]['ns']), ev['sensor'], ev['fault'],
                   float(ev.get('value', 0.0)))

    def _act_publish(self, ev, t0):
        cls = self._msg_class(ev['type'])
        if cls is None:
            raise RunError('%s: unknown message type %r' % (ev['id'], ev['type']))
        m = cls()
        try:
            from genpy.message import fill_message_args
            fill_message_args(m, [dict(ev.get('msg') or {})])
        except Exception as e:  # noqa: BLE001 - genpy raises several kinds
            raise RunError('%s: cannot fill a %s from %r: %s' % (ev['id'], ev['type'],
                                                                 ev.get('msg'), e))
        self._publish(ev['topic'], m)

    def _act_log(self, ev, t0):
        self.say('  t=%.3f s: %s' % (t0, ev['text']))
