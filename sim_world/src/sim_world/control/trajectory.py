"""ros_controllers' joint_trajectory_controller in pure Python (issue 48 part 4): no ROS, no
world. ``JointTrajectoryController`` runs inside sim_world.control.controllers'
ControllerManager at every physics step, in sim time, against the same hardware interface.

As ros_controllers does it:

- a trajectory is, per joint, a list of spline segments (QuinticSplineSegment): linear
  between points with positions only, cubic with velocities, quintic with accelerations; a
  sample before a segment holds its start, after its end holds its end at rest;
- a new trajectory (the ``command`` topic or a ``follow_joint_trajectory`` goal) starts at
  its header stamp (zero: now); the current trajectory keeps running until then, and a
  bridge segment joins its state at that time to the first new point; points in the past are
  dropped (a first point at time 0 with a zero stamp silently); continuous joints take the
  turn nearest to the current position;
- refused: points not strictly increasing in time, a point whose positions, velocities or
  accelerations do not have one value per joint, joint names that are not the controller's
  (INVALID_JOINTS), every point in the past, the controller stopped;
- tolerances (``constraints``: ``goal_time``, ``stopped_velocity_tolerance`` (0.01),
  ``<joint>/trajectory``, ``<joint>/goal``; a goal's ``path_tolerance``, ``goal_tolerance``
  and ``goal_time_tolerance`` override them, 0 keeps, -1 erases): a path error beyond its
  tolerance aborts the goal (PATH_TOLERANCE_VIOLATED); after the last point the goal succeeds
  once every joint is within its goal tolerance (position, and velocity within
  stopped_velocity_tolerance), or aborts after ``goal_time`` (GOAL_TOLERANCE_VIOLATED);
- an empty trajectory, a cancel or a stop holds the current position;
- ``position_controllers/JointTrajectoryController`` sends the desired position (kinematic
  on a PositionJointInterface without PID, as DefaultRobotHWSim);
  ``effort_controllers/JointTrajectoryController`` a PID effort per joint (``gains/<joint>:
  {p, i, d, i_clamp}``) on the position and velocity errors.

Goals come through a handle (the ROS side's actionlib goal handle, or a test's recorder):
``accept()``, ``reject(code, text)``, ``succeed(code, text)``, ``abort(code, text)``,
``cancel()``, ``feedback(state)``. Goals and commands are queued by any thread
(``submit_goal``, ``submit_command``, ``submit_cancel``) and applied at the next update, in
the world's step, so a lockstep run applies them at a known step.
"""
import bisect
import collections
import math
import threading

from .controllers import Controller, ControllerError, Pid, _angle_diff, _num

__all__ = ['Point', 'Trajectory', 'JointTrajectoryController', 'SUCCESSFUL', 'INVALID_GOAL',
           'INVALID_JOINTS', 'OLD_HEADER_TIMESTAMP', 'PATH_TOLERANCE_VIOLATED',
           'GOAL_TOLERANCE_VIOLATED', 'TrajectoryError']

# control_msgs/FollowJointTrajectoryResult error codes
SUCCESSFUL, INVALID_GOAL, INVALID_JOINTS, OLD_HEADER_TIMESTAMP = 0, -1, -2, -3
PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED = -4, -5


class TrajectoryError(ValueError):
    """A trajectory refused; ``code`` is the FollowJointTrajectoryResult error code."""

    def __init__(self, code, text):
        ValueError.__init__(self, text)
        self.code = code


# -- splines (trajectory_interface::QuinticSplineSegment) --------------------------------------
def _coefficients(p0, v0, a0, p1, v1, a1, T, order):
    if order == 1:
        return (p0, 0.0 if T == 0 else (p1 - p0) / T, 0.0, 0.0, 0.0, 0.0)
    if T == 0:
        return (p0, v0, 0.5 * a0 if order == 5 else 0.0, 0.0, 0.0, 0.0)
    if order == 3:
        return (p0, v0, (-3 * p0 + 3 * p1 - 2 * v0 * T - v1 * T) / T ** 2,
                (2 * p0 - 2 * p1 + v0 * T + v1 * T) / T ** 3, 0.0, 0.0)
    T2, T3, T4, T5 = T * T, T ** 3, T ** 4, T ** 5
    return (p0, v0, 0.5 * a0,
            (-20 * p0 + 20 * p1 - 3 * a0 * T2 + a1 * T2 - 12 * v0 * T - 8 * v1 * T) / (2 * T3),
            (30 * p0 - 30 * p1 + 3 * a0 * T2 - 2 * a1 * T2 + 16 * v0 * T + 14 * v1 * T) / (2 * T4),
            (-12 * p0 + 12 * p1 - a0 * T2 + a1 * T2 - 6 * v0 * T - 6 * v1 * T) / (2 * T5))


