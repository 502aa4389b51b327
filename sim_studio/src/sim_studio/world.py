"""The studio's link to the running world through ROS: the same services the testing
instance's actions call (/gazebo/set_model_state, <ns>/inject_touch, <ns>/press_button,
/gazebo/set_environment, /gazebo/set_sensor_fault, /gazebo/step_world, pause/unpause,
reset), and the latest of what the world publishes (/gazebo/model_states, /clock, the
phone camera's image, the image topics the phones' displays show: ``watch_images``). The
subscribers only keep the latest message: nothing here can hold the world back."""
import threading
import time

__all__ = ['WorldLink', 'WorldError', 'jpeg_of']


class WorldError(RuntimeError):
    """A world service refused or failed; the message says which and why."""


def quat_from_rpy(r, p, y):
    from testing_instance.scenario.motion import quat_from_rpy as q
    return q(r, p, y)


class WorldLink(object):
    def __init__(self, rospy, camera_topic='/mobile_device/image_raw'):
        self.rospy = rospy
        self.camera_topic = camera_topic
        self.states = None            # the latest ModelStates
        self.states_seq = 0
        self.image = None             # the latest sensor_msgs/Image of camera_topic
        self.image_seq = 0
        self.images = {}              # topic -> its latest sensor_msgs/Image (watch_images)
        self.image_seqs = {}          # topic -> how many arrived
        self.clock = 0.0              # the latest /clock (s)
        self._rtf = []                # [(wall, sim)] samples of the last seconds
        self._proxies = {}
        self._lock = threading.Lock()
        self.subs = []
        self.articulated = {}         # model -> its links that move against each other
        self._links = {}              # model -> {link: [x, y, z, qx, qy, qz, qw]}
        self._links_at = 0.0
        self.links_rate = 20.0        # Hz at most of asking for the links' poses
        self.links_rest_rate = 2.0    # Hz once they have kept still for REST_POLLS asks
        self._still = 0               # asks in a row that found every link where it was
        self._watched = set()         # image topics subscribed by watch_images

    def start(self):
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import Image
        from mobile_device_sim.msg import ModelStates
        rospy = self.rospy
        self.subs = [
            rospy.Subscriber('/gazebo/model_states', ModelStates, self._on_states, queue_size=1),
            rospy.Subscriber('/clock', Clock, self._on_clock, queue_size=1),
            rospy.Subscriber(self.camera_topic, Image, self._on_image, queue_size=1,
                             buff_size=2 ** 24),
        ]

    def close(self):
        for s in self.subs:
            s.unregister()
        for p in self._proxies.values():
            try:
                p.close()
            except Exception:  # noqa: BLE001 - best effort at the end
                pass

    # -- what the world publishes (rospy's threads) -----------------------------------------
    def _on_states(self, msg):
        self.states = msg
        self.states_seq += 1

    def link_poses(self):
        """{model: {link: [x, y, z, qx, qy, qz, qw]}} in the world of the articulated
        models' links, as last asked with ``poll_links`` ({} before)."""
        return self._links

    REST_POLLS = 10

    def links_due(self):
        """Whether ``poll_links`` would ask the world now: ``links_rate`` times a second
        while a link moves, ``links_rest_rate`` once they all kept still for REST_POLLS
        asks (each ask makes the world's service thread take its step lock: at 20 Hz that
        was 13 % of the office world's busy samples in a py-spy profile with one client
        and a door standing still, 6 % with this back-off)."""
        if not self.articulated:
            return False
        rate = self.links_rate if self._still < self.REST_POLLS else self.links_rest_rate
        return time.monotonic() - self._links_at >= 1.0 / rate

    def links_moved(self):
        """A command may have moved a link (a pose set, a reset, a step): ask at the full
        rate again."""
        self._still = 0

    def poll_links(self):
        """Ask /gazebo/get_link_state for each link of the articulated models when
        ``links_due`` (one short call per moving link: the world's /gazebo/link_states would
        make it gather every link of every model 100 times a second, which costs it more
        than the whole office's physics)."""
        if not self.links_due():
            return
        self._links_at = time.monotonic()
        from mobile_device_sim.srv import GetLinkState
        out = {}
        for model, links in sorted(self.articulated.items()):
            for link in links:
                try:
                    res = self._call('/gazebo/get_link_state', GetLinkState,
                                     '%s::%s' % (model, link), '')
                except WorldError:
                    continue           # a model deleted since; the next poll tries again
                p = res.link_state.pose
                out.setdefault(model, {})[link] = [round(v, 6) for v in (
                    p.position.x, p.position.y, p.position.z, p.orientation.x,
                    p.orientation.y, p.orientation.z, p.orientation.w)]
        self._still = self._still + 1 if out == self._links else 0
        self._links = out

    def _on_image(self, msg):
        self.image = msg
        self.image_seq += 1
        self._on_topic_image(msg, self.camera_topic)

    def _on_topic_image(self, msg, topic):
        self.images[topic] = msg
        self.image_seqs[topic] = self.image_seqs.get(topic, 0) + 1

    def watch_images(self, topics):
        """Subscribe (queue size 1, once each) to the image ``topics`` not yet watched (the
        camera topic is already): their latest images are ``images[topic]``, counted in
        ``image_seqs[topic]``. Blocks on the master: call it from a worker thread."""
        from sensor_msgs.msg import Image
        for topic in topics:
            if topic == self.camera_topic or topic in self._watched:
                continue
            self._watched.add(topic)
            self.subs.append(self.rospy.Subscriber(
                topic, Image, self._on_topic_image, callback_args=topic, queue_size=1,
                buff_size=2 ** 24))

    def _on_clock(self, msg):
        t = msg.clock.to_sec()
        self.clock = t
        now = time.monotonic()
        self._rtf.append((now, t))
        while self._rtf and now - self._rtf[0][0] > 2.0:
            self._rtf.pop(0)

    def rtf(self):
        """Real-time factor over the last ~2 s of /clock (0 while paused)."""
        s = list(self._rtf)
        if len(s) < 2 or time.monotonic() - s[-1][0] > 0.5:
            return 0.0
        dw = s[-1][0] - s[0][0]
        return (s[-1][1] - s[0][1]) / dw if dw > 0 else 0.0

    def model_names(self):
        st = self.states
        return set(st.name) if st is not None else set()

    def poses(self):
        """{model: [x, y, z, qx, qy, qz, qw]} of the latest /gazebo/model_states."""
        st = self.states
        if st is None:
            return {}
        out = {}
        for n, p in zip(st.name, st.pose):
            out[n] = [round(v, 6) for v in (p.position.x, p.position.y, p.position.z,
                                             p.orientation.x, p.orientation.y,
                                             p.orientation.z, p.orientation.w)]
        return out

    # -- services ---------------------------------------------------------------------------
    def proxy(self, name, typ):
        """The persistent ServiceProxy of service ``name`` (made once; dropped when a call
        through ``_call`` fails, so the next call reconnects)."""
        with self._lock:
            if name not in self._proxies:
                self._proxies[name] = self.rospy.ServiceProxy(name, typ, persistent=True)
            return self._proxies[name]

    def _call(self, name, typ, *args):
        try:
            res = self.proxy(name, typ)(*args)
        except Exception as e:  # noqa: BLE001 - gone service, refused connection
            with self._lock:
                px = self._proxies.pop(name, None)
            if px is not None:
                px.close()
            raise WorldError('service %s failed: %s' % (name, e))
        if hasattr(res, 'success') and not res.success:
            raise WorldError('%s: %s' % (name, res.status_message))
        return res

    def set_pose(self, model, position, rpy):
        from mobile_device_sim.msg import ModelState
        from mobile_device_sim.srv import SetModelState
        s = ModelState()
        s.model_name = model
        s.pose.position.x, s.pose.position.y, s.pose.position.z = position
        q = quat_from_rpy(*rpy)
        (s.pose.orientation.x, s.pose.orientation.y, s.pose.orientation.z,
         s.pose.orientation.w) = (float(v) for v in q)
        self._call('/gazebo/set_model_state', SetModelState, s)

    def get_pose(self, model):
        from mobile_device_sim.srv import GetModelState
        res = self._call('/gazebo/get_model_state', GetModelState, model, '')
        p, q = res.pose.position, res.pose.orientation
        return [p.x, p.y, p.z], [q.x, q.y, q.z, q.w]

    def model_description(self, model):
        """The world's /gazebo/get_model_description answer for ``model`` (format, xml,
        robot_namespace, base_dir); WorldError when it has none."""
        from mobile_device_sim.srv import GetModelDescription
        return self._call('/gazebo/get_model_description', GetModelDescription, model)

    def touch(self, model, x, y, duration, size):
        """A touch at (x, y) in 0..1 of the display of ``size`` (width, height) px, which
        the studio knows from the model's description (scene.display_of)."""
        from mobile_device_sim.srv import InjectTouch
        w, h = size
        self._call('/%s/inject_touch' % model, InjectTouch, min(x * w, w - 1e-6),
                   min(y * h, h - 1e-6), duration, 0.5, -1.0, -1.0)
        return w, h

    def press_button(self, model, button, duration):
        from mobile_device_sim.srv import PressButton
        self._call('/%s/press_button' % model, PressButton, button, duration)

    def set_environment(self, values):
        from mobile_device_sim.msg import EnvironmentValue
        from mobile_device_sim.srv import SetEnvironment
        self._call('/gazebo/set_environment', SetEnvironment,
                   [EnvironmentValue(name=k, value=float(v)) for k, v in sorted(values.items())])

    def fault(self, model, sensor, fault, value):
        from mobile_device_sim.srv import SetSensorFault
        self._call('/gazebo/set_sensor_fault', SetSensorFault, model, sensor, fault,
                   float(value))

    def play(self):
        from std_srvs.srv import Empty
        self._call('/gazebo/unpause_physics', Empty)

    def pause(self):
        from std_srvs.srv import Empty
        self._call('/gazebo/pause_physics', Empty)

    def reset(self):
        from std_srvs.srv import Empty
        self._call('/gazebo/reset_world', Empty)

    def step(self, until):
        from mobile_device_sim.srv import StepWorld
        res = self._call('/gazebo/step_world', StepWorld, float(until), '', False)
        return res.sim_time

    def camera_jpeg(self, quality=70):
        """The latest camera image as JPEG bytes (None: none yet)."""
        return jpeg_of(self.image, quality)

    def image_jpeg(self, topic, width=None, quality=70):
        """The latest image of a watched ``topic`` as JPEG bytes, at most ``width`` pixels
        wide (None: none yet)."""
        return jpeg_of(self.images.get(topic), quality, width)


def jpeg_of(msg, quality=70, width=None):
    """A sensor_msgs/Image as JPEG bytes, scaled down to ``width`` pixels (its aspect kept)
    when it is wider; None for None or an image simvid.imageconv cannot convert (the one
    converter of the package's image readers)."""
    if msg is None:
        return None
    import cv2
    import numpy as np
    from simvid.imageconv import UnsupportedEncoding, image_to_rgb
    try:
        rgb = image_to_rgb(msg)
    except UnsupportedEncoding:
        return None
    a = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2BGR)
    if width and msg.width > width:
        a = cv2.resize(a, (int(width), max(1, int(round(msg.height * width / msg.width)))),
                       interpolation=cv2.INTER_LINEAR)     # 0.5 ms; INTER_AREA: 4
    ok, buf = cv2.imencode('.jpg', a, [int(cv2.IMWRITE_JPEG_QUALITY), quality])
    return buf.tobytes() if ok else None
