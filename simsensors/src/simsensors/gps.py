"""The GPS receiver of thesis section 3.3.1, code snippet 3.3.1: ``libgazebo_ros_gps.so``,
hector's ``libhector_gazebo_ros_gps.so`` and the 2011 ``<sensor:gps><LatLon>`` with
``<controller:generic_gps>`` (no library named: ``libgeneric_gps.so``).

Position: latitude/longitude of the report frame from the world's spherical coordinates
(``env.geodetic``: the east/north offsets from the world origin added in UTM with pyproj),
or, when the plugin has its own origin, from that: ``LatLon`` (thesis: the coordinates of the
phone's *starting* point, the distance moved since then is added in UTM) or hector's
``referenceLatitude``/``referenceLongitude`` (the coordinates of the world origin). North is
the world's (``north_alpha``) unless ``referenceHeading`` is given.

Reception: inside an indoor volume of the world there is no fix (NavSatFix status -1,
latitude/longitude/altitude NaN, no velocity, NMEA quality 0 / status V) except within the
volume's margin of an opening (door, window). When the sky is visible again the fix returns
after the time to first fix: ``warmStartTime`` when the fix was lost less than
``warmValidity`` seconds ago, else ``coldStartTime``. The receiver runs on every tick whether
or not anybody listens (the time to first fix is history). Fault ``no_fix`` (``set_fault``)
drops the fix as if indoors.

Topics: ``fix`` (sensor_msgs/NavSatFix, covariance from the position error model, ENU m^2),
``fix_velocity`` (geometry_msgs/Vector3Stamped, ENU m/s), ``nmea_sentence``
(std_msgs/String, one ``$GPGGA`` and one ``$GPRMC`` per tick, built with pynmea2).
"""
import datetime
import math

import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['Gps', 'nmea_sentences', 'FAULT_NO_FIX', 'UTC_EPOCH']

FAULT_NO_FIX = 'no_fix'
#: UTC of sim time 0 for the NMEA sentences: 2011-10-01T00:00:00Z (the thesis's year)
UTC_EPOCH = 1317427200.0
KNOTS = 1.0 / 0.514444


def _latlon(text):
    vals = [float(x) for x in text.replace(',', ' ').split()]
    if len(vals) != 2 or not all(math.isfinite(v) for v in vals):
        raise ValueError('two numbers "latitude longitude" in degrees')
    if not -90.0 <= vals[0] <= 90.0:
        raise ValueError('a latitude in [-90, 90] degrees and a longitude')
    if not -180.0 <= vals[1] <= 360.0:
        raise ValueError('a latitude and a longitude in [-180, 360] degrees')
    return tuple(vals)


_latlon.what = ('two numbers "latitude longitude" in degrees, latitude in [-90, 90], '
                'longitude in [-180, 360]')


def _dm(deg, lat):
    """NMEA ddmm.mmmm / dddmm.mmmm and the hemisphere letter."""
    hemi = ('N' if deg >= 0 else 'S') if lat else ('E' if deg >= 0 else 'W')
    a = abs(deg)
    d = int(a)
    m = (a - d) * 60.0
    if round(m, 5) >= 60.0:
        d, m = d + 1, 0.0
    return ('%02d%08.5f' if lat else '%03d%08.5f') % (d, m), hemi


def nmea_sentences(t_utc, lat, lon, alt, fix, speed=0.0, course=0.0, sats=8, hdop=1.0):
    """($GPGGA..., $GPRMC...) at the UTC time t_utc (s since 1970) built with pynmea2;
    without a fix quality 0 and status V with empty position fields."""
    import pynmea2
    ts = datetime.datetime.fromtimestamp(t_utc, datetime.timezone.utc)
    hms = ts.strftime('%H%M%S') + ('%.2f' % (ts.microsecond / 1e6))[1:]
    dmy = ts.strftime('%d%m%y')
    if fix:
        la, ns = _dm(lat, True)
        lo, ew = _dm(lon, False)
        gga = pynmea2.GGA('GP', 'GGA', (hms, la, ns, lo, ew, '1', '%02d' % sats,
                                        '%.1f' % hdop, '%.1f' % alt, 'M', '0.0', 'M', '', ''))
        rmc = pynmea2.RMC('GP', 'RMC', (hms, 'A', la, ns, lo, ew, '%.2f' % (speed * KNOTS),
                                        '%.1f' % course, dmy, '', '', 'A'))
    else:
        gga = pynmea2.GGA('GP', 'GGA', (hms, '', '', '', '', '0', '00', '', '', 'M', '',
                                        'M', '', ''))
        rmc = pynmea2.RMC('GP', 'RMC', (hms, 'V', '', '', '', '', '', '', dmy, '', '', 'N'))
    return str(gga), str(rmc)