def _poly(c, t):
    p = c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))))
    v = c[1] + t * (2 * c[2] + t * (3 * c[3] + t * (4 * c[4] + t * 5 * c[5])))
    a = 2 * c[2] + t * (6 * c[3] + t * (12 * c[4] + t * 20 * c[5]))
    return p, v, a


class State(object):
    """One joint's position, and velocity / acceleration when given (None: not given)."""
    __slots__ = ('p', 'v', 'a')

    def __init__(self, p, v=None, a=None):
        self.p, self.v, self.a = p, v, a


class Segment(object):
    """One joint's spline from ``t0`` to ``t1``; ``goal`` and ``tol`` of the goal it serves."""
    __slots__ = ('t0', 'duration', 'c', 'goal', 'tol', 'p0', 'p1')

    def __init__(self, t0, s0, t1, s1, goal=None, tol=None):
        if t1 < t0:
            raise TrajectoryError(INVALID_GOAL, 'segment ends before it starts')
        order = 1
        if s0.v is not None and s1.v is not None:
            order = 5 if (s0.a is not None and s1.a is not None) else 3
        self.t0, self.duration = t0, t1 - t0
        self.c = _coefficients(s0.p, s0.v or 0.0, s0.a or 0.0, s1.p, s1.v or 0.0, s1.a or 0.0,
                               self.duration, order)
        self.goal, self.tol = goal, tol
        # where it holds before and after (a held pose is sampled there every step)
        self.p0 = _poly(self.c, 0.0)[0]
        self.p1 = _poly(self.c, self.duration)[0]

    @property
    def t1(self):
        return self.t0 + self.duration

    def sample(self, t):
        dt = t - self.t0
        if dt < 0:
            return self.p0, 0.0, 0.0
        if dt > self.duration:
            return self.p1, 0.0, 0.0
        return _poly(self.c, dt)


def find_segment(segments, t, hint=-1):
    """Index of the segment active at ``t`` (the last one starting at or before it; the
    first one before every start). ``hint``: the index found last time, checked first, then
    the one after it (a sample every step stays in its segment or moves to the next), before
    a binary search."""
    n = len(segments)
    if 0 <= hint < n:
        for k in (hint, hint + 1):
            if k < n and (k == 0 or segments[k].t0 <= t) and \
                    (k + 1 == n or segments[k + 1].t0 > t):
                return k
    return max(0, bisect.bisect_right(segments, t, key=_start) - 1)


def _start(segment):
    return segment.t0


class Point(object):
    """A trajectory point: positions, velocities, accelerations (lists, possibly empty) and
    its time from the start in s."""

    def __init__(self, positions, velocities=(), accelerations=(), time_from_start=0.0):
        self.positions = [float(x) for x in positions]
        self.velocities = [float(x) for x in velocities]
        self.accelerations = [float(x) for x in accelerations]
        self.time_from_start = float(time_from_start)


class Trajectory(object):
    """A trajectory_msgs/JointTrajectory without ROS: joint names, start time (s of sim time;
    0: now) and points."""

    def __init__(self, joint_names, points, start_time=0.0):
        self.joint_names = list(joint_names)
        self.points = list(points)
        self.start_time = float(start_time)

    @classmethod
    def from_msg(cls, msg):
        pts = [Point(p.positions, p.velocities, p.accelerations, p.time_from_start.to_sec())
               for p in msg.points]
        return cls(msg.joint_names, pts, msg.header.stamp.to_sec())


