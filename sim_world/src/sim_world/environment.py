"""The world environment that sensors read (thesis 3.3.1, 3.3.4, 3.3.5, 3.3.11).

Parsed once from the world file into one ``Environment`` object (``world.environment``)::

    <spherical_coordinates>                       <!-- SDF -->
      <surface_model>EARTH_WGS84</surface_model>
      <latitude_deg>48.148940</latitude_deg> <longitude_deg>11.566730</longitude_deg>
      <elevation>519</elevation> <heading_deg>111.5</heading_deg>
    </spherical_coordinates>
    <atmosphere type="adiabatic">                 <!-- SDF -->
      <temperature>288.15</temperature> <pressure>101325</pressure>
      <temperature_gradient>-0.0065</temperature_gradient>
    </atmosphere>
    <environment>                                 <!-- mobile_device_sim -->
      <north_alpha>338.5</north_alpha>            <!-- deg CCW from world x to north -->
      <magnetic_field>                            <!-- omit: World Magnetic Model -->
        <magnitude>4.88e-5</magnitude> <inclination>64.4</inclination>
        <declination>4.4</declination>
      </magnetic_field>
      <magnetic_epoch>2025.0</magnetic_epoch>     <!-- decimal year for the WMM -->
      <temperature>15</temperature> <indoor_temperature>21</indoor_temperature>
      <humidity>60</humidity> <pressure_offset>0</pressure_offset> <daylight>10000</daylight>
      <indoor_volume name="office" margin="1.0">
        <box><pose>3 -2 1.25 0 0 0</pose><size>6.2 6.2 2.5</size></box>
        <!-- or <polyhedron><point>x y z</point>... <face>0 1 2 3</face>...</polyhedron> -->
        <opening name="door"><pose>6.05 -3 1 0 0 0</pose><size>0.3 0.9 2</size></opening>
      </indoor_volume>
    </environment>

The thesis's north offset alpha (figure 3.5) and SDF's heading describe the same thing:
SDF's world x axis points ``heading`` degrees counter-clockwise from east, so north is at
alpha = 90 - heading from the world x axis. Either may be given; alpha wins.

**Time of day.** ``time_of_day`` (h, local solar time 0..24; 12 is solar noon) and
``day_of_year`` (1..366, default 80: 21 March, an equinox) place the sun: its elevation at
the world origin's ``latitude`` (the world file's ``<spherical_coordinates>``, else the
equator, 0) is ``sun_elevation`` (declination by Cooper's formula, hour angle 15 degrees an
hour), and the outdoor ``daylight`` is the clear-sky horizontal illuminance of the IES's
recommended practice for daylight availability (``clear_sky_illuminance``; below the
horizon, twilight down to starlight). Which wins is the last one set: setting
``time_of_day`` makes ``daylight`` follow the sun (also when ``day_of_year`` or ``latitude``
change later); setting ``daylight`` itself holds it at that value (``time_of_day`` keeps its
last value, unused) until ``time_of_day`` is set again. Within one ``set_many`` (one
``/gazebo/set_environment`` request) the later entry wins. A world file that gives neither
keeps ``daylight`` at its default (10000 lux), as before.

Values are read and changed by name (``get``, ``set``, ``values``); ``set`` checks the value
and refuses a bad one with ValueError naming it (``/gazebo/set_environment`` answers
success false). Units are SI except where the name says otherwise (degrees, percent, degC
as the thesis and Android use them); see ``VALUES``.
"""
import math
import os
import xml.etree.ElementTree as ET

import numpy as np

from .model import _local

__all__ = ['Environment', 'IndoorVolume', 'EnvironmentError', 'VALUES', 'parse_environment',
           'sun_elevation', 'clear_sky_illuminance']

G0 = 9.80665          # m/s^2, standard gravity (ICAO)
M_AIR = 0.0289644     # kg/mol
R_GAS = 8.3144598     # J/(mol K)


class EnvironmentError(ValueError):
    """A bad environment description or value; the message names it."""


