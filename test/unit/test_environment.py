"""The world environment (issue 9): the office's location, north, field, atmosphere and
indoor volume; run-time changes; bad descriptions refused with one clear message."""
import math
import os

import numpy as np
import pytest

from sim_world.environment import (Environment, EnvironmentError, IndoorVolume,
                                   clear_sky_illuminance, parse_environment_text,
                                   sun_elevation)
from sim_world.model import ModelError
from sim_world.sdf import load_world_file, parse_world

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')


@pytest.fixture(scope='module')
def office():
    return load_world_file(OFFICE).environment


def test_office_carries_the_thesis_values(office):
    v = office.values()
    assert v['latitude'] == 48.148940 and v['longitude'] == 11.566730
    assert v['elevation'] == 519 and v['north_alpha'] == 338.5
    assert v['heading'] == pytest.approx(111.5)       # SDF's heading for the same north
    assert (v['sea_level_pressure'], v['sea_level_temperature'], v['temperature_gradient']) \
        == (101325, 288.15, -0.0065)
    # World Magnetic Model at Munich: ~48.7 uT, dip ~64 deg, declination ~4 deg east
    assert v['magnetic_magnitude'] == pytest.approx(48.7e-6, rel=0.03)
    assert v['magnetic_inclination'] == pytest.approx(64.4, abs=1.0)
    assert v['magnetic_declination'] == pytest.approx(4.2, abs=1.0)


def test_north_and_field_directions(office):
    a = math.radians(338.5)
    assert office.north_world() == pytest.approx([math.cos(a), math.sin(a), 0])
    n, e = office.north_world(), office.east_world()
    assert np.cross(e, n) == pytest.approx([0, 0, 1])     # east, north, up: right-handed
    b = office.magnetic_field_world()
    f, inc, dec = office.magnetic_elements()
    assert np.linalg.norm(b) == pytest.approx(f)
    assert b[2] < 0                                         # dips down in the north
    h = b[:2] / np.linalg.norm(b[:2])
    # horizontal field: north turned east by the declination
    ang = math.degrees(math.atan2(h.dot(e[:2]), h.dot(n[:2])))
    assert ang == pytest.approx(dec, abs=1e-6)


def test_pressure_falls_11_pa_per_metre_at_519_m(office):
    p0 = office.pressure_at(0.0)
    assert p0 == pytest.approx(101325 * (1 - 0.0065 * 519 / 288.15) ** 5.2559, rel=1e-4)
    assert office.pressure_at(1.0) - p0 == pytest.approx(-11.4, abs=0.3)
    env = load_world_file(OFFICE).environment
    env.set('pressure_offset', 250)
    assert env.pressure_at(0.0) == pytest.approx(p0 + 250)


def test_indoor_volume_and_door_margin(office):
    assert office.indoor((3.0, -2.0, 1.0)) == (True, 'office', False)
    assert office.indoor((5.5, -3.0, 1.0)) == (True, 'office', True)    # near the door
    assert office.indoor((2.0, -3.0, 1.0))[2] is False
    assert office.indoor((8.0, -3.0, 1.0)) == (False, '', False)        # outdoors
    assert office.air_temperature((3, -2, 1)) == 21 and office.air_temperature((8, -3, 1)) == 15


def test_geodetic_adds_metres_in_utm(office):
    lat0, lon0, alt0 = office.geodetic((0, 0, 0))
    assert (lat0, lon0, alt0) == pytest.approx((48.148940, 11.566730, 519))
    lat, lon, _ = office.geodetic(1000 * office.north_world())
    assert lon == pytest.approx(lon0, abs=1e-6)
    assert (lat - lat0) * 111195 == pytest.approx(1000, rel=0.003)     # ~111.2 km per degree
    lat, lon, _ = office.geodetic(1000 * office.east_world())
    assert lat == pytest.approx(lat0, abs=1e-5)
    assert (lon - lon0) * 111320 * math.cos(math.radians(lat0)) == pytest.approx(1000, rel=0.003)


def test_set_checks_names_and_ranges():
    env = Environment()
    env.set('temperature', 30)
    assert env.get('temperature') == 30
    with pytest.raises(EnvironmentError, match='humidity must be a number in'):
        env.set('humidity', 130)
    with pytest.raises(EnvironmentError, match='unknown environment value'):
        env.set('temprature', 1)
    with pytest.raises(EnvironmentError):
        env.set_many([('temperature', 5), ('humidity', -1)])
    assert env.get('temperature') == 30          # nothing changed
    seen = []
    env.on_change.append(lambda n, v: seen.append((n, v)))
    env.set('daylight', 500)
    assert seen == [('daylight', 500)]


def test_sun_elevation_by_hand():
    # solar noon: 90 - |latitude - declination|; 21 June (day 172): declination 23.45 deg
    assert sun_elevation(48.14894, 172, 12.0) == pytest.approx(90 - (48.14894 - 23.45), abs=0.01)
    assert sun_elevation(-33.9, 172, 12.0) == pytest.approx(90 - (33.9 + 23.45), abs=0.01)
    # an equinox (declination ~0): rises at 6, sets at 18 anywhere; the pole sees it on the
    # horizon all day
    for lat in (0.0, 48.0, -60.0):
        assert abs(sun_elevation(lat, 81, 6.0)) < 0.5 and abs(sun_elevation(lat, 81, 18.0)) < 0.5
    assert abs(sun_elevation(90.0, 81, 3.0)) < 0.5
    # midnight: below the horizon by 90 - lat + decl (winter, Munich: deep night)
    assert sun_elevation(48.14894, 355, 0.0) == pytest.approx(-(90 - 48.14894 + 23.45), abs=0.05)
    # symmetric about noon
    assert sun_elevation(30, 100, 9.5) == pytest.approx(sun_elevation(30, 100, 14.5))


