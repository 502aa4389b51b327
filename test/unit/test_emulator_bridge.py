"""emulator_bridge without ROS: unit conversions, Android orientation angles, command
builders, and the console client/bridge against the console test server (auth, wrong token,
KO once per kind, wall-clock rate limit, reconnects, no server)."""
import math
import threading
import time
from types import SimpleNamespace as NS

import pytest

from emulator_bridge.bridge import (AuthError, Bridge, ConsoleClient, ConsoleError,
                                    battery_commands, cell_commands, fix_commands,
                                    fraction_to_percent, gga_satellites, humidity_commands,
                                    imu_commands, m_to_cm, magnetic_commands,
                                    orientation_angles, pa_to_hpa, pressure_commands,
                                    proximity_commands, tesla_to_microtesla, wifi_commands)
from fixtures.emulator_console_testserver import ConsoleTestServer
from sim_world.transforms import quat_from_rpy, quat_multiply
from sim_world.netutil import free_port  # noqa: E402


def v3(x, y, z):
    return NS(x=x, y=y, z=z)


class Log(object):
    def __init__(self):
        self.lines = []

    def __call__(self, text):
        self.lines.append(text)

    def count(self, word):
        return sum(word in l for l in self.lines)


# ------------------------------------------------------------------------- conversions

def test_unit_conversions():
    assert tesla_to_microtesla(48e-6) == pytest.approx(48.0)
    assert pa_to_hpa(95500.0) == pytest.approx(955.0)
    assert m_to_cm(0.05) == pytest.approx(5.0)
    assert fraction_to_percent(0.42) == pytest.approx(42.0)


# north along world +y (north_alpha 90) unless stated
@pytest.mark.parametrize('rpy, alpha, expect', [
    ((0, 0, 0), 90.0, (0, 0, 0)),                      # face up, top (+y) at north
    ((0, 0, -math.pi / 2), 90.0, (90, 0, 0)),         # turned clockwise: top at east
    ((0, 0, math.pi / 2), 90.0, (270, 0, 0)),         # top at west
    ((0, 0, math.pi), 90.0, (180, 0, 0)),             # top at south
    ((0, 0, 0), 0.0, (270, 0, 0)),                    # north along world x: top (+y) at west
])
def test_orientation_azimuth(rpy, alpha, expect):
    az, pitch, roll = orientation_angles(quat_from_rpy(*rpy), alpha)
    assert az == pytest.approx(expect[0], abs=1e-6)
    assert pitch == pytest.approx(expect[1], abs=1e-6)
    assert roll == pytest.approx(expect[2], abs=1e-6)


def test_orientation_pitch_and_roll():
    # top edge tilted up by 30 deg about the device x axis: pitch -30 (getOrientation:
    # asin(-R21), R21 = the up component of the device y axis = sin 30)
    q = quat_from_rpy(math.radians(30), 0, 0)
    az, pitch, roll = orientation_angles(q, 90.0)
    assert pitch == pytest.approx(-30.0, abs=1e-6)
    assert roll == pytest.approx(0.0, abs=1e-6)
    assert az == pytest.approx(0.0, abs=1e-6)
    # right edge lowered by 20 deg (rotation about device y by +20): x tilts down
    q = quat_from_rpy(0, math.radians(20), 0)
    az, pitch, roll = orientation_angles(q, 90.0)
    assert roll == pytest.approx(20.0, abs=1e-6)
    assert pitch == pytest.approx(0.0, abs=1e-6)
    # the office's north (338.5 deg): face up with the top at north is azimuth 0
    q = quat_from_rpy(0, 0, math.radians(338.5 - 90))
    assert orientation_angles(q, 338.5)[0] == pytest.approx(0.0, abs=1e-6)
    # upright (top up, screen towards south): pitch -90
    q = quat_multiply(quat_from_rpy(0, 0, 0), quat_from_rpy(math.pi / 2, 0, 0))
    assert orientation_angles(q, 90.0)[1] == pytest.approx(-90.0, abs=1e-6)


def test_orientation_bad_quaternion():
    with pytest.raises(ValueError):
        orientation_angles((0, 0, 0, 0), 90.0)