# name: (default, unit, (lo, hi) or None, description)
VALUES = {
    'latitude': (0.0, 'deg', (-90.0, 90.0), 'latitude of the world origin (WGS84)'),
    'longitude': (0.0, 'deg', (-180.0, 180.0), 'longitude of the world origin (WGS84)'),
    'elevation': (0.0, 'm', (-500.0, 9000.0), 'height of the world origin above sea level'),
    'heading': (0.0, 'deg', None, 'SDF heading_deg: world x axis CCW from east'),
    'north_alpha': (90.0, 'deg', None, 'thesis alpha: north CCW from the world x axis'),
    'magnetic_magnitude': (None, 'T', (0.0, 1e-3), 'total field (None: World Magnetic Model)'),
    'magnetic_inclination': (None, 'deg', (-90.0, 90.0), 'dip, positive down'),
    'magnetic_declination': (None, 'deg', (-180.0, 180.0), 'magnetic north east of true north'),
    'magnetic_epoch': (2025.0, 'year', (2020.0, 2030.0), 'decimal year of the WMM'),
    'temperature': (15.0, 'degC', (-90.0, 70.0), 'outdoor air temperature'),
    'indoor_temperature': (21.0, 'degC', (-50.0, 70.0), 'air temperature in indoor volumes'),
    'humidity': (50.0, 'percent', (0.0, 100.0), 'relative humidity'),
    'pressure_offset': (0.0, 'Pa', (-10000.0, 10000.0), 'weather: added to the standard '
                                                          'atmosphere'),
    'sea_level_pressure': (101325.0, 'Pa', (50000.0, 120000.0), 'SDF atmosphere pressure'),
    'sea_level_temperature': (288.15, 'K', (180.0, 340.0), 'SDF atmosphere temperature'),
    'temperature_gradient': (-0.0065, 'K/m', (-0.05, 0.05), 'SDF atmosphere lapse rate'),
    'daylight': (10000.0, 'lux', (0.0, 150000.0), 'outdoor illuminance, horizontal surface'),
    'time_of_day': (12.0, 'h', (0.0, 24.0), 'local solar time; setting it makes daylight '
                                            'follow the sun'),
    'day_of_year': (80.0, 'day', (1.0, 366.0), "date of the sun's declination (80: 21 "
                                               "March)"),
}

# -- the sun ------------------------------------------------------------------------------------
#: IES clear sky (Recommended Practice for the Calculation of Daylight Availability, J. IES
#: 13(4) 381-392, 1984; the IESNA Lighting Handbook's daylight availability model): solar
#: illuminance constant (lux), atmospheric extinction coefficient of a clear sky, and the
#: clear sky's horizontal sky illuminance A + B sin(elevation)^C (lux)
SOLAR_ILLUMINANCE = 127500.0
EXTINCTION_CLEAR = 0.21
SKY_A, SKY_B, SKY_C = 800.0, 15500.0, 0.5
#: (sun elevation deg, lux) of a clear twilight (AMS Glossary of Meteorology: civil twilight
#: ends at -6 degrees with about 3.5-2 lux, nautical at -12 with about 0.008 lux); below
#: -18 degrees (astronomical night) the starlit sky's 0.001 lux. Log-linear between.
TWILIGHT = ((-6.0, 3.0), (-12.0, 0.008), (-18.0, 0.001))
NIGHT_LUX = 0.001


def sun_elevation(latitude, day_of_year, hours):
    """Elevation (deg) of the sun's centre at local solar time ``hours`` (12: solar noon) on
    ``day_of_year`` at ``latitude`` (deg): declination 23.45 sin(360 (284 + n) / 365) deg
    (Cooper 1969), hour angle 15 deg per hour from noon; no refraction."""
    decl = math.radians(23.45 * math.sin(math.radians(360.0 * (284.0 + day_of_year) / 365.0)))
    lat = math.radians(latitude)
    omega = math.radians(15.0 * (hours - 12.0))
    s = math.sin(lat) * math.sin(decl) + math.cos(lat) * math.cos(decl) * math.cos(omega)
    return math.degrees(math.asin(max(-1.0, min(1.0, s))))


def clear_sky_illuminance(elevation, day_of_year=80.0):
    """Outdoor horizontal illuminance (lux) under a clear sky with the sun at ``elevation``
    (deg). Sun above the horizon (IES 1984): direct E_ext exp(-c m) sin(el), with E_ext the
    solar illuminance constant corrected for the Earth's orbit (1 + 0.034 cos(2 pi (n - 2) /
    365)), c the clear sky's extinction coefficient and m = 1 / sin(el) the air mass, plus the
    sky's A + B sin(el)^C. Below it: the twilight table (``TWILIGHT``), continuous with the
    sky's A at the horizon."""
    if elevation > 0.0:
        s = math.sin(math.radians(elevation))
        e_ext = SOLAR_ILLUMINANCE * (1.0 + 0.034 * math.cos(2.0 * math.pi *
                                                            (day_of_year - 2.0) / 365.0))
        return e_ext * math.exp(-EXTINCTION_CLEAR / s) * s + SKY_A + SKY_B * s ** SKY_C
    pts = ((0.0, SKY_A),) + TWILIGHT
    for (e0, l0), (e1, l1) in zip(pts, pts[1:]):
        if elevation >= e1:
            f = (elevation - e0) / (e1 - e0)
            return 10.0 ** (math.log10(l0) + f * (math.log10(l1) - math.log10(l0)))
    return NIGHT_LUX


