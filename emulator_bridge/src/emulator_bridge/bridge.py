"""The simulated phone's sensors into an unmodified Android emulator, through its console.

The Android emulator listens on a telnet console (``localhost:5554`` for the first one)
and accepts sensor values, location, battery and signal there (``telnet localhost 5554``,
``adb emu ...``). This module is the ROS-free part of ``emulator_bridge``:

- unit conversions from the phone's SI messages to Android's units (T -> uT, Pa -> hPa,
  m -> cm, fraction -> percent, orientation quaternion -> azimuth/pitch/roll in degrees);
- command builders: one function per message type giving ``(kind, command)`` pairs
  (``kind`` is what the rate limit and the once-per-kind KO log count by);
- :class:`ConsoleClient`: the console protocol (banner, ``auth <token>`` when the console
  asks for it, one reply per command: ``OK`` or ``KO: <reason>``);
- :class:`Bridge`: latest value per kind, sent at most ``rate`` times per second of WALL
  time (the emulator runs on the wall clock, whatever the simulation's real-time factor),
  reconnects when the console closes (also in the middle of a command) or the emulator
  restarts, one log line per retry period while no emulator listens.

Console grammar (Android emulator docs "Send emulator console commands",
android/console.cpp): on connect the console prints lines ending with ``OK``; a console
with authentication prints ``Android Console: Authentication required`` and the path of
the token file (``~/.emulator_console_auth_token``) first and wants ``auth <token>``; a
wrong token gets ``KO: authentication token does not match ...``.
"""
import math
import os
import socket
import threading
import time

import numpy as np

from sim_world.logonce import LogOnce
from sim_world.transforms import quat_normalize, quat_to_matrix

DEFAULT_TOKEN_FILE = '~/.emulator_console_auth_token'
G = 9.80665

# ---------------------------------------------------------------------------- conversions


def tesla_to_microtesla(t):
    return float(t) * 1e6


def pa_to_hpa(pa):
    return float(pa) / 100.0


def m_to_cm(m):
    return float(m) * 100.0


def fraction_to_percent(f):
    return float(f) * 100.0


def mbit_to_kbit(mbit):
    return float(mbit) * 1000.0


def orientation_angles(q, north_alpha_deg=90.0):
    """(azimuth, pitch, roll) in degrees, Android's convention, of the device frame whose
    orientation in the world is the quaternion ``q`` (x, y, z, w; device -> world).

    North is at ``north_alpha_deg`` counter-clockwise from the world x axis (the world's
    ``north_alpha``), up is world +z. As ``SensorManager.getRotationMatrix`` +
    ``getOrientation``: R maps device to (east, north, up); azimuth = atan2(R01, R11) in
    [0, 360) (0 = the top of the phone at north, 90 = east), pitch = asin(-R21) (negative
    when the top edge tilts up: upright is -90), roll = atan2(-R20, R22) (positive when the
    right edge goes down). Face up, top at north: 0, 0, 0."""
    a = math.radians(north_alpha_deg)
    north = np.array([math.cos(a), math.sin(a), 0.0])
    east = np.array([math.sin(a), -math.cos(a), 0.0])
    up = np.array([0.0, 0.0, 1.0])
    r = np.vstack([east, north, up]).dot(quat_to_matrix(quat_normalize(q)))
    azimuth = math.degrees(math.atan2(r[0, 1], r[1, 1])) % 360.0
    pitch = math.degrees(math.asin(max(-1.0, min(1.0, -r[2, 1]))))
    roll = math.degrees(math.atan2(-r[2, 0], r[2, 2]))
    if azimuth >= 360.0 - 5e-7:
        azimuth = 0.0
    return azimuth, pitch + 0.0, roll + 0.0


def fmt(v):
    """A number as the console's sscanf("%g") reads it, 6 significant digits."""
    v = float(v)
    if v == 0:
        v = 0.0  # no "-0"
    return '%.6g' % v


def vec(*vs):
    return ':'.join(fmt(v) for v in vs)


# ------------------------------------------------------------------------ command builders
# Each takes a ROS message (duck-typed: any object with the fields) and returns a list of
# (kind, command) pairs; an empty list: nothing to send for this message.

def _finite(*vs):
    return all(math.isfinite(float(v)) for v in vs)