def imu(acc=(0, 0, 9.81), gyro=(0, 0, 0), q=(0, 0, 0, 1), ocov0=0.0):
    return NS(linear_acceleration=v3(*acc), angular_velocity=v3(*gyro),
              orientation=NS(x=q[0], y=q[1], z=q[2], w=q[3]),
              orientation_covariance=[ocov0] + [0.0] * 8)


def test_command_builders():
    cmds = dict(imu_commands(imu(acc=(0.01, 9.81, -0.02), gyro=(0.1, 0, 0)), 90.0))
    assert cmds['acceleration'] == 'sensor set acceleration 0.01:9.81:-0.02'
    assert cmds['gyroscope'] == 'sensor set gyroscope 0.1:0:0'
    assert cmds['orientation'] == 'sensor set orientation 0:0:0'
    # no orientation (covariance[0] == -1) or north unknown: no orientation command
    assert 'orientation' not in dict(imu_commands(imu(ocov0=-1.0), 90.0))
    assert 'orientation' not in dict(imu_commands(imu(), None))
    assert magnetic_commands(NS(magnetic_field=v3(20e-6, -5e-6, -44e-6))) == \
        [('magnetic-field', 'sensor set magnetic-field 20:-5:-44')]
    assert pressure_commands(NS(fluid_pressure=95512.0)) == \
        [('pressure', 'sensor set pressure 955.12')]
    assert humidity_commands(NS(relative_humidity=0.45)) == \
        [('humidity', 'sensor set humidity 45')]
    assert proximity_commands(NS(range=0.05, min_range=0.0, max_range=0.05)) == \
        [('proximity', 'sensor set proximity 5')]
    assert proximity_commands(NS(range=float('inf'), min_range=0.0, max_range=0.05)) == \
        [('proximity', 'sensor set proximity 5')]
    fix = NS(status=NS(status=0), latitude=48.26, longitude=11.67, altitude=519.3)
    assert fix_commands(fix, 9) == [('geo', 'geo fix 11.6700000 48.2600000 519.30 9')]
    assert fix_commands(fix, 40)[0][1].endswith(' 12')       # console: 1..12 satellites
    nofix = NS(status=NS(status=-1), latitude=float('nan'), longitude=float('nan'),
               altitude=float('nan'))
    assert fix_commands(nofix) == []
    bat = dict(battery_commands(NS(percentage=0.873, power_supply_status=2)))
    assert bat == {'power capacity': 'power capacity 87', 'power status': 'power status discharging',
                   'power ac': 'power ac off'}
    bat = dict(battery_commands(NS(percentage=1.0, power_supply_status=4)))
    assert bat['power status'] == 'power status full' and bat['power ac'] == 'power ac on'
    assert cell_commands(NS(enabled=True, cell_id='262-01-1', asu=17)) == \
        [('gsm signal', 'gsm signal 17')]
    assert cell_commands(NS(enabled=False, cell_id='', asu=17)) == \
        [('gsm signal', 'gsm signal 99')]
    assert wifi_commands(NS(enabled=True, connected=True, link_speed=54)) == \
        [('network speed', 'network speed 54000:54000')]
    assert wifi_commands(NS(enabled=True, connected=False, link_speed=0)) == []
    assert gga_satellites('$GPGGA,120000.00,4815.600,N,01140.200,E,1,07,1.0,519.3,M,0,M,,*47') == 7
    assert gga_satellites('$GPRMC,...') is None


# -------------------------------------------------------------------- console client

@pytest.fixture
def token_file(tmp_path):
    p = tmp_path / 'emulator_console_auth_token'
    p.write_text('s3cretTok3n\n')
    return str(p)


@pytest.fixture
def server(token_file):
    srv = ConsoleTestServer(token_file=token_file).start()
    yield srv
    srv.stop()


def test_auth_with_the_right_token(server, token_file):
    c = ConsoleClient('127.0.0.1', server.port, token_file=token_file, timeout=2)
    c.connect()
    assert c.command('sensor set acceleration 0:9.81:0') == (True, '')
    assert server.lines[0] == 'auth s3cretTok3n'
    assert server.accepted == ['sensor set acceleration 0:9.81:0']
    ok, text = c.command('sensor set acceleration 1:2')
    assert not ok and text.startswith('KO:')
    c.close()


def test_token_parameter_overrides_the_file(server, tmp_path):
    c = ConsoleClient('127.0.0.1', server.port, token='s3cretTok3n',
                      token_file=str(tmp_path / 'missing'), timeout=2)
    c.connect()
    assert c.command('ping')[0]