def _vec(text, n, what):
    try:
        v = np.array([float(x) for x in (text or '').split()])
    except ValueError:
        v = np.array([])
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise EnvironmentError('%s must be %d numbers, got %r' % (what, n, text))
    return v


def _rot_z(yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _pose_matrix(text, what):
    v = _vec(text or '0 0 0 0 0 0', 6, what + ' pose')
    from .transforms import quat_from_rpy, quat_to_matrix
    return v[:3], quat_to_matrix(quat_from_rpy(*v[3:]))


class _Box(object):
    """An oriented box: centre, rotation, half extents."""

    def __init__(self, centre, rot, size, what):
        size = np.asarray(size, float)
        if np.any(size <= 0):
            raise EnvironmentError('%s size must be three positive numbers, got %s'
                                   % (what, list(size)))
        self.c, self.r, self.h = np.asarray(centre, float), rot, size / 2.0

    def local(self, p):
        return self.r.T.dot(np.asarray(p, float) - self.c)

    def contains(self, p):
        return bool(np.all(np.abs(self.local(p)) <= self.h + 1e-12))

    def distance(self, p):
        d = np.maximum(np.abs(self.local(p)) - self.h, 0.0)
        return float(np.linalg.norm(d))

    def mesh(self):
        sx, sy, sz = self.h
        pts = np.array([[x, y, z] for x in (-sx, sx) for y in (-sy, sy) for z in (-sz, sz)])
        verts = pts.dot(self.r.T) + self.c
        faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4),
                 (1, 5, 7, 3)]
        return verts, faces


class IndoorVolume(object):
    """A closed polyhedron of indoor space, with openings (windows, entrances) near which,
    within ``margin`` metres, satellite signals still reach (thesis 3.3.1)."""

    def __init__(self, name, vertices, faces, openings=(), margin=1.0):
        self.name = name
        self.vertices = np.asarray(vertices, float)
        self.faces = [tuple(int(i) for i in f) for f in faces]
        self.openings = list(openings)        # [(name, _Box)]
        self.margin = float(margin)
        if not (self.margin >= 0):
            raise EnvironmentError('indoor volume %r: margin must be >= 0, got %r'
                                   % (name, margin))
        self._check_closed()
        tris = []
        for f in self.faces:
            for k in range(1, len(f) - 1):
                tris.append((f[0], f[k], f[k + 1]))
        t = self.vertices[np.array(tris)]
        self._t0, self._e1, self._e2 = t[:, 0], t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        self.lo, self.hi = self.vertices.min(axis=0), self.vertices.max(axis=0)

    def _check_closed(self):
        n = len(self.vertices)
        if n < 4 or len(self.faces) < 4:
            raise EnvironmentError('indoor volume %r is not a closed polyhedron: it needs at '
                                   'least 4 points and 4 faces' % self.name)
        edges = {}
        for f in self.faces:
            if len(f) < 3 or any(i < 0 or i >= n for i in f):
                raise EnvironmentError('indoor volume %r: face %s must name at least 3 of its '
                                       '%d points (0-based)' % (self.name, list(f), n))
            for a, b in zip(f, f[1:] + f[:1]):
                key = (min(a, b), max(a, b))
                edges[key] = edges.get(key, 0) + 1
        bad = [e for e, c in edges.items() if c != 2]
        if bad:
            raise EnvironmentError('indoor volume %r is not a closed polyhedron: edge %s is '
                                   'shared by %d faces (must be 2)'
                                   % (self.name, list(bad[0]), edges[bad[0]]))

    def contains(self, p):
        """Point in polyhedron by the parity of crossings of a ray (skewed so it meets no
        edge of an axis-aligned room)."""
        p = np.asarray(p, float)
        if np.any(p < self.lo - 1e-9) or np.any(p > self.hi + 1e-9):
            return False
        d = np.array([0.5773, 0.5774, 0.5775])
        pv = np.cross(d, self._e2)
        det = np.einsum('ij,ij->i', self._e1, pv)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        tv = p - self._t0
        u = np.einsum('ij,ij->i', tv, pv) * inv
        qv = np.cross(tv, self._e1)
        v = qv.dot(d) * inv
        t = np.einsum('ij,ij->i', self._e2, qv) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        return bool(np.count_nonzero(hit) % 2)

    def near_opening(self, p):
        return any(b.distance(p) <= self.margin for _, b in self.openings)