@register('libgazebo_ros_gps.so', 'libhector_gazebo_ros_gps.so', 'libgeneric_gps.so')
class Gps(Sensor):
    DEFAULT_TOPIC = 'fix'
    DEFAULT_RATE = 1.0
    ALWAYS_MEASURE = True          # time to first fix: history, whoever listens
    FAULTS_OWN = (FAULT_NO_FIX,)
    ERRORS = {
        # a phone's GNSS: a few metres horizontal, slowly wandering (Gauss-Markov drift with
        # a 5 min correlation time), plus sample noise; vertical about 1.5 times worse
        'position': dict(dims=3, drift=(2.0, 2.0, 3.0), drift_frequency=1.0 / 300.0,
                         gaussian_noise=(0.5, 0.5, 1.0)),
        'velocity': dict(dims=3, gaussian_noise=(0.1, 0.1, 0.2)),
    }
    PARAMS = [
        Param('LatLon', _latlon, None, aliases=('latlon', 'latLon'), unit='deg',
              doc='thesis 2011: latitude longitude of the starting point'),
        Param('referenceLatitude', float, None, aliases=('reference_latitude',), unit='deg',
              check=(-90.0, 90.0), doc='hector: latitude of the world origin'),
        Param('referenceLongitude', float, None, aliases=('reference_longitude',), unit='deg',
              check=(-180.0, 360.0), doc='hector: longitude of the world origin'),
        Param('referenceAltitude', float, None, aliases=('reference_altitude',), unit='m',
              doc='altitude of the world origin (default: the world elevation)'),
        Param('referenceHeading', float, None, aliases=('reference_heading',), unit='deg',
              doc='hector: angle of north counter-clockwise from the world x axis, like '
                  "north_alpha (default: the world's north_alpha)"),
        Param('velocityTopicName', str, 'fix_velocity', aliases=('velocity_topic',)),
        Param('nmeaTopicName', str, 'nmea_sentence', aliases=('nmea_topic',)),
        Param('coldStartTime', float, 30.0, aliases=('cold_start_time', 'coldTTFF'), unit='s',
              check='>=0', doc='time to first fix without recent almanac/ephemeris'),
        Param('warmStartTime', float, 5.0, aliases=('warm_start_time', 'warmTTFF'), unit='s',
              check='>=0', doc='time to first fix when the fix was lost recently'),
        Param('warmValidity', float, 7200.0, aliases=('warm_validity',), unit='s',
              check='>=0', doc='a fix lost less than this long ago gives a warm start'),
        Param('initialFix', bool, True, aliases=('initial_fix',),
              doc='the receiver had a fix at start (outdoors: fix at once; indoors: it was '
                  'lost at time 0, warm start); false: cold start at the first sky view'),
        Param('status', int, 0, check=(0, 2), doc='NavSatStatus with a fix: 0 FIX, 1 SBAS, '
                                                  '2 GBAS'),
        Param('service', int, 1, check=(1, 15), doc='NavSatStatus.service bits (1 GPS)'),
        Param('satellites', int, 8, check=(0, 99), doc='satellites in the NMEA GGA'),
        Param('utcEpoch', float, UTC_EPOCH, unit='s', doc='UTC (s since 1970) at sim time 0 '
              'for the NMEA time and date'),
    ]

    def setup(self):
        from geometry_msgs.msg import Vector3Stamped
        from sensor_msgs.msg import NavSatFix, NavSatStatus
        from std_msgs.msg import String
        self.NavSatFix, self.NavSatStatus, self.Vector3Stamped, self.String = \
            NavSatFix, NavSatStatus, Vector3Stamped, String
        p = self.p
        self.output('main', NavSatFix)
        self.vel_pub = self.output('fix_velocity', Vector3Stamped, topic=p.velocityTopicName)
        self.nmea_pub = self.output('nmea_sentence', String, topic=p.nmeaTopicName)
        self.origin_env = None     # own origin (LatLon / reference*): a private Environment
        self.origin_point = np.zeros(3)
        lat0 = lon0 = None
        if p.LatLon is not None:
            lat0, lon0 = p.LatLon
            self.origin_point = np.array(self.state().pose.p, float)
        elif p.referenceLatitude is not None or p.referenceLongitude is not None:
            lat0 = p.referenceLatitude if p.referenceLatitude is not None \
                else self.env.get('latitude')
            lon0 = p.referenceLongitude if p.referenceLongitude is not None \
                else self.env.get('longitude')
        if lat0 is not None or p.referenceHeading is not None:
            from sim_world.environment import Environment
            e = Environment()
            e.set('latitude', lat0 if lat0 is not None else self.env.get('latitude'))
            e.set('longitude', lon0 if lon0 is not None else self.env.get('longitude'))
            e.set('elevation', self.env.get('elevation'))
            e.set('north_alpha', self.env.get('north_alpha') if p.referenceHeading is None
                  else p.referenceHeading)
            self.origin_env = e
        self._reset_receiver()

    def _reset_receiver(self):
        t = self.world.sim_time
        self.has_fix = False
        self.lost_at = t if self.p.initialFix else None
        self.acquire_start = None
        self.ttff = None
        self._first = bool(self.p.initialFix)

    # -- what the receiver sees ------------------------------------------------------------------
    def sky_visible(self, p):
        if self.fault == FAULT_NO_FIX:
            return False
        inside, _, margin = self.env.indoor(p)
        return (not inside) or margin

    def geodetic(self, p):
        """(lat, lon, alt) of a world point without errors."""
        p = np.asarray(p, float)
        if self.origin_env is None:
            lat, lon, alt = self.env.geodetic(p)
        else:
            lat, lon, _ = self.origin_env.geodetic(p - self.origin_point)
            alt = self.env.altitude(p)
        if self.p.referenceAltitude is not None:
            alt = self.p.referenceAltitude + float(p[2])
        return lat, lon, alt

    def _env(self):
        return self.origin_env or self.env

    def _receiver(self, t, visible):
        if not visible:
            if self.has_fix:
                self.lost_at = t
            self.has_fix = False
            self.acquire_start = None
            self._first = False
            return
        if self.has_fix:
            return
        if self._first:                       # on and outdoors from the start
            self.has_fix, self._first = True, False
            return
        if self.acquire_start is None:
            self.acquire_start = t
            warm = self.lost_at is not None and t - self.lost_at <= self.p.warmValidity
            self.ttff = self.p.warmStartTime if warm else self.p.coldStartTime
        if t - self.acquire_start >= self.ttff - 1e-9:
            self.has_fix = True

    def measure(self, state, dt):
        p = np.asarray(state.pose.p, float)
        self._receiver(state.t, self.sky_visible(p))
        if not self.has_fix:
            return (state.t, False, (math.nan,) * 3, np.zeros(3))
        env = self._env()
        e, n = env.east_world(), env.north_world()
        # position error in ENU metres, added before the projection
        err = self.errors['position'].apply(np.zeros(3))
        off = err[0] * e + err[1] * n + np.array([0.0, 0.0, err[2]])
        lat, lon, alt = self.geodetic(p + off)
        lin = np.asarray(state.lin, float)
        enu = np.array([lin.dot(e), lin.dot(n), lin[2]])
        enu = self.errors['velocity'].apply(enu)
        return (state.t, True, (lat, lon, alt), enu)

    def to_msg(self, value, stamp):
        t, fix, (lat, lon, alt), _ = value
        m = self.NavSatFix()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.status.service = self.p.service
        if fix:
            m.status.status = self.p.status
            m.latitude, m.longitude, m.altitude = float(lat), float(lon), float(alt)
            var = self.errors['position'].variance
            m.position_covariance = [float(var[0]), 0.0, 0.0, 0.0, float(var[1]), 0.0,
                                     0.0, 0.0, float(var[2])]
            m.position_covariance_type = self.NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
        else:
            m.status.status = self.NavSatStatus.STATUS_NO_FIX
            m.latitude = m.longitude = m.altitude = float('nan')
            m.position_covariance_type = self.NavSatFix.COVARIANCE_TYPE_UNKNOWN
        return m

    def messages(self, value, stamp):
        t, fix, (lat, lon, alt), enu = value
        out = {'main': lambda: self.to_msg(value, stamp)}
        if fix:
            v = self.Vector3Stamped()
            v.header.stamp = stamp
            v.header.frame_id = self.frame_id
            v.vector.x, v.vector.y, v.vector.z = (float(x) for x in enu)
            out['fix_velocity'] = v

        def nmea():
            speed = float(math.hypot(enu[0], enu[1]))
            course = math.degrees(math.atan2(enu[0], enu[1])) % 360.0 if speed > 0.05 else 0.0
            return [self.String(data=s) for s in nmea_sentences(
                self.p.utcEpoch + t, lat, lon, alt, fix, speed, course, self.p.satellites)]
        out['nmea_sentence'] = nmea
        return out

    def reset(self):
        Sensor.reset(self)
        self._reset_receiver()