def test_clear_sky_illuminance_is_the_ies_model():
    # sun at 30 deg, day 2 (E_ext = 1.034 x 127.5 klx): direct 131835 exp(-0.42) 0.5 = 43.3
    # klx, sky 0.8 + 15.5 sqrt(0.5) = 11.76 klx
    assert clear_sky_illuminance(30.0, 2) == pytest.approx(43314 + 11760, rel=1e-3)
    # a high summer sun gives the clear day's ~100 klx, sunrise hundreds, twilight's ends
    assert 90000 < clear_sky_illuminance(65.0, 172) < 120000
    assert clear_sky_illuminance(1e-6) == pytest.approx(800, rel=1e-2)
    assert clear_sky_illuminance(-1e-6) == pytest.approx(800, rel=1e-3)   # continuous
    assert clear_sky_illuminance(-6.0) == pytest.approx(3.0)
    assert clear_sky_illuminance(-12.0) == pytest.approx(0.008)
    assert clear_sky_illuminance(-40.0) == 0.001
    els = np.linspace(-30, 90, 241)
    lux = [clear_sky_illuminance(e) for e in els]
    assert np.all(np.diff(lux) >= 0)                  # brighter the higher the sun


def test_time_of_day_drives_daylight_and_the_last_one_set_wins():
    env = Environment()
    env.set('latitude', 48.14894)
    assert env.get('daylight') == 10000 and not env.daylight_from_sun     # not asked: as before
    seen = []
    env.on_change.append(lambda n, v: seen.append(n))
    env.set('time_of_day', 12.0)
    noon = env.get('daylight')
    assert env.daylight_from_sun and seen == ['time_of_day', 'daylight']
    assert noon == pytest.approx(clear_sky_illuminance(sun_elevation(48.14894, 80, 12.0)))
    assert 60000 < noon < 90000
    env.set('time_of_day', 0.0)
    assert env.get('daylight') == 0.001                                   # night
    env.set('time_of_day', 6.0)
    assert 300 < env.get('daylight') < 1000                               # sunrise
    env.set('day_of_year', 172)                                           # June: up earlier
    assert env.get('daylight') > 5000
    env.set('latitude', 0.0)                                              # the equator
    assert env.get('daylight') < 5000
    env.set('daylight', 1234)                                             # held
    assert env.get('daylight') == 1234 and not env.daylight_from_sun
    env.set('day_of_year', 10)
    assert env.get('daylight') == 1234 and env.get('time_of_day') == 6.0
    env.set_many([('daylight', 50), ('time_of_day', 12)])                 # the later wins
    assert env.get('daylight') > 50000
    env.set_many([('time_of_day', 12), ('daylight', 50)])
    assert env.get('daylight') == 50
    with pytest.raises(EnvironmentError, match=r'time_of_day must be a number in \[0, 24\]'):
        env.set('time_of_day', 25)
    assert env.get('time_of_day') == 12 and env.get('daylight') == 50      # nothing changed
    # from a world file: the sun at the world's latitude
    w = parse_environment_text(WORLD % (
        '<spherical_coordinates><latitude_deg>48.14894</latitude_deg></spherical_coordinates>'
        '<environment><time_of_day>12</time_of_day></environment>'))
    assert w.get('daylight') == pytest.approx(noon)


WORLD = '''<sdf version="1.6"><world name="w">%s</world></sdf>'''


@pytest.mark.parametrize('xml, words', [
    ('<spherical_coordinates><latitude_deg>95</latitude_deg></spherical_coordinates>',
     'latitude must be a number in [-90, 90]'),
    ('<environment><indoor_volume name="v"><polyhedron><point>0 0 0</point><point>1 0 0</point>'
     '<point>0 1 0</point><point>0 0 1</point><face>0 1 2</face><face>0 1 3</face>'
     '<face>0 2 3</face></polyhedron></indoor_volume></environment>',
     "indoor volume 'v' is not a closed polyhedron"),
    ('<environment><indoor_volume name="v"><box><size>1 -1 1</size></box></indoor_volume>'
     '</environment>', 'size must be three positive numbers'),
    ('<environment><humidty>5</humidty></environment>', 'unknown environment element <humidty>'),
    ('<environment><indoor_volume name="v" margin="-1"><box><size>1 1 1</size></box>'
     '</indoor_volume></environment>', 'margin must be >= 0'),
])
def test_bad_environment_is_refused_with_one_message(xml, words):
    with pytest.raises(ModelError, match='world .w.: .*' + words.replace('[', r'\[')
                       .replace(']', r'\]').replace('(', r'\(').replace(')', r'\)')):
        parse_world(WORLD % xml)


def test_closed_tetrahedron_contains():
    v = IndoorVolume('t', [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)],
                     [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)])
    assert v.contains((0.1, 0.1, 0.1)) and not v.contains((0.6, 0.6, 0.6))
    env = parse_environment_text(WORLD % '<environment><magnetic_field><magnitude>5e-5</magnitude>'
                                 '<inclination>0</inclination><declination>0</declination>'
                                 '</magnetic_field></environment>')
    assert env.magnetic_field_world() == pytest.approx([0, 5e-5, 0])   # alpha 90: north = +y