class Environment(object):
    """See the module doc. ``on_change``: callbacks(name, value) after each change."""

    def __init__(self):
        self._v = {k: d[0] for k, d in VALUES.items()}
        self._given = set()
        self.indoor_volumes = []
        self.transmitters = []            # radio: filled by transmitter plugins
        self.on_change = []
        self._proj = None
        self._field_cache = None
        self.daylight_from_sun = False    # daylight follows time_of_day (see the module doc)

    # -- values ------------------------------------------------------------------------------------
    def get(self, name):
        if name not in self._v:
            raise EnvironmentError('unknown environment value %r (known: %s)'
                                   % (name, ', '.join(sorted(VALUES))))
        if name in ('magnetic_magnitude', 'magnetic_inclination', 'magnetic_declination') \
                and self._v[name] is None:
            f, i, d = self.magnetic_elements()
            return {'magnetic_magnitude': f, 'magnetic_inclination': i,
                    'magnetic_declination': d}[name]
        return self._v[name]

    def check(self, name, value):
        """The value as float; raises EnvironmentError naming a bad name or value."""
        if name not in VALUES:
            raise EnvironmentError('unknown environment value %r (known: %s)'
                                   % (name, ', '.join(sorted(VALUES))))
        try:
            v = float(value)
        except (TypeError, ValueError):
            v = float('nan')
        rng = VALUES[name][2]
        if not math.isfinite(v) or (rng is not None and not rng[0] <= v <= rng[1]):
            raise EnvironmentError('environment %s must be %s (%s), got %r' % (
                name, 'a finite number' if rng is None else
                'a number in [%g, %g]' % rng, VALUES[name][1], value))
        return v

    def set(self, name, value):
        v = self.check(name, value)
        self._set(name, v)

    def set_many(self, pairs):
        """Set several values atomically: all are checked before any changes."""
        checked = [(n, self.check(n, v)) for n, v in pairs]
        for n, v in checked:
            self._set(n, v)

    def _set(self, name, v):
        if name == 'heading':
            self._v['north_alpha'] = (90.0 - v) % 360.0
        if name == 'north_alpha':
            v = v % 360.0
            self._v['heading'] = (90.0 - v + 180.0) % 360.0 - 180.0
        self._v[name] = v
        self._given.add(name)
        if name in ('latitude', 'longitude', 'elevation', 'magnetic_epoch'):
            self._field_cache = None
            self._proj = None
        if name == 'daylight':
            self.daylight_from_sun = False
        elif name == 'time_of_day':
            self.daylight_from_sun = True
        for cb in list(self.on_change):
            cb(name, v)
        if self.daylight_from_sun and name in ('time_of_day', 'day_of_year', 'latitude'):
            d = min(VALUES['daylight'][2][1], self.sun_daylight())
            self._v['daylight'] = d
            for cb in list(self.on_change):
                cb('daylight', d)

    def sun_elevation(self):
        """The sun's elevation (deg) at the world origin now (``time_of_day``,
        ``day_of_year``, ``latitude``)."""
        v = self._v
        return sun_elevation(v['latitude'], v['day_of_year'], v['time_of_day'])

    def sun_daylight(self):
        """The clear-sky daylight (lux) of the sun's elevation now."""
        return clear_sky_illuminance(self.sun_elevation(), self._v['day_of_year'])

    def values(self):
        """{name: value} of every value (derived magnetic elements filled in)."""
        return {k: self.get(k) for k in sorted(VALUES)}

    # -- directions ------------------------------------------------------------------------------
    @property
    def alpha(self):
        return math.radians(self._v['north_alpha'])

    def north_world(self):
        a = self.alpha
        return np.array([math.cos(a), math.sin(a), 0.0])

    def east_world(self):
        a = self.alpha
        return np.array([math.sin(a), -math.cos(a), 0.0])

    # -- magnetic field ------------------------------------------------------------------------
    def magnetic_elements(self):
        """(total field T, inclination deg, declination deg): the world file's values, else
        the World Magnetic Model at the origin's location and ``magnetic_epoch``."""
        v = self._v
        if None not in (v['magnetic_magnitude'], v['magnetic_inclination'],
                        v['magnetic_declination']):
            return (v['magnetic_magnitude'], v['magnetic_inclination'],
                    v['magnetic_declination'])
        if self._field_cache is None:
            from pygeomag import GeoMag
            r = GeoMag().calculate(glat=v['latitude'], glon=v['longitude'],
                                   alt=v['elevation'] / 1000.0, time=v['magnetic_epoch'])
            self._field_cache = (r.f * 1e-9, r.i, r.d)
        f, i, d = self._field_cache
        return (v['magnetic_magnitude'] if v['magnetic_magnitude'] is not None else f,
                v['magnetic_inclination'] if v['magnetic_inclination'] is not None else i,
                v['magnetic_declination'] if v['magnetic_declination'] is not None else d)

    def magnetic_field_world(self):
        """The field vector (T) in the world frame: horizontal part towards magnetic north
        (true north turned east by the declination), vertical part down by the
        inclination."""
        f, inc, dec = self.magnetic_elements()
        inc, dec = math.radians(inc), math.radians(dec)
        h = f * math.cos(inc)
        mag_north = math.cos(dec) * self.north_world() + math.sin(dec) * self.east_world()
        return h * mag_north + np.array([0.0, 0.0, -f * math.sin(inc)])

    # -- atmosphere ----------------------------------------------------------------------------
    def altitude(self, p):
        """Height above sea level (m) of a world point."""
        return self._v['elevation'] + float(np.asarray(p, float)[2] if np.ndim(p) else p)

    def pressure_at(self, z):
        """Air pressure (Pa) at world height z: the ICAO standard atmosphere at
        elevation + z, plus the weather's pressure_offset."""
        v = self._v
        h = v['elevation'] + float(z)
        t0, lapse, p0 = v['sea_level_temperature'], v['temperature_gradient'], \
            v['sea_level_pressure']
        if abs(lapse) < 1e-12:
            p = p0 * math.exp(-G0 * M_AIR * h / (R_GAS * t0))
        else:
            p = p0 * (1.0 + lapse * h / t0) ** (-G0 * M_AIR / (R_GAS * lapse))
        return p + v['pressure_offset']

    def air_temperature(self, p):
        """Air temperature (degC) at a world point: indoor_temperature inside an indoor
        volume, else the outdoor temperature."""
        inside, _, _ = self.indoor(p)
        return self._v['indoor_temperature'] if inside else self._v['temperature']

    # -- indoor / outdoor ----------------------------------------------------------------------
    def indoor(self, p):
        """(inside, volume name, in_margin): in_margin when inside but within the margin of
        one of the volume's openings."""
        for vol in self.indoor_volumes:
            if vol.contains(p):
                return True, vol.name, vol.near_opening(p)
        return False, '', False

    # -- geodesy ------------------------------------------------------------------------------
    def _projection(self):
        if self._proj is None:
            if 'PROJ_DATA' not in os.environ and os.path.isdir('/usr/share/proj'):
                os.environ['PROJ_DATA'] = '/usr/share/proj'
            import pyproj
            lat, lon = self._v['latitude'], self._v['longitude']
            zone = int((lon + 180.0) // 6.0) % 60 + 1
            epsg = (32600 if lat >= 0 else 32700) + zone
            proj = pyproj.Proj('EPSG:%d' % epsg)
            tr = pyproj.Transformer.from_crs('EPSG:4326', 'EPSG:%d' % epsg, always_xy=True)
            inv = pyproj.Transformer.from_crs('EPSG:%d' % epsg, 'EPSG:4326', always_xy=True)
            e0, n0 = tr.transform(lon, lat)
            fac = proj.get_factors(lon, lat)
            conv = math.radians(fac.meridian_convergence)
            k = fac.meridional_scale
            self._proj = (inv, e0, n0, conv, k)
        return self._proj

    def geodetic(self, p):
        """(latitude deg, longitude deg, altitude m) of a world point: its east/north
        offsets from the origin added in UTM (thesis 3.3.1), turned by the meridian
        convergence and scaled by the grid scale factor so that true north stays north."""
        p = np.asarray(p, float)
        inv, e0, n0, conv, k = self._projection()
        de, dn = float(p.dot(self.east_world())), float(p.dot(self.north_world()))
        # grid north is true north turned by -convergence (east of the central meridian)
        c, s = math.cos(conv), math.sin(conv)
        ge = k * (c * de - s * dn)
        gn = k * (s * de + c * dn)
        lon, lat = inv.transform(e0 + ge, n0 + gn)
        return lat, lon, self.altitude(p)


# -- parsing -----------------------------------------------------------------------------------------
def _child(el, name):
    return next((c for c in el if _local(c.tag) == name), None)


def _text(el, name):
    c = _child(el, name)
    return c.text.strip() if c is not None and c.text and c.text.strip() else None


def _number(env, name, text):
    try:
        env.set(name, float(text))
    except ValueError:
        raise EnvironmentError('environment %s must be %s, got %r' % (
            name, 'a number in [%g, %g]' % VALUES[name][2] if VALUES[name][2] else
            'a number', text))


def _volume(vel):
    name = vel.get('name', 'indoor')
    what = 'indoor volume %r' % name
    try:
        margin = float(vel.get('margin', _text(vel, 'margin') or '1.0'))
    except ValueError:
        raise EnvironmentError('%s: margin must be a number, got %r' % (what, vel.get('margin')))
    openings = []
    for oel in vel:
        if _local(oel.tag) in ('opening', 'window', 'entrance', 'door'):
            oname = oel.get('name', _local(oel.tag))
            c, r = _pose_matrix(_text(oel, 'pose'), '%s opening %r' % (what, oname))
            openings.append((oname, _Box(c, r, _vec(_text(oel, 'size'), 3, '%s opening %r size'
                                                    % (what, oname)),
                                         '%s opening %r' % (what, oname))))
    box, poly = _child(vel, 'box'), _child(vel, 'polyhedron')
    if box is not None:
        c, r = _pose_matrix(_text(box, 'pose'), what + ' box')
        verts, faces = _Box(c, r, _vec(_text(box, 'size'), 3, what + ' box size'),
                            what).mesh()
    elif poly is not None:
        verts = [_vec(p.text, 3, what + ' point') for p in poly if _local(p.tag) == 'point']
        faces = []
        for f in poly:
            if _local(f.tag) != 'face':
                continue
            try:
                faces.append(tuple(int(x) for x in f.text.split()))
            except (ValueError, AttributeError):
                raise EnvironmentError('%s: face must be point indices, got %r'
                                       % (what, f.text))
    else:
        raise EnvironmentError('%s needs a <box> or a <polyhedron>' % what)
    return IndoorVolume(name, verts, faces, openings, margin)


def parse_environment(wel):
    """Environment of a <world> element (xml.etree). Raises EnvironmentError."""
    env = Environment()
    sc = _child(wel, 'spherical_coordinates')
    if sc is not None:
        model = _text(sc, 'surface_model')
        if model not in (None, 'EARTH_WGS84'):
            raise EnvironmentError('spherical_coordinates surface_model must be EARTH_WGS84, '
                                   'got %r' % model)
        for tag, name in (('latitude_deg', 'latitude'), ('longitude_deg', 'longitude'),
                          ('elevation', 'elevation'), ('heading_deg', 'heading')):
            t = _text(sc, tag)
            if t is not None:
                _number(env, name, t)
    at = _child(wel, 'atmosphere')
    if at is not None:
        if at.get('type', 'adiabatic') != 'adiabatic':
            raise EnvironmentError('atmosphere type must be adiabatic, got %r' % at.get('type'))
        for tag, name in (('temperature', 'sea_level_temperature'),
                          ('pressure', 'sea_level_pressure'),
                          ('temperature_gradient', 'temperature_gradient')):
            t = _text(at, tag)
            if t is not None:
                _number(env, name, t)
    el = _child(wel, 'environment')
    if el is not None:
        for c in el:
            tag = _local(c.tag)
            if tag == 'indoor_volume':
                env.indoor_volumes.append(_volume(c))
            elif tag == 'magnetic_field':
                for sub, name in (('magnitude', 'magnetic_magnitude'),
                                  ('inclination', 'magnetic_inclination'),
                                  ('declination', 'magnetic_declination')):
                    t = _text(c, sub)
                    if t is not None:
                        _number(env, name, t)
            elif tag in VALUES:
                if c.text is None or not c.text.strip():
                    raise EnvironmentError('environment %s is empty' % tag)
                _number(env, tag, c.text.strip())
            elif isinstance(c.tag, str):
                raise EnvironmentError('unknown environment element <%s> (known: %s, '
                                       'magnetic_field, indoor_volume)'
                                       % (tag, ', '.join(sorted(VALUES))))
    env._given.clear()
    return env


def parse_environment_text(text):
    """Environment of a world file's text (tests)."""
    root = ET.fromstring(text)
    wel = root if _local(root.tag) == 'world' else root.find('world')
    return parse_environment(wel)
