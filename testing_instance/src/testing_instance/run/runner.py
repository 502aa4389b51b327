"""The scenario runner: world start, lockstep timeline in sim time, verdicts, JUnit, rosbag.

    rosrun mobile_device_sim run_scenario FILE [--seed N] [--record BAG] [--junit XML]
        [--real-time-factor R] [--attach] [--replay BAG] [--jobs N DIR...]

Lockstep: the world runs paused; the runner advances it with /gazebo/step_world to the next
instant that matters (an action's time, a slice boundary while a `when` condition waits,
at most 1 s), waits until the messages of that slice have arrived (the world is paused,
so nothing new is produced meanwhile), feeds them to the expectations in the order of their
stamps, evaluates conditions, and applies due actions while the world is still paused. So
actions land at exact sim times and the verdicts and the recorded sensor messages do not
depend on the real-time factor or the machine's speed. The wall clock is only the outer
watchdog (``timeout``).

Exit codes: 0 every expectation passed, 1 at least one failed, 2 error (the scenario file is
invalid, the world could not start or died, an action failed, a topic never appeared, a
field does not exist, the watchdog fired).

The Runner holds the one loop (``run_timeline``, live and replayed alike); each of its
jobs is an object of its own module:

- ``world.worldside.WorldSide``: the master and the world (embedded, launched, warm,
  attached), its services, its processes watched, its log;
- ``world.apps.Apps``: the scenario's apps started, ready, finished or crashed, answered;
- ``intake.Intake``: the subscriptions and each message's sim time, into the
  ``inbox.Inbox`` (the slice's messages for the expectations) and the
  ``recording.Recorder`` (``--record``);
- ``clock``: what drives the one loop (``run_timeline``): the world's lockstep
  (``WorldClock``) or a recording's replay (``ReplayClock``, set up by ``replay``);
- ``actions``: the timeline's actions as objects, acting through the run's ``Hands``;
- ``scenario.timeline``: the agenda, the `when` conditions and the slice rule (pure);
  ``scenario.expect``: the expectations' verdicts; ``scenario.results``: the result and
  JUnit.
"""
import os
import shutil
import sys
import tempfile
import threading
import time

from ..scenario.expect import Expectation, FieldError, Verdict  # noqa: F401 - Verdict re-exported
from ..scenario.format import ScenarioError, load
from ..scenario.results import EXIT_ERROR, EXIT_FAIL, EXIT_PASS, Result, RunError, write_junit
from ..scenario.timeline import Agenda, ConditionError, Conditions, next_stop
from ..world import procs
from ..world.apps import Apps
from ..world.procs import free_port  # noqa: F401 - re-exported
from ..world.worldside import (LAUNCHES, PKG_ROOT, WorldSide,  # noqa: F401 - re-exported
                               launch_args, start_pose, world_key)
from .actions import Hands, action_of
from .clock import WorldClock
from .inbox import Inbox
from .intake import Intake
from .recording import EVENTS_TOPIC, HEAVY_TYPES, META_TOPIC, Recorder  # noqa: F401

__all__ = ['Runner', 'RunError', 'Result', 'run_file', 'free_port', 'EXIT_PASS', 'EXIT_FAIL',
           'EXIT_ERROR']