def imu_commands(msg, north_alpha_deg=None):
    """sensor_msgs/Imu (already in Android's device frame): acceleration m/s^2, gyroscope
    rad/s, and orientation when the message has one and the world's north is known."""
    out = []
    a, w, o = msg.linear_acceleration, msg.angular_velocity, msg.orientation
    if _finite(a.x, a.y, a.z):
        out.append(('acceleration', 'sensor set acceleration ' + vec(a.x, a.y, a.z)))
    if _finite(w.x, w.y, w.z):
        out.append(('gyroscope', 'sensor set gyroscope ' + vec(w.x, w.y, w.z)))
    has_orientation = (list(msg.orientation_covariance)[:1] != [-1.0]
                       and _finite(o.x, o.y, o.z, o.w)
                       and (o.x, o.y, o.z, o.w) != (0, 0, 0, 0))
    if has_orientation and north_alpha_deg is not None:
        az, pitch, roll = orientation_angles((o.x, o.y, o.z, o.w), north_alpha_deg)
        out.append(('orientation', 'sensor set orientation ' + vec(az, pitch, roll)))
    return out


def magnetic_commands(msg):
    f = msg.magnetic_field
    if not _finite(f.x, f.y, f.z):
        return []
    return [('magnetic-field', 'sensor set magnetic-field '
             + vec(*(tesla_to_microtesla(v) for v in (f.x, f.y, f.z))))]


def temperature_commands(msg):
    t = msg.temperature
    return [('temperature', 'sensor set temperature ' + fmt(t))] if _finite(t) else []


def proximity_commands(msg):
    r = msg.range
    if not _finite(r):           # REP 117: +inf = nothing within range
        r = msg.max_range if (_finite(msg.max_range) and r > 0) else msg.min_range
    return [('proximity', 'sensor set proximity ' + fmt(m_to_cm(r)))] if _finite(r) else []


def illuminance_commands(msg):
    v = msg.illuminance
    return [('light', 'sensor set light ' + fmt(v))] if _finite(v) else []


def pressure_commands(msg):
    v = msg.fluid_pressure
    return [('pressure', 'sensor set pressure ' + fmt(pa_to_hpa(v)))] if _finite(v) else []


def humidity_commands(msg):
    v = msg.relative_humidity
    if not _finite(v):
        return []
    return [('humidity', 'sensor set humidity '
             + fmt(max(0.0, min(100.0, fraction_to_percent(v)))))]


def fix_commands(msg, satellites=8):
    """NavSatFix -> ``geo fix <longitude> <latitude> <altitude> <satellites>`` (longitude
    first) while status.status >= 0 (a fix); nothing without a fix. The console takes 1..12
    satellites."""
    if msg.status.status < 0 or not _finite(msg.latitude, msg.longitude):
        return []
    alt = msg.altitude if _finite(msg.altitude) else 0.0
    sats = int(max(1, min(12, satellites)))
    return [('geo', 'geo fix %s %s %s %d' % ('%.7f' % msg.longitude, '%.7f' % msg.latitude,
                                              '%.2f' % alt, sats))]


# sensor_msgs/BatteryState constants
_STATUS = {1: 'charging', 2: 'discharging', 3: 'not-charging', 4: 'full'}


def battery_commands(msg):
    """BatteryState -> ``power capacity``, ``power status``, ``power ac`` (the charger is
    plugged while charging, full or not charging)."""
    out = []
    if _finite(msg.percentage):
        pct = int(round(max(0.0, min(1.0, msg.percentage)) * 100))
        out.append(('power capacity', 'power capacity %d' % pct))
    status = _STATUS.get(int(msg.power_supply_status))
    if status:
        out.append(('power status', 'power status ' + status))
        out.append(('power ac', 'power ac ' + ('off' if status == 'discharging' else 'on')))
    return out


def cell_commands(msg):
    """CellSignal -> ``gsm signal <rssi 0..31, 99 unknown>`` (the ASU is the 27.007 rssi)."""
    asu = int(msg.asu)
    if not msg.enabled or not msg.cell_id or not (0 <= asu <= 31):
        asu = 99
    return [('gsm signal', 'gsm signal %d' % asu)]


def wifi_commands(msg):
    """WifiLink -> ``network speed <up>:<down>`` in kbit/s (the console's unit) from the link
    speed in Mbit/s, both directions; nothing while not connected."""
    if not (msg.enabled and msg.connected) or msg.link_speed <= 0:
        return []
    k = fmt(mbit_to_kbit(msg.link_speed))
    return [('network speed', 'network speed %s:%s' % (k, k))]