class Tolerances(object):
    """Per joint: path (position, velocity, acceleration), goal (the same), and the goal
    time tolerance (s)."""

    def __init__(self, path, goal, goal_time):
        self.path, self.goal, self.goal_time = path, goal, goal_time

    def copy(self):
        return Tolerances([list(x) for x in self.path], [list(x) for x in self.goal],
                          self.goal_time)

    def apply(self, joint_names, path_tolerance=(), goal_tolerance=(), goal_time=0.0):
        """A goal's JointTolerance entries (name, position, velocity, acceleration): > 0 sets,
        < 0 erases (no check), 0 keeps the default; goal_time > 0 sets, < 0 erases."""
        for entries, table in ((path_tolerance, self.path), (goal_tolerance, self.goal)):
            for e in entries:
                name, vals = e[0], e[1:]
                if name not in joint_names:
                    continue
                row = table[joint_names.index(name)]
                for k, v in enumerate(vals):
                    if v > 0:
                        row[k] = float(v)
                    elif v < 0:
                        row[k] = 0.0
        if goal_time > 0:
            self.goal_time = float(goal_time)
        elif goal_time < 0:
            self.goal_time = 0.0


def _within(err, tol):
    return all(not (t > 0 and abs(e) > t) for e, t in zip(err, tol))


class _Goal(object):
    """A goal being executed: its handle, tolerances, per-joint success flags."""

    def __init__(self, handle, tol):
        self.handle, self.tol = handle, tol