def test_wrong_token_names_the_file(server, tmp_path):
    bad = tmp_path / 'my_token'
    bad.write_text('wrong\n')
    c = ConsoleClient('127.0.0.1', server.port, token_file=str(bad), timeout=2)
    with pytest.raises(AuthError) as e:
        c.connect()
    assert str(bad) in str(e.value) and 'refused' in str(e.value)
    assert server.auth_failures == 1
    missing = ConsoleClient('127.0.0.1', server.port, token_file=str(tmp_path / 'none'),
                            timeout=2)
    with pytest.raises(AuthError) as e:
        missing.connect()
    assert str(tmp_path / 'none') in str(e.value)


def test_bridge_logs_wrong_token_once(server, tmp_path):
    bad = tmp_path / 'tok'
    bad.write_text('nope')
    log = Log()
    b = Bridge(ConsoleClient('127.0.0.1', server.port, token_file=str(bad), timeout=2),
               retry_period=0.0, info=log, warn=log, error=log)
    b.submit('light', 'sensor set light 300')
    for _ in range(5):
        b.step()
    assert server.auth_failures == 5
    assert log.count(str(bad)) == 1
    assert server.accepted == []


def test_ko_logged_once_per_kind(token_file):
    srv = ConsoleTestServer(token_file=token_file, disabled=('humidity',)).start()
    try:
        log = Log()
        t = [0.0]
        b = Bridge(ConsoleClient('127.0.0.1', srv.port, token_file=token_file, timeout=2),
                   rate=50, info=log, warn=log, error=log, clock=lambda: t[0])
        for i in range(10):
            b.submit('humidity', 'sensor set humidity %d' % (40 + i))
            b.submit('light', 'sensor set light %d' % (100 + i))
            b.submit('bogus', 'sensor set bogus 1')
            b.step()
            t[0] += 0.05
        assert b.refused == {'humidity': 10, 'bogus': 10}
        assert log.count('refused') == 2
        assert log.count("'sensor set humidity 40'") == 1
        assert log.count('KO: sensor humidity is not enabled') == 1
        assert len(srv.commands('sensor set light')) == 10
    finally:
        srv.stop()


def test_rate_limit_wall_clock(server, token_file):
    """200 values in 1 s of wall time at 50 Hz: about 50 reach the console, the last one
    among them (latest value wins); another kind is limited on its own."""
    b = Bridge(ConsoleClient('127.0.0.1', server.port, token_file=token_file, timeout=2),
               rate=50, info=Log(), warn=Log(), error=Log())
    b.start()
    try:
        t0 = time.monotonic()
        for i in range(200):
            b.submit('acceleration', 'sensor set acceleration 0:%d:0' % i)
            if i % 4 == 0:
                b.submit('light', 'sensor set light %d' % i)
            target = t0 + (i + 1) * 0.005
            while time.monotonic() < target:
                time.sleep(0.001)
        elapsed = time.monotonic() - t0
        got = server.wait_for('sensor set acceleration 0:199:0', 1, 3.0)
        assert got, 'the latest value never arrived'
        acc = server.commands('sensor set acceleration')
        light = server.commands('sensor set light')
        # at most one per 20 ms (+1 for the final flush), and not starved
        assert len(acc) <= 50 * elapsed + 3
        assert len(acc) >= 10                   # not starved (loose: a loaded machine)
        assert len(light) <= 50 * elapsed + 3 and len(light) >= 10
        nums = [int(c.split(':')[1]) for c in acc]
        assert nums == sorted(nums)
    finally:
        b.stop()


def test_rate_limit_with_a_fake_clock(server, token_file):
    t = [0.0]
    b = Bridge(ConsoleClient('127.0.0.1', server.port, token_file=token_file, timeout=2),
               rate=50, info=Log(), warn=Log(), error=Log(), clock=lambda: t[0])
    for i in range(200):          # 200 values over 1 s, one step per value
        b.submit('acceleration', 'sensor set acceleration 0:%d:0' % i)
        b.step()
        t[0] += 0.005
    n = len(server.commands('sensor set acceleration'))
    assert 49 <= n <= 51