def gga_satellites(sentence):
    """Satellites in use of a ``$GPGGA`` sentence (field 7), None for anything else."""
    for line in str(sentence).split('\n'):
        f = line.strip().split(',')
        if len(f) > 7 and f[0].endswith('GGA'):
            try:
                return int(f[7])
            except ValueError:
                return None
    return None


# ------------------------------------------------------------------------- console client

class ConsoleError(Exception):
    """The console is gone (closed, refused, timed out): reconnect."""


class AuthError(Exception):
    """The console refused the token."""


def read_token(token=None, token_file=DEFAULT_TOKEN_FILE):
    """The token: ``token`` when given, else the first line of the token file ('' when the
    file is missing or empty: authentication disabled, as the emulator does)."""
    if token:
        return str(token).strip()
    try:
        with open(os.path.expanduser(token_file)) as f:
            return f.read().strip()
    except (IOError, OSError):
        return ''


class ConsoleClient(object):
    """One console session: ``connect()`` reads the banner (and authenticates),
    ``command(text)`` -> (ok, reply text)."""

    def __init__(self, host='localhost', port=5554, token=None,
                 token_file=DEFAULT_TOKEN_FILE, timeout=5.0):
        self.host, self.port, self.timeout = host, int(port), float(timeout)
        self.token, self.token_file = token, token_file
        self.sock, self._buf = None, b''
        self.banner = []

    def _readline(self):
        while b'\n' not in self._buf:
            try:
                data = self.sock.recv(4096)
            except socket.timeout:
                raise ConsoleError('no reply within %.1f s' % self.timeout)
            except OSError as e:
                raise ConsoleError('connection lost (%s)' % e)
            if not data:
                raise ConsoleError('console closed the connection')
            self._buf += data
        line, self._buf = self._buf.split(b'\n', 1)
        return line.decode('utf-8', 'replace').rstrip('\r')

    def _reply(self):
        """Lines up to ``OK`` or ``KO...``: (ok, text of the lines)."""
        lines = []
        while True:
            line = self._readline()
            s = line.strip()
            if s == 'OK':
                return True, '\n'.join(lines)
            if s.startswith('KO'):
                return False, s
            lines.append(line)

    def connect(self):
        self.close()
        try:
            self.sock = socket.create_connection((self.host, self.port), timeout=self.timeout)
        except OSError as e:
            self.sock = None
            raise ConsoleError('no emulator console at %s:%d (%s)'
                               % (self.host, self.port, e.strerror or e))
        self.sock.settimeout(self.timeout)
        try:
            ok, text = self._reply()
            self.banner = text.splitlines()
            if 'authentication required' in text.lower():
                token = read_token(self.token, self.token_file)
                where = 'the ~auth_token parameter' if self.token else \
                    os.path.expanduser(self.token_file)
                if not token:
                    raise AuthError('the emulator console at %s:%d asks for an auth token and '
                                    '%s is missing or empty (copy the emulator\'s '
                                    '~/.emulator_console_auth_token there or set ~auth_token)'
                                    % (self.host, self.port, where))
                self._send('auth ' + token)
                ok, text = self._reply()
                if not ok:
                    raise AuthError('the emulator console at %s:%d refused the auth token from '
                                    '%s (%s); copy the emulator\'s ~/.emulator_console_auth_'
                                    'token there or set ~auth_token'
                                    % (self.host, self.port, where, text))
        except (ConsoleError, AuthError):
            self.close()
            raise
        return self.banner

    def _send(self, text):
        try:
            self.sock.sendall((text + '\r\n').encode('utf-8'))
        except OSError as e:
            raise ConsoleError('connection lost (%s)' % e)

    def command(self, text):
        """Send one command: (True, output) on ``OK``, (False, 'KO: reason') on ``KO``;
        ConsoleError when the connection breaks (also half-way through the reply)."""
        if self.sock is None:
            raise ConsoleError('not connected')
        try:
            self._send(text)
            return self._reply()
        except ConsoleError:
            self.close()
            raise

    @property
    def connected(self):
        return self.sock is not None

    def close(self):
        if self.sock is not None:
            try:
                self.sock.close()
            except OSError:
                pass
        self.sock, self._buf = None, b''


# ------------------------------------------------------------------------------- the bridge