class JointTrajectoryController(Controller):
    """Base of the two hardware variants (``POSITION`` / ``EFFORT`` below)."""
    TYPE = ''
    INTERFACE = None
    MULTI = True

    def load(self, params):
        n = self.name
        self.state_publish_rate = _num(params, 'state_publish_rate', n, 50.0,
                                       lambda x: x >= 0, 'must be >= 0 Hz')
        self.action_monitor_rate = _num(params, 'action_monitor_rate', n, 20.0,
                                        lambda x: x > 0, 'must be > 0 Hz')
        self.stop_trajectory_duration = _num(params, 'stop_trajectory_duration', n, 0.0,
                                             lambda x: x >= 0, 'must be >= 0 s')
        partial = params.get('allow_partial_joints_goal', False)
        if not isinstance(partial, bool):
            raise ControllerError('%s/allow_partial_joints_goal must be true or false, got %r'
                                  % (n, partial))
        self.allow_partial = partial
        cons = params.get('constraints', {})
        if not isinstance(cons, dict):
            raise ControllerError('%s/constraints must be a dict (goal_time, '
                                  'stopped_velocity_tolerance, <joint>: {trajectory, goal})' % n)
        where = '%s/constraints' % n
        svt = _num(cons, 'stopped_velocity_tolerance', where, 0.01, lambda x: x >= 0,
                   'must be >= 0')
        goal_time = _num(cons, 'goal_time', where, 0.0, lambda x: x >= 0, 'must be >= 0 s')
        path, goal = [], []
        for j in self.joints:
            jc = cons.get(j, {})
            if not isinstance(jc, dict):
                raise ControllerError('%s/%s must be a dict (trajectory, goal)' % (where, j))
            path.append([_num(jc, 'trajectory', '%s/%s' % (where, j), 0.0, lambda x: x >= 0,
                              'must be >= 0'), 0.0, 0.0])
            goal.append([_num(jc, 'goal', '%s/%s' % (where, j), 0.0, lambda x: x >= 0,
                              'must be >= 0'), svt, 0.0])
        for k in cons:
            if k not in self.joints and k not in ('stopped_velocity_tolerance', 'goal_time'):
                raise ControllerError('%s/%s: %r is not one of the controller\'s joints (%s)'
                                      % (where, k, k, ', '.join(self.joints)))
        self.default_tol = Tolerances(path, goal, goal_time)
        self.wraps = [self.hw.joint_type(j) == 'continuous' for j in self.joints]
        self.load_gains(params)
        self.segments = None          # per joint: [Segment]
        self.at = []                  # per joint: its segment's index at the last update
        self.goal = None              # the _Goal being executed
        self.done = [False] * len(self.joints)
        self.inbox = collections.deque()
        self.inbox_lock = threading.Lock()
        self.on_state = None          # callable(state dict) set by the ROS side
        self.last_state = None
        self.time = 0.0
        self.feedback_next = 0.0
        self.state_next = 0.0

    def load_gains(self, params):
        pass

    # -- from any thread ----------------------------------------------------------------------
    def submit_goal(self, traj, handle, path_tolerance=(), goal_tolerance=(), goal_time=0.0):
        with self.inbox_lock:
            self.inbox.append(('goal', traj, handle, (path_tolerance, goal_tolerance, goal_time)))

    def submit_command(self, traj):
        with self.inbox_lock:
            self.inbox.append(('command', traj, None, None))

    def submit_cancel(self, handle):
        with self.inbox_lock:
            self.inbox.append(('cancel', None, handle, None))

    # -- the controller ----------------------------------------------------------------------
    def starting(self, t):
        self.time = t
        if getattr(self, 'goal', None) is not None:      # the world was reset under it
            self.goal.handle.abort(INVALID_GOAL, '%s restarted (world reset)' % self.name)
            self.goal = None
        self.hold(t)
        self.state_next = t
        self.feedback_next = t
        self.done = [False] * len(self.joints)

    def stopping(self):
        """Stopped by a switch or the plugin's end: a goal being executed is aborted."""
        self._drain(self.time, accept=False)
        if self.goal is not None:
            self.goal.handle.abort(INVALID_GOAL, '%s was stopped' % self.name)
            self.goal = None

    def hold(self, t, goal=None):
        """Hold the current position (ros_controllers' setHoldPosition). With
        ``stop_trajectory_duration`` T > 0 a moving joint is brought to rest in T: the segment
        ends where a quintic from (q, v) to (q, -v) over 2T is at its midpoint (where its
        velocity is 0: 5/8 v T further on), as ros_controllers builds it; with 0, at once."""
        T = self.stop_trajectory_duration
        self.segments = []
        for j in self.joints:
            q, v = self.hw.state(j)[:2]
            if T > 0 and v:
                s0 = State(q, v, 0.0)
                end = State(*Segment(t, s0, t + 2 * T, State(q, -v, 0.0)).sample(t + T))
                self.segments.append([Segment(t, s0, t + T, end, goal)])
            else:
                s = State(q, 0.0, 0.0)
                self.segments.append([Segment(t, s, t, s, goal)])

    def sample(self, t, at=None):
        """(positions, velocities, accelerations) of the current trajectory at ``t``. ``at``:
        a list of each joint's segment index, used as hints and set to the ones at ``t``
        (update keeps its own in ``self.at``: sampled every step, a joint stays in its segment
        or moves to the next)."""
        ps, vs, accs = out = ([], [], [])
        if at is None or len(at) != len(self.segments):
            at = [-1] * len(self.segments)
        for i, segs in enumerate(self.segments):
            k = at[i] = find_segment(segs, t, at[i])
            p, v, a = segs[k].sample(t)
            ps.append(p)
            vs.append(v)
            accs.append(a)
        return out

    def update(self, t, dt):
        self.time = t
        self._drain(t)
        n = len(self.joints)
        if len(self.at) != len(self.segments):
            self.at = [-1] * len(self.segments)
        des_p, des_v, des_a = self.sample(t, self.at)
        act = self.read_states()
        err_p = [(_angle_diff(des_p[i], act[i][0]) if self.wraps[i] else des_p[i] - act[i][0])
                 for i in range(n)]
        err_v = [des_v[i] - act[i][1] for i in range(n)]
        goal = self.goal
        if goal is not None:
            for i in range(n):
                seg = self.segments[i][self.at[i]]         # found by sample(t)
                if seg.goal is not goal:
                    continue
                err = (err_p[i], err_v[i], 0.0)
                if t < seg.t1:
                    if not _within(err, goal.tol.path[i]):
                        self._finish('abort', PATH_TOLERANCE_VIOLATED, '%s path error %f'
                                     % (self.joints[i], err_p[i]))
                        break
                elif seg is self.segments[i][-1]:
                    if _within(err, goal.tol.goal[i]):
                        self.done[i] = True
                    elif t < seg.t1 + goal.tol.goal_time - 1e-9:
                        pass
                    else:
                        self._finish('abort', GOAL_TOLERANCE_VIOLATED, '%s goal error %f'
                                     % (self.joints[i], err_p[i]))
                        break
            if self.goal is not None and all(self.done):
                self._finish('succeed', SUCCESSFUL, '')
        self.command(des_p, des_v, err_p, err_v, dt)
        state = {'time': t, 'joint_names': list(self.joints),
                 'desired': (des_p, des_v, des_a),
                 'actual': ([a[0] for a in act], [a[1] for a in act]),
                 'error': (err_p, err_v)}
        self.last_state = state
        if self.goal is not None and t + 1e-9 >= self.feedback_next:
            self.feedback_next = t + 1.0 / self.action_monitor_rate
            self.goal.handle.feedback(state)
        if self.state_publish_rate > 0 and t + 1e-9 >= self.state_next:
            self.state_next += 1.0 / self.state_publish_rate
            if self.state_next <= t:
                self.state_next = t + 1.0 / self.state_publish_rate
            if self.on_state is not None:
                self.on_state(state)

    def command(self, des_p, des_v, err_p, err_v, dt):
        raise NotImplementedError

    def _finish(self, how, code, text):
        g, self.goal = self.goal, None
        self.done = [False] * len(self.joints)
        if how == 'succeed':
            g.handle.succeed(code, text)
        else:
            self.hw_log('%s: goal aborted: %s' % (self.name, text))
            g.handle.abort(code, text)

    def hw_log(self, text):
        import logging
        logging.getLogger('sim_world.control').error('controller_manager: %s', text)

    # -- goals and commands, applied in the world's step ----------------------------------------
    def _drain(self, t, accept=True):
        if not self.inbox:        # (an item appended meanwhile waits for the next update)
            return
        with self.inbox_lock:
            items = list(self.inbox)
            self.inbox.clear()
        for kind, traj, handle, tol in items:
            if kind == 'cancel':
                if self.goal is not None and self.goal.handle is handle:
                    self.goal = None
                    self.done = [False] * len(self.joints)
                    self.hold(t)
                    handle.cancel()
                continue
            if not accept or not self.running:
                if handle is not None:
                    handle.reject(INVALID_GOAL, "Can't accept new action goals. Controller "
                                                "is not running.")
                continue
            try:
                if kind == 'goal':
                    self._check_joints(traj)
                    tols = self.default_tol.copy()
                    tols.apply(self.joints, *tol)
                    g = _Goal(handle, tols)
                    self._set(traj, t, g)
                    if self.goal is not None:
                        self.goal.handle.cancel()          # preempted by the new goal
                    handle.accept()
                    self.goal = g
                    self.done = [False] * len(self.joints)
                else:
                    self._set(traj, t, None)
                    if self.goal is not None:              # a command preempts the goal
                        self.goal.handle.cancel()
                        self.goal = None
            except TrajectoryError as e:
                self.hw_log('%s: trajectory refused: %s' % (self.name, e))
                if handle is not None:
                    handle.reject(e.code, str(e))

    def _check_joints(self, traj):
        names = traj.joint_names
        if not self.allow_partial and len(names) != len(self.joints):
            raise TrajectoryError(INVALID_JOINTS, "Joints on incoming goal don't match the "
                                  "controller joints: got %s, controller has %s"
                                  % (list(names), self.joints))
        bad = [j for j in names if j not in self.joints]
        if bad or len(set(names)) != len(names):
            raise TrajectoryError(INVALID_JOINTS, "Joints on incoming goal don't match the "
                                  "controller joints: %s not in %s"
                                  % (bad or list(names), self.joints))

    def _set(self, traj, now, goal):
        """The new per-joint segments (ros_controllers' initJointTrajectory)."""
        if not traj.points:
            self.hold(now, goal)
            return
        self._check_joints(traj)
        pts = traj.points
        for k, p in enumerate(pts):
            for what, vals in (('positions', p.positions), ('velocities', p.velocities),
                               ('accelerations', p.accelerations)):
                if what == 'positions' and len(vals) != len(traj.joint_names) or \
                        vals and len(vals) != len(traj.joint_names):
                    raise TrajectoryError(INVALID_GOAL, 'point %d has %d %s for %d joints'
                                          % (k, len(vals), what, len(traj.joint_names)))
                if not all(math.isfinite(x) for x in vals):
                    raise TrajectoryError(INVALID_GOAL, 'point %d has a non-finite value in '
                                          'its %s' % (k, what))
            if not math.isfinite(p.time_from_start):
                raise TrajectoryError(INVALID_GOAL, 'point %d: time_from_start is not finite'
                                      % k)
            if k and p.time_from_start <= pts[k - 1].time_from_start:
                raise TrajectoryError(INVALID_GOAL, 'Trajectory message contains waypoints '
                                      'that are not strictly increasing in time (point %d at '
                                      '%g s, point %d at %g s)' % (
                                          k - 1, pts[k - 1].time_from_start, k,
                                          p.time_from_start))
        start = traj.start_time if traj.start_time > 0 else now
        # the first point after now (the ones before are dropped)
        first = 0
        while first < len(pts) and start + pts[first].time_from_start <= now:
            first += 1
        if first == len(pts):
            raise TrajectoryError(INVALID_GOAL, 'Dropping all %d trajectory point(s), as they '
                                  'occur before the current time. Last point is %g s in the '
                                  'past.' % (len(pts), now - start - pts[-1].time_from_start))
        bridge_t = max(start, now)
        tol = goal.tol if goal is not None else None
        new = []
        for i, j in enumerate(self.joints):
            if j not in traj.joint_names:
                new.append(self.segments[i])            # partial goal: this joint keeps its own
                continue
            m = traj.joint_names.index(j)
            segs = self.segments[i]
            a = find_segment(segs, now)
            b = find_segment(segs, bridge_t)
            keep = segs[a:b + 1]
            p0, v0, a0 = segs[b].sample(bridge_t)

            def state(p, off=0.0):
                return State(p.positions[m] + off,
                             p.velocities[m] if p.velocities else None,
                             p.accelerations[m] if p.accelerations else None)
            off = 0.0
            if self.wraps[i]:
                q1 = pts[first].positions[m]
                off = (p0 + _angle_diff(q1, p0)) - q1
            out = list(keep)
            out.append(Segment(bridge_t, State(p0, v0, a0),
                               start + pts[first].time_from_start, state(pts[first], off),
                               goal, tol))
            for k in range(first, len(pts) - 1):
                out.append(Segment(start + pts[k].time_from_start, state(pts[k], off),
                                   start + pts[k + 1].time_from_start, state(pts[k + 1], off),
                                   goal, tol))
            new.append(out)
        self.segments = new

    def query_state(self, t):
        """(names, positions, velocities, accelerations) of the trajectory at sim time t
        (the query_state service); ControllerError when stopped."""
        if not self.running or self.segments is None:
            raise ControllerError("%s: Can't sample trajectory. Controller is not running."
                                  % self.name)
        p, v, a = self.sample(t)
        return list(self.joints), p, v, a


