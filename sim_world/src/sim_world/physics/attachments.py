"""Links of two models held together by a fixed joint made at run time: the link attacher
(gazebo_ros_link_attacher's ``attach`` / ``detach``), so a gripper or a hand can hold the
phone. Both engines (ODE: a FixedJoint between the two bodies; Bullet: a JOINT_FIXED
constraint), behind the engine interface::

    engine.attach(model1, link1, model2, link2)   # fixes link2 to link1 where they are now
    engine.detach(model1, link1, model2, link2)   # True if that attachment was there
    engine.attachments()                          # [(model1, link1, model2, link2)]

``model1``/``link1`` holds, ``model2``/``link2`` is held: when the holder moves without
physics (``set_model_pose``, ``set_joint_positions``, a reset of its joints) the held model
is carried along at its offset; when the held model is teleported, it is held again at
its new offset. Either side may be a link of a static model (fixed to the world there),
not both; two links of one model cannot be attached (closed chains are not simulated).
The two bodies do not collide with each other while attached. Removing a model drops its
attachments. Bullet holds a link of an articulated model (a multibody) and a one-body model
together, or anything with a static model (the held body is made static until detached);
two one-body or two articulated models only in ODE (pybullet's fixed constraint between two
free rigid bodies ignores the frames' orientations), refused by name in Bullet. Bad input
raises ``KeyError`` / ``ValueError`` with a sentence naming it.
"""

__all__ = ['Attachment', 'Attachments']


class Attachment(object):
    """One fixed joint of the attacher: ``rel`` is link2's pose in link1's frame."""
    __slots__ = ('model1', 'link1', 'model2', 'link2', 'rel', 'native')

    def __init__(self, model1, link1, model2, link2, rel):
        self.model1, self.link1, self.model2, self.link2 = model1, link1, model2, link2
        self.rel = rel
        self.native = None

    @property
    def key(self):
        return (self.model1, self.link1, self.model2, self.link2)

    def __repr__(self):
        return '<Attachment %s::%s holds %s::%s>' % self.key


class Attachments(object):
    """The attachments of one engine (``engine._attached``); the backend makes and
    removes the native joints (``_fix(att, rec1, rec2)``, ``_unfix(att)``)."""

    def __init__(self, engine):
        self.engine = engine
        self.items = []
        self._moving = False     # carrying held models along: no regrip of them

    def __len__(self):
        return len(self.items)

    def _check(self, model, link):
        e = self.engine
        if not isinstance(model, str) or not model:
            raise KeyError('no model name given')
        if not e.has_model(model):
            raise KeyError('no model named %r' % model)
        if not isinstance(link, str) or not link:
            raise KeyError('model %r: no link name given' % model)
        rec = e._check_link(model, link)     # KeyError naming the link
        return rec

    def find(self, model1, link1, model2, link2):
        for att in self.items:
            if att.key == (model1, link1, model2, link2):
                return att
        return None

    def attach(self, model1, link1, model2, link2):
        """Fix link2 of model2 to link1 of model1 at their current relative pose. Returns
        False when exactly this attachment exists already (nothing changes)."""
        e = self.engine
        rec1 = self._check(model1, link1)
        rec2 = self._check(model2, link2)
        if model1 == model2:
            if link1 == link2:
                raise ValueError('link %r of model %r cannot be attached to itself'
                                 % (link1, model1))
            raise ValueError('links %r and %r are both of model %r: links of one model '
                             'cannot be attached to each other (closed chains are not '
                             'simulated)' % (link1, link2, model1))
        if rec1.static and rec2.static:
            raise ValueError('models %r and %r are both static: nothing to hold'
                             % (model1, model2))
        if self.find(model1, link1, model2, link2) is not None:
            return False
        for att in self.items:
            if {att.model1, att.model2} == {model1, model2}:
                raise ValueError('models %r and %r are attached already (%s::%s - %s::%s): '
                                 'detach that first' % ((model1, model2) + att.key))
        rel = e.link_pose(model1, link1).inverse() * e.link_pose(model2, link2)
        att = Attachment(model1, link1, model2, link2, rel)
        e._fix(att, rec1, rec2)
        self.items.append(att)
        return True

    def detach(self, model1, link1, model2, link2):
        att = self.find(model1, link1, model2, link2)
        if att is None:
            return False
        self.items.remove(att)
        self.engine._unfix(att)
        return True

    def drop_model(self, name):
        """Drop (unfix) the attachments of a model being removed."""
        for att in [a for a in self.items if name in (a.model1, a.model2)]:
            self.items.remove(att)
            self.engine._unfix(att)

    def clear(self):
        for att in list(self.items):
            self.items.remove(att)
            self.engine._unfix(att)

    def moved(self, name, via=None):
        """Model ``name`` was moved without physics: carry what it holds along (at the
        stored offset, at rest; the joint's relative pose still holds, nothing is remade:
        a kinematic controller moves the arm every step), and hold it again where it is now
        if it is held (``via``: the attachment that carried it here)."""
        if self._moving or not self.items:
            return
        e = self.engine
        carried = []
        self._moving = True
        try:
            for att in list(self.items):
                if att is via:
                    continue
                if att.model1 == name:
                    if e._get(att.model2).static:
                        # a static held side cannot be carried: the holder is held there
                        self._refix(att)
                        continue
                    held = e.link_pose(att.model1, att.link1) * att.rel
                    root = e.model_pose(att.model2)
                    off = root.inverse() * e.link_pose(att.model2, att.link2)
                    e.set_model_pose(att.model2, held * off.inverse())
                    e.set_model_twist(att.model2, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
                    carried.append(att)
                elif att.model2 == name:
                    self._refix(att)
        finally:
            self._moving = False
        for att in carried:
            self.moved(att.model2, via=att)      # what the held model holds in turn

    def _refix(self, att):
        e = self.engine
        att.rel = e.link_pose(att.model1, att.link1).inverse() * \
            e.link_pose(att.model2, att.link2)
        e._unfix(att)
        e._fix(att, e._get(att.model1), e._get(att.model2))