class Bridge(object):
    """Latest command per kind, sent at most ``rate`` per second per kind (wall clock), over
    a :class:`ConsoleClient` that is (re)connected as needed.

    ``submit(kind, command)`` is thread-safe (ROS callbacks); ``run()`` (a thread) or
    ``step()`` (tests) sends. Logging goes to the callables ``info``, ``warn``, ``error``."""

    def __init__(self, client, rate=50.0, retry_period=2.0, info=print, warn=print,
                 error=print, clock=time.monotonic):
        self.client = client
        self.rate = float(rate)
        self.period = 1.0 / self.rate if self.rate > 0 else 0.0
        self.retry_period = float(retry_period)
        self.info, self.warn, self.error, self.clock = info, warn, error, clock
        self.pending = {}       # kind -> command waiting to be sent (latest value)
        self.last_sent = {}     # kind -> wall time of the last send
        self.sent = []          # (kind, command) that the console accepted
        self.refused = {}       # kind -> count of KO replies
        self._logged_ko = LogOnce(say=lambda text: self.warn(text))
        self._next_try = 0.0
        self._last_auth_error = None
        self._was_connected = False
        self.connects = 0
        self._replies = 0       # replies on the current connection
        self._cv = threading.Condition()
        self._stop = False

    def submit(self, kind, command):
        with self._cv:
            self.pending[kind] = command
            self._cv.notify()

    def submit_all(self, pairs):
        for kind, command in pairs:
            self.submit(kind, command)

    def _ensure_connected(self, now):
        if self.client.connected:
            return True
        if now < self._next_try:
            return False
        self._next_try = now + self.retry_period
        try:
            self.client.connect()
        except AuthError as e:
            msg = str(e)
            if msg != self._last_auth_error:
                self.error(msg)
                self._last_auth_error = msg
            return False
        except ConsoleError as e:
            self.info('%s; retrying every %g s' % (e, self.retry_period))
            return False
        self._last_auth_error = None
        self._replies = 0
        self.connects += 1
        self.info('connected to the emulator console at %s:%d%s'
                  % (self.client.host, self.client.port,
                     ' (again)' if self._was_connected else ''))
        self._was_connected = True
        return True

    def due(self, now):
        """Kinds whose pending command may go now."""
        with self._cv:
            return [k for k in self.pending
                    if now - self.last_sent.get(k, -1e18) >= self.period - 1e-9]

    def step(self, now=None):
        """Connect if needed and send every due command once. Returns the number sent."""
        now = self.clock() if now is None else now
        if not self._ensure_connected(now) or not self.pending:
            return 0
        n = 0
        for kind in self.due(now):
            with self._cv:
                command = self.pending.get(kind)
            if command is None:
                continue
            try:
                ok, text = self.client.command(command)
            except ConsoleError as e:
                self.warn('emulator console at %s:%d: %s during %r; reconnecting'
                          % (self.client.host, self.client.port, e, command))
                # at once after a working session (a refused connect then waits
                # retry_period); a console that breaks before any reply: wait retry_period
                self._next_try = 0.0 if self._replies else now + self.retry_period
                return n               # the command stays pending: sent again after reconnect
            self._replies += 1
            with self._cv:
                if self.pending.get(kind) == command:
                    del self.pending[kind]
            self.last_sent[kind] = now
            n += 1
            if ok:
                self.sent.append((kind, command))
            else:
                self.refused[kind] = self.refused.get(kind, 0) + 1
                self._logged_ko('emulator console refused %r: %s (logged once for %s)'
                                % (command, text, kind), key=(kind, text))
        return n

    def next_wakeup(self, now):
        with self._cv:
            if not self.client.connected:
                return max(now, self._next_try)
            if not self.pending:
                return None
            return min(self.last_sent.get(k, -1e18) + self.period for k in self.pending)

    def run(self):
        """Send until ``stop()``: sleeps until the next command is due or submitted."""
        while not self._stop:
            try:
                self.step()
            except Exception as e:   # never let the sender die
                self.error('emulator_bridge: unexpected error %r; going on' % (e,))
                self.client.close()
                time.sleep(self.retry_period)
            now = self.clock()
            wake = self.next_wakeup(now)
            with self._cv:
                if self._stop:
                    break
                if wake is None:
                    self._cv.wait(0.5)
                elif wake > now:
                    self._cv.wait(min(0.5, wake - now))

    def start(self):
        t = threading.Thread(target=self.run, name='emulator_bridge', daemon=True)
        t.start()
        self.thread = t
        return t

    def stop(self):
        with self._cv:
            self._stop = True
            self._cv.notify_all()
        self.client.close()