class PositionJointTrajectoryController(JointTrajectoryController):
    TYPE = 'position_controllers/JointTrajectoryController'
    INTERFACE = 'position'

    def command(self, des_p, des_v, err_p, err_v, dt):
        many = getattr(self.hw, 'commands', None)
        if many is not None:
            many(self.joints, 'position', des_p)
            return
        for j, q in zip(self.joints, des_p):
            self.hw.command(j, 'position', q)


class EffortJointTrajectoryController(JointTrajectoryController):
    TYPE = 'effort_controllers/JointTrajectoryController'
    INTERFACE = 'effort'

    def load_gains(self, params):
        gains = params.get('gains')
        if not isinstance(gains, dict):
            raise ControllerError('%s/gains is missing (gains: {<joint>: {p, i, d, i_clamp}})'
                                  % self.name)
        self.pids = [Pid.from_params(gains.get(j), '%s/gains/%s' % (self.name, j))
                     for j in self.joints]

    def starting(self, t):
        JointTrajectoryController.starting(self, t)
        for p in self.pids:
            p.reset()

    def command(self, des_p, des_v, err_p, err_v, dt):
        for j, pid, ep, ev in zip(self.joints, self.pids, err_p, err_v):
            self.hw.command(j, 'effort', pid.compute(ep, ev, dt))