class Runner(object):
    def __init__(self, scenario, seed=None, real_time_factor=None, record=None, junit=None,
                 attach=False, replay=None, out=None, run_dir=None, port=None, report=None,
                 warm=None, embedded=False, on_start=None, live=False):
        self.sc = scenario
        self.live = live           # say each verdict when it is decided (--live)
        self.on_start = on_start   # called at sim time 0 (a farm's worker tells its pool)
        self.seed = scenario.seed if seed is None else int(seed)
        self.rtf = scenario.real_time_factor if real_time_factor is None \
            else float(real_time_factor)
        self.record_path = record
        self.junit = junit
        self.attach = attach or bool(scenario.world.get('attach'))
        self.replay = replay
        self.out = out or (lambda s: (sys.stdout.write(s + '\n'), sys.stdout.flush()))
        self.own_dir = run_dir is None
        self.run_dir = run_dir or tempfile.mkdtemp(prefix='scenario_')
        self.warm = warm if not (self.attach or replay) else None  # a WarmHost (warm.py)
        # the World in this process (embed.py): this node becomes the world node. 'auto':
        # when the launch file has one sim_world node (else that node runs as a process)
        self.world = WorldSide(scenario, self.run_dir, port, self.attach,
                               bool(embedded) and not (self.attach or replay or self.warm),
                               embedded is True, self.warm, self.launch_args)
        self.debug = bool(os.environ.get('SCENARIO_DEBUG'))
        self.inbox = Inbox()                 # the slice's messages, for the expectations
        self.recorder = Recorder()           # --record
        self.intake = Intake(self.inbox, self.recorder, self.say, self.debug)
        self.apps = Apps(scenario, self.world.env, self.run_dir, self.say,
                         lambda: self.intake.world_node,
                         lambda: self.world.watch.get(procs.MASTER))
        self.storage_problems = []      # lines of the recording's storage faults
        self.conditions = Conditions(scenario.timeline)   # the `when`s; what happened when
        self.timed_out = False
        self.t = 0.0
        self.report_dir, self.collector = report, None      # --report DIR (report.py)
        self.sync_wall = 0.0       # wall s spent waiting for slices to complete
        self.topic_looks = 0       # looks at the master's topics (the handshake line)
        self.agenda = Agenda()     # what is due at a sim time: actions, motion steps
        # the timeline's actions act through these (the world's services, the inputs)
        self.hands = Hands(scenario, self.world, self.agenda.push, self.say, self.check_world)
        # what drives the loop: the world in lockstep (a replay makes its own: replay.py)
        self.clock = None if replay else WorldClock(self)

    # -- the public API a clock source drives (replay.py; the live loop uses the same) ----
    def start_after(self, event_id, t):
        """Timeline event event_id happened at sim time t: start the windows after it."""
        self.conditions.happen(event_id, t)
        for e in self.expectations:
            if e.after == event_id:
                e.start(t)

    def master_uri(self):
        return self.world.master_uri()

    # the world's side (worldside.py): what the clocks, replay.py and warm.py ask of it
    port = property(lambda self: self.world.port,
                    lambda self, port: setattr(self.world, 'port', port))
    embedded = property(lambda self: self.world.embedded)
    get_state = property(lambda self: self.world.get_state)
    world_log = property(lambda self: self.world.log_tail)
    start_master = property(lambda self: self.world.start_master)     # a replay's master

    @property
    def event_times(self):
        """{event id: sim time it happened} (the report's timeline)."""
        return self.conditions.happened

    @property
    def world_node(self):
        """The caller id serving /gazebo/step_world (None: no world node, a replay)."""
        return self.intake.world_node

    def open_recording(self):
        """--record: .bag a rosbag, .mcap an MCAP file (ROS 1), a list all of them."""
        from ..io.mcap_io import RecordingError
        try:
            self.recorder.open(self.record_path)
        except RecordingError as e:
            raise RunError(str(e))

    def start_apps(self):
        self.apps.launch(self._own_pending, self._world_nodes)
        self.apps.await_ready()

    def start_at(self, t0):
        """The scenario's sim time 0 is the world's (or the recording's) ``t0``: the
        timeline and the expectations' windows count from it."""
        self.t0 = self.t = t0
        for e in self.expectations:
            e.begin(t0)

    def stamp_held(self, last=False):
        """End of a slice handshake: time the held unstamped messages (Intake). A replay of
        a pipelined run times the apps' answers at the next slice's end (but the last)."""
        self.intake.stamp_held(self.t, bool(self.replay) and self.sc.pipeline and not last)

    # -- output ----------------------------------------------------------------------------
    def say(self, text):
        self.out(text)

    # -- processes -------------------------------------------------------------------------
    def launch_args(self):
        return launch_args(self.sc, self.seed, self.rtf, self.report_dir)

    def start_pose(self):
        return start_pose(self.sc)

    def world_key(self):
        return world_key(self.sc, self.report_dir)

    # -- ROS side --------------------------------------------------------------------------
    def init_ros(self):
        os.environ.update({k: v for k, v in self.world.env().items()
                           if k in ('ROS_MASTER_URI', 'ROS_HOSTNAME')})
        import rospy
        self.rospy = rospy
        self.intake.start(rospy, self.embedded, self._own_topics)
        self.world.init_node(rospy, self.intake.on_message)
        if self.embedded:
            self.intake.on_new_publisher(self.clock.new_own_topic)

    def _world_settings(self):
        """Attached: the seed and real-time factor are the running world's."""
        seed, rtf = self.world.settings()
        self.seed = self.seed if seed is None else seed
        self.rtf = self.rtf if rtf is None else rtf

    def _services(self):
        self.intake.world_node = self.world.connect(self.check_world)
        self.step_srv = self.world.step_srv

    def _spawn_more_phones(self):
        """The scenario's phones after the first (which the launch file spawns): each the one
        description (mobile_device.urdf.xacro with the phone's ``args``, no ``ns``) spawned
        as model ``ns`` with robot_namespace ``/ns``, gazebo_ros's way to several robots
        (sim_world.spawn). An attached world may have them already (a .test file that
        spawns both): kept."""
        for ph in self.sc.phones[1:]:
            if self.attach and self.world.has_model(ph['ns']):
                continue
            xacro = os.path.join(PKG_ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')
            self.hands.spawn(ph['ns'], xacro, ph.get('position', [0, 0, 1]),
                             ph.get('rpy', [0, 0, 0]), '/' + ph['ns'].strip('/'),
                             dict(ph.get('args') or {}))

    def check_world(self):
        """Every process of the run still there? An error naming the first one that is not,
        with its log tail (also the apps: an app that exits 0 has finished, one that exits
        otherwise or is killed crashed)."""
        if self.timed_out:
            raise RunError('watchdog: the scenario did not finish within %g s of wall time '
                           '(timeout)' % self.sc.timeout, self.world_log())
        self.world.check(self._fault_t)
        self.apps.check(self.t, self._fault_t)

    def _fault_t(self):
        """The sim time of a fault: the last /clock this node saw (the world may have
        stepped past the end of the last completed slice before it died)."""
        try:
            return max(self.t, self.rospy.get_rostime().to_sec())
        except Exception:  # noqa: BLE001 - rospy not initialised (start-up)
            return self.t

    def _topic_types(self):
        self.topic_looks += 1
        try:
            return self.intake.published_types()
        except Exception as e:  # noqa: BLE001 - OSError, rosgraph.MasterException
            self.check_world()
            raise RunError('the ROS master stopped answering at sim time %.3f s (%s)'
                           % (self._fault_t(), e), self.world_log())

    def _wanted_topics(self):
        want = {}
        for e in self.expectations:
            want.setdefault(e.topic, 'expect')
        for topic in self.conditions.topics():
            want.setdefault(topic, 'condition')
        if self.recorder.active:
            types = self.intake.topic_types
            prefixes = ['/%s/' % ph['ns'].strip('/') for ph in self.sc.phones]
            for t, typ in types.items():
                if any(t.startswith(p) for p in prefixes) and typ not in HEAVY_TYPES:
                    want.setdefault(t, 'record')
            want.setdefault('/gazebo/environment', 'record')
            for t in self.sc.record:
                want.setdefault(t, 'record')
        if self.collector is not None:
            for t in self.collector.image_topics:
                want.setdefault(t, 'report')
        return want

    def subscribe_all(self, wait_connections=True):
        """Subscribe what the expectations, conditions, recording and report want and
        somebody publishes (Intake.subscribe); returns the new topics."""
        self._topic_types()
        return self.intake.subscribe(self._wanted_topics(), self._check_fields,
                                     self.apps.names(), wait_connections)

    def _check_fields(self, topic, cls):
        proto = cls()
        for e in self.expectations:
            if e.topic == topic and e.field and e.verdict is None:
                try:
                    _probe_field(proto, e.field)
                except FieldError as err:
                    e.error('field %r does not exist on %s: %s' % (e.field, cls._type, err))

    def _own_topics(self):
        """The topics this runner's actions publish on (Hands.publisher)."""
        return {topic for topic, _typ in self.hands.pubs}

    def settle(self, quiet=0.02, longest=3.0):
        """Wait until no message arrived for ``quiet`` s of wall time (the world is paused:
        what is still on its way belongs to the slice just run)."""
        self.inbox.settle(quiet, longest)

    def answered(self, w0):
        """The end of a slice handshake begun at wall time ``w0``, live or replayed (the
        clock's handshake): the apps have answered (appwatch), the held unstamped messages
        are timed; then the slice's messages, all in now, go to the recording (in its one
        order: recording.Recorder.flush; not counted as waiting)."""
        self.apps.wait_answered(self.inbox.wake)
        self.stamp_held()
        self.sync_wall += time.monotonic() - w0
        self.recorder.flush()

    def _world_nodes(self):
        """[(name, pid)] of a world node of its own, for the app watch: one handling an input
        (in its callback, or publishing what the input caused to an app) means an app that
        looks idle now has more coming (bench/load: the NFC example's OK, handled as the step
        answer went out, reached phone A during the next step, a slice late, in 2 attached
        runs of 8; with the node's threads read one by one, once in a warm farm under load
        after that). Held to the apps' rule: none of its threads ran since a reading taken
        before the look's queues."""
        return [('the world node (pid %d)' % pid, pid) for pid in self.world.world_pids()
                if pid != os.getpid()]

    def _own_pending(self, q):
        """Why the runner (or the world) still holds app messages not yet delivered, or
        None: a subscription deserialised more than reached the inbox, or bytes wait on a
        socket of this process or of the world node (``q``: procs.tcp_queues(), the app
        watch's snapshot)."""
        topic = self.intake.undelivered()
        if topic is not None:
            return 'runner: %s' % topic
        for pid in self.world.world_pids():
            if any(q.get(i, (0, 0))[1] for i in procs.socket_inodes(pid)):
                return 'bytes waiting on a socket of pid %d' % pid
        # a message off its socket, not yet through its callbacks: a receive thread of this
        # process (the runner's subscriptions; an embedded world's too) behind the GIL
        busy = procs.receivers_busy()
        if busy:
            return 'receiving %s' % busy[0]
        return None

    def drain(self):
        for t, _s, topic, msg in self.inbox.take():
            for e in self.by_topic.get(topic, ()):
                if e.verdict is None:
                    e.feed(t, msg)
                    if self.live and e.verdict is not None:
                        self.say('decided ' + e.verdict.line())
            try:
                self.conditions.feed(topic, t, msg)
            except ConditionError as e:
                raise RunError(str(e))
            if self.collector is not None:
                self.collector.feed(t, topic, msg)
            if topic == '/gazebo/environment':
                self.hands.env_values = {v.name: v.value for v in msg.values}

    # -- events ----------------------------------------------------------------------------
    def _push(self, t, fn, what):
        self.agenda.push(t, fn, what)

    def _fire(self, ev, t):
        """Event ev triggers at sim time t: schedule its action and what waits for it."""
        if not self.conditions.happen(ev['id'], t):
            return
        self.say('  t=%.3f s: %s (%s)' % (t, ev['id'], ev['action']))
        self.recorder.event(t, 'event', id=ev['id'], action=ev['action'])
        action_of(ev).apply(self.hands, t)
        for e in self.expectations:
            if e.after == ev['id']:
                e.start(t)
        for other in self.sc.timeline:
            if other.get('after') == ev['id']:
                ot = t + float(other.get('delay', 0.0))
                self._push(ot, lambda tt, o=other: self._fire(o, tt), other['id'])

    def _check_conditions(self):
        """Fire the events whose `when` holds at the end of this slice."""
        for ev in self.conditions.due(self._position):
            self._fire(ev, self.t)

    def _position(self, event_id, model):
        """(x, y, z) of ``model`` now (a reach condition of event ``event_id``)."""
        res = self.get_state(model, '')
        if not res.success:
            raise RunError('%s.when.reach: %s' % (event_id, res.status_message))
        p = res.pose.position
        return p.x, p.y, p.z

    # -- the run ---------------------------------------------------------------------------
    def run(self):
        wall0 = self.wall0 = time.monotonic()
        self.phases = []                 # (phase of the start-up, monotonic time it ended)
        self.expectations = [Expectation(e, self.sc.duration) for e in self.sc.expect]
        self.by_topic = {}
        for e in self.expectations:
            self.by_topic.setdefault(e.topic, []).append(e)
        if self.report_dir:
            from ..report import Collector
            self.collector = Collector(self, self.report_dir, 'replay' if self.replay else 'live')
        error, log = None, []
        watchdog = threading.Timer(self.sc.timeout, self._on_timeout)
        watchdog.daemon = True
        watchdog.start()
        try:
            if self.replay:
                from .replay import replay_run
                replay_run(self)
            else:
                self._run_live()
        except RunError as e:
            error, log = str(e), e.log_lines
        except KeyboardInterrupt:
            error = 'interrupted'
        finally:
            watchdog.cancel()
            self._shutdown()
        if error is None:
            verdicts = [e.finish(self.t) for e in self.expectations]
        else:
            verdicts = [e.verdict for e in self.expectations if e.verdict is not None]
        if self.storage_problems:           # the verdicts stand; the run is still an ERROR
            error = '; '.join(([error] if error else []) + self.storage_problems)
        result = Result(self.sc.name, verdicts, error, log, self.t, time.monotonic() - wall0)
        self.report(result)
        if self.collector is not None:
            self.collector.write(result)
        return result

    def _on_timeout(self):
        self.timed_out = True
        self.world.interrupt('scenario timeout')

    def _phase(self, name):
        """Mark the end of a phase of the start-up (printed with its figure)."""
        self.phases.append((name, time.monotonic()))

    def _start_world(self):
        deadline = time.monotonic() + min(self.sc.timeout, 120.0)
        # the Python apps import while the master starts and the world loads (or a warm
        # world is reset); they talk to no master before apps.launch
        self.apps.prestart()
        self.world.start(deadline)
        self._phase('master')
        if self.warm is not None:
            # a farm's warm world: started over (or launched, for a new world) at sim time 0
            self.warm.prepare(self, deadline)
            self.world.proc = self.warm.launch
            self._phase('warm world')
        # the apps go on once the master answers; start_apps waits for them
        self.apps.launch(self._own_pending, self._world_nodes)
        self.init_ros()
        self._phase('node' if not self.world.embedded else 'node and world')
        if self.attach:
            self._world_settings()
        self._services()
        self._phase('world services')
        self.world.wait_phones(deadline, self.check_world)
        self.world.find_watched()
        self._phase('phones')

    def _run_live(self):
        self._start_world()
        self._spawn_more_phones()
        if self.record_path:
            self.open_recording()
        self.start_apps()
        self._phase('apps')
        if self.warm is not None:
            # the last scenario's apps are gone (one deaf to its SIGINT was waited for)
            for name, before in self.warm.settle():
                self.say(procs.deaf_warning('app %s of scenario %s' % (name, before),
                                            ' (this start-up waited for it)'))
        self.start_at(self.clock.step_to(0.0))  # paused now (attach: wherever it was)
        self._phase('first step')
        self.intake.input_node, self.intake.hold_unstamped = self.world_node, True
        self.subscribe_all()
        self.clock.handshake()
        self.drain()
        self._phase('subscribing')
        self.startup = procs.age() if procs.first_run() else time.monotonic() - self.wall0
        if self.on_start is not None:
            self.on_start()
        self.write_meta()
        for ev in self.sc.timeline:
            if 'at' in ev:
                self._push(self.t0 + ev['at'], lambda tt, e=ev: self._fire(e, tt), ev['id'])
        w0, s0 = time.monotonic(), self.t
        self.run_timeline(self.clock, self.t0 + self.sc.duration)
        self.loop_wall = (time.monotonic() - w0, self.t - s0)

    def startup_phases(self):
        """The start-up's phases and their seconds, in order: what came before this run
        (the command's Python start and imports; in a farm's later runs nothing), then each
        marked phase; phases under 5 ms are left out."""
        if getattr(self, 'startup', None) is None or not self.phases:
            return []
        end = self.phases[-1][1]
        before = self.startup - (end - self.wall0)
        out = [('Python and imports', before)] if before >= 0.005 else []
        prev = self.wall0
        for name, t in self.phases:
            if t - prev >= 0.005:
                out.append((name, t - prev))
            prev = t
        return out

    def run_timeline(self, clock, end):
        """The one loop of a run, live or replayed, from the sim time now to ``end``: the
        due agenda entries, then a step of ``clock`` to the next instant that matters, a
        slice handshake when due, the slice's messages fed to the expectations, and the
        `when` conditions; at the end the last slice's messages and the topics that never
        appeared."""
        last_settle = self.t
        while True:
            self.check_world()
            due = self.agenda.pop_due(self.t)
            while due is not None:
                due[0](self.t)
                due = self.agenda.pop_due(self.t)
            if self.t >= end - 5e-4:
                break
            nxt = next_stop(self.t, end, clock.longest, self.agenda.next_time(),
                            bool(self.conditions.pending()), self.sc.slice)
            self.t = clock.step_to(nxt)
            # wait for the slice's messages when a topic condition waits for them, and at
            # least every settle_every s of sim time (so apps keep up); short motion slices
            # in between only step (sim-time rule: the same slices settle in every run)
            # (pipelined: every step, as the next one sends the apps what this one made)
            if self.sc.pipeline or self.conditions.wait_for_messages() or \
                    self.t - last_settle >= clock.settle_every - 1e-9:
                clock.handshake()
                last_settle = self.t
                clock.look()       # topics that appeared late (apps, spawned models)
            self.drain()
            if clock.acts:
                self._check_conditions()
        clock.finish()
        self.drain()
        # topics an expectation waits for that never appeared
        for e in self.expectations:
            if e.topic not in self.intake.subs and e.verdict is None:
                known = sorted(t for t in self.intake.topic_types if t.startswith(
                    '/' + e.topic.strip('/').split('/')[0] + '/'))
                e.error('topic %s never appeared%s%s' % (
                    e.topic, clock.absent,
                    ' (similar topics: %s)' % ', '.join(known[:8]) if known else ''))

    def write_meta(self):
        """The recording's meta: seed, inputs (what a replay feeds), t0, duration, types,
        pipeline (how a replay times the apps' answers)."""
        if not self.recorder.active:
            return
        import rosgraph
        intake = self.intake
        pubs, _subs, _srv = rosgraph.Master('/scenario_runner').getSystemState()
        inputs = intake.world_inputs(pubs)
        if getattr(self, 'replay_meta', None):
            inputs = self.replay_meta['inputs']
        self.recorder.meta(dict(scenario=os.path.abspath(self.sc.path), seed=self.seed,
                                real_time_factor=self.rtf, inputs=inputs, t0=self.t0,
                                duration=self.sc.duration, pipeline=self.sc.pipeline,
                                types={t: intake.topic_types.get(t) for t in intake.subs}),
                           self.t)

    def _shutdown(self):
        # with the world or the master gone (roslaunch takes the master down with its
        # required world) each unregister would print 'unable to communicate with ROS
        # Master' once per topic; rospy's own clean-up at exit is one quiet call
        gone = self.world.any_gone()
        self.intake.close(unregister=not gone)
        self.world.close_proxies()
        if self.warm is not None and not gone:
            # the next scenario in this process starts its inputs afresh (sequence numbers)
            for pub in self.hands.pubs.values():
                try:
                    pub.unregister()
                except Exception:  # noqa: BLE001 - not a rospy publisher
                    pass
        self.storage_problems = self.recorder.close()   # storage faults: one line each
        # a warm world stays for the next scenario
        for name in self.world.stop(self.apps.procs) or ():
            # (rospy's own handler deadlocks when the SIGINT lands during a call to the
            # master: the app waits on a lock its thread holds; preapp.py)
            self.say(procs.deaf_warning(name))
        if self.collector is not None:
            self.collector.grab_logs(self.run_dir)
        if self.own_dir and not os.environ.get('SCENARIO_KEEP_LOGS'):
            shutil.rmtree(self.run_dir, ignore_errors=True)

    def report(self, result):
        self.say('scenario %s (seed %d, real_time_factor %g): %s at sim time %.3f s, '
                 '%.1f s wall' % (result.name, self.seed, self.rtf, result.status,
                                  result.sim_time, result.wall))
        lw = getattr(self, 'loop_wall', None)
        if lw and lw[0] > 0:
            self.say('timeline: %.3f s of sim time in %.2f s of wall time (real-time factor '
                     '%.2f)' % (lw[1], lw[0], lw[1] / lw[0]))
        if getattr(self, 'startup', None) is not None:
            parts = ', '.join('%s %.2f' % p for p in self.startup_phases())
            self.say('start-up: %.2f s from the command to sim time 0%s'
                     % (self.startup, ' (%s)' % parts if parts else ''))
        if self.world_node is not None and not self.replay:
            got = sum(self.inbox.from_world.values())
            dropped = {t: d for t, d in self.clock.dropped.items()
                       if t in self.intake.subs}   # (rospy's own /clock: not ours)
            lost = sum(dropped.values())
            self.say('handshake: %d messages from the world, %d dropped by its queues%s; '
                     '%.2f s of wall time waiting for slices%s; %d looks for new topics' % (
                         got, lost, '' if not lost else ' (%s)' % ', '.join(
                             '%s %d' % kv for kv in sorted(dropped.items())),
                         self.sync_wall, '' if self.apps.waited is None else
                         ' (%.2f s of it for the apps to answer)' % self.apps.waited,
                         self.topic_looks))
        for v in result.verdicts:
            self.say(v.line())
        if result.error:
            self.say('ERROR %s' % result.error)
            if result.log_lines:
                self.say('  last lines of the world/app log:')
                for ln in result.log_lines:
                    self.say('  | ' + ln)
        if self.junit:
            try:
                write_junit(result, self.junit)
            except OSError as e:
                self.say('ERROR cannot write the JUnit file %s: %s' % (self.junit,
                                                                       e.strerror or e))
                if result.error is None:
                    result.error = 'cannot write the JUnit file %s' % self.junit


def _probe_field(proto, path):
    """Check that a field path's names exist on a default message (indexes not checked)."""
    v = proto
    for part in path.split('.'):
        name = part.split('[')[0]
        if not name:
            continue
        slots = getattr(v, '__slots__', None)
        if slots is None:
            return
        if name not in slots:
            raise FieldError('%s has no field %r (fields: %s)' % (
                type(v).__name__, name, ', '.join(slots)))
        v = getattr(v, name)
        if '[' in part:
            return   # element types of arrays: checked on the first message


def run_file(path, **kw):
    """Load and run one scenario file; ScenarioError -> an ERROR result (exit code 2)."""
    out = kw.get('out') or (lambda s: (sys.stdout.write(s + '\n'), sys.stdout.flush()))
    values = kw.pop('values', None)       # --set NAME=VALUE (testing_instance.scenario.params)
    try:
        sc = load(path, values=values)
    except ScenarioError as e:
        out('ERROR scenario file %s is invalid:' % path)
        for p in e.problems:
            out('  ' + p)
        res = Result(os.path.splitext(os.path.basename(path))[0], [],
                     'invalid scenario file: %s' % '; '.join(e.problems))
        if kw.get('junit'):
            write_junit(res, kw['junit'])
        if kw.get('report'):
            from ..report import write_invalid
            write_invalid(kw['report'], path, e.problems, out)
        return res
    return Runner(sc, **kw).run()
