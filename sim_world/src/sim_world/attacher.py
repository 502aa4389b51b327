"""The link attacher: gazebo_ros_link_attacher's services, so a gripper or a hand can hold
the phone (issue 48 part 4).

Services (``mobile_device_sim/Attach``: the definition of gazebo_ros_link_attacher's
srv/Attach.srv, so the same md5sum)::

  /gazebo/attach, /link_attacher_node/attach    model_name_1, link_name_1 hold
                                                model_name_2, link_name_2 -> ok
  /gazebo/detach, /link_attacher_node/detach    remove that attachment -> ok

(``/link_attacher_node/*`` are the names the Gazebo plugin serves, so a Gazebo user's
client works unchanged.) Attaching makes a fixed joint between the two links where they are
now (ODE: a FixedJoint; Bullet: a JOINT_FIXED constraint; sim_world.physics.attachments):
the held model moves with the holding link, and its sensors read that motion. Bad input (an
unknown model or link, a link attached to itself, two links of one model, two static
models, a detach of nothing) answers ``ok: false`` and logs one line naming it; attaching
what is attached already answers ok and changes nothing. ``/gazebo/reset_world`` and
``reset_simulation`` detach everything (a warm world's next run starts with nothing held).
"""
import rospy

from mobile_device_sim.srv import Attach, AttachResponse

from . import srvcheck, transport

__all__ = ['LinkAttacher', 'SERVICES']

#: (attach, detach) service names: this package's and the Gazebo plugin's
SERVICES = (('/gazebo/attach', '/gazebo/detach'),
            ('/link_attacher_node/attach', '/link_attacher_node/detach'))


def _names(req):
    return tuple((x or '').strip() for x in (req.model_name_1, req.link_name_1,
                                             req.model_name_2, req.link_name_2))


class LinkAttacher(object):
    """The attach/detach services of ``api`` (a GazeboRosApi: its ``world`` is read at each
    call, so /gazebo/reload_world's new world is served)."""

    def __init__(self, api, serve=True, log=None):
        self.api = api
        self.log = log or rospy.logwarn
        self.services = []
        if serve:      # serve=False: the handlers alone (unit tests)
            for att, det in SERVICES:
                self.services.append(transport.service(att, Attach, self.attach))
                self.services.append(transport.service(det, Attach, self.detach))

    @property
    def world(self):
        return self.api.world

    def _refuse(self, what, text):
        self.log(srvcheck.one_line('%s: %s' % (what, text)))
        return AttachResponse(ok=False)

    def attach(self, req):
        m1, l1, m2, l2 = names = _names(req)
        w = self.world
        try:
            with w.lock:
                for m in (m1, m2):
                    if m not in w.models:
                        raise KeyError('no model named %r' % m if m else 'no model name given')
                made = w.physics.attach(m1, l1, m2, l2)
                if w.pass_states:
                    w.pass_states.clear()
        except (KeyError, ValueError) as e:
            return self._refuse('Attach %s::%s to %s::%s' % (m2, l2, m1, l1),
                                e.args[0] if e.args else e)
        except Exception as e:  # noqa: BLE001 - a bug: one line, the world keeps serving
            return self._refuse('Attach %s::%s to %s::%s' % (m2, l2, m1, l1),
                                'internal error: %s: %s' % (type(e).__name__, e))
        if not made:
            rospy.loginfo('Attach: %s::%s already holds %s::%s', *names)
        return AttachResponse(ok=True)

    def detach(self, req):
        m1, l1, m2, l2 = _names(req)
        w = self.world
        try:
            with w.lock:
                done = w.physics.detach(m1, l1, m2, l2)
        except Exception as e:  # noqa: BLE001 - a bug: one line, the world keeps serving
            return self._refuse('Detach', 'internal error: %s: %s' % (type(e).__name__, e))
        if not done:
            held = ', '.join('%s::%s holds %s::%s' % a for a in w.physics.attachments())
            return self._refuse('Detach %s::%s from %s::%s' % (m2, l2, m1, l1),
                                'no such attachment (attached: %s)' % (held or 'nothing'))
        return AttachResponse(ok=True)