class VelocityJointTrajectoryController(EffortJointTrajectoryController):
    """velocity_controllers/JointTrajectoryController: ros_controllers' velocity adapter, the
    command is ``velocity_ff/<joint>`` (default 0) times the desired velocity plus the PID
    (``gains/<joint>``) of the position and velocity errors; 0 when it starts."""
    TYPE = 'velocity_controllers/JointTrajectoryController'
    INTERFACE = 'velocity'

    def load_gains(self, params):
        EffortJointTrajectoryController.load_gains(self, params)
        ff = params.get('velocity_ff', {})
        if not isinstance(ff, dict):
            raise ControllerError('%s/velocity_ff must be a dict ({<joint>: factor}), got %r'
                                  % (self.name, ff))
        self.velocity_ff = [_num(ff, j, '%s/velocity_ff' % self.name, 0.0) for j in self.joints]

    def starting(self, t):
        EffortJointTrajectoryController.starting(self, t)
        for j in self.joints:
            self.hw.command(j, 'velocity', 0.0)

    def command(self, des_p, des_v, err_p, err_v, dt):
        for j, pid, ff, dv, ep, ev in zip(self.joints, self.pids, self.velocity_ff, des_v,
                                          err_p, err_v):
            self.hw.command(j, 'velocity', ff * dv + pid.compute(ep, ev, dt))