def test_reconnect_after_restart_and_mid_command(token_file):
    port = free_port()
    srv = ConsoleTestServer(port=port, token_file=token_file).start()
    log = Log()
    t = [0.0]
    b = Bridge(ConsoleClient('127.0.0.1', port, token_file=token_file, timeout=2),
               rate=50, retry_period=2.0, info=log, warn=log, error=log, clock=lambda: t[0])
    try:
        b.submit('light', 'sensor set light 1')
        b.step()
        assert srv.commands('sensor set light') == ['sensor set light 1']
        # the emulator restarts on the same port
        srv.restart()
        t[0] += 1.0
        b.submit('light', 'sensor set light 2')
        b.step()                      # finds the connection closed: reconnects at once
        b.step()
        assert srv.commands('sensor set light') == ['sensor set light 1', 'sensor set light 2']
        assert srv.connections == 2 and b.connects == 2
        # the console closes the connection on receiving the next command (no reply)
        srv.close_mid_command(1)
        t[0] += 1.0
        b.submit('light', 'sensor set light 3')
        b.step()
        assert log.count('reconnecting') >= 1
        b.step()
        assert srv.commands('sensor set light')[1:] == ['sensor set light 2', 'sensor set light 3']
        assert b.connects == 3
        assert 'sensor set light 3' in srv.lines
    finally:
        srv.stop()


def test_no_server_one_line_per_retry_period(token_file):
    port = free_port()
    log = Log()
    t = [100.0]
    b = Bridge(ConsoleClient('127.0.0.1', port, token_file=token_file, timeout=1),
               retry_period=2.0, info=log, warn=log, error=log, clock=lambda: t[0])
    b.submit('light', 'sensor set light 5')
    for _ in range(100):          # 10 s in steps of 0.1 s
        b.step()
        t[0] += 0.1
    assert log.count('no emulator console at 127.0.0.1:%d' % port) == 5
    assert 'retrying every 2 s' in log.lines[0]
    # the emulator comes up: the pending value goes out
    srv = ConsoleTestServer(port=port, token_file=token_file).start()
    try:
        t[0] += 2.0
        b.step()
        assert srv.commands('sensor set light') == ['sensor set light 5']
    finally:
        srv.stop()


def test_console_error_on_refused_connect():
    c = ConsoleClient('127.0.0.1', free_port(), timeout=1)
    with pytest.raises(ConsoleError):
        c.connect()
    with pytest.raises(ConsoleError):
        c.command('ping')


def test_no_auth_when_the_console_does_not_ask(tmp_path):
    empty = tmp_path / 'empty'
    empty.write_text('')
    srv = ConsoleTestServer(token_file=str(empty)).start()
    try:
        c = ConsoleClient('127.0.0.1', srv.port, token_file=str(tmp_path / 'none'), timeout=2)
        c.connect()
        assert c.command('geo fix 11.67 48.26 519 8')[0]
        assert srv.lines == ['geo fix 11.67 48.26 519 8']
        assert not c.command('geo fix 181 48 519 8')[0]      # argument check of the server
    finally:
        srv.stop()


def test_bridge_connects_before_the_first_value(server, token_file):
    log = Log()
    b = Bridge(ConsoleClient('127.0.0.1', server.port, token_file=token_file, timeout=2),
               info=log, warn=log, error=log)
    assert b.step() == 0
    assert b.connects == 1 and server.lines == ['auth s3cretTok3n']
    assert log.count('connected to the emulator console') == 1


def test_console_that_always_breaks_is_retried_per_period(token_file):
    """A console closing every connection at its first command: one attempt (and one
    warning) per retry period, not a busy loop."""
    srv = ConsoleTestServer(token_file=token_file).start()
    log = Log()
    t = [0.0]
    b = Bridge(ConsoleClient('127.0.0.1', srv.port, token_file=token_file, timeout=2),
               retry_period=2.0, info=log, warn=log, error=log, clock=lambda: t[0])
    try:
        b.submit('light', 'sensor set light 7')
        for _ in range(40):          # 4 s
            srv.close_mid_command(1)
            b.step()
            t[0] += 0.1
        assert srv.connections == 2
        assert log.count('reconnecting') == 2
        assert srv.commands('sensor set light') == []
        srv.close_mid_command(None)   # the console works again: the value goes out
        b.step(t[0] + 2.0)
        assert srv.commands('sensor set light') == ['sensor set light 7']
    finally:
        srv.stop()
