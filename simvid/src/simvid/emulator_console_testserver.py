"""A stand-in for the Android emulator console, for tests (no emulator runs here).

Speaks the documented grammar (Android emulator docs "Send emulator console commands",
android/console.cpp): the banner, ``Android Console: Authentication required`` with the
token file's path when a token file with a token is given, ``auth <token>``, one reply per
command, ``OK`` or ``KO: <reason>``, and checks the arguments of the commands the bridge
uses: ``sensor set <name> <v[:v...]>``, ``sensor get``, ``geo fix <lon> <lat> [alt] [sats]
[knots]``, ``power capacity|status|ac|present|health``, ``gsm signal <rssi> [ber]``,
``network speed <name|kbit|up:down>``, ``ping``, ``help``, ``quit``/``exit``.

It records every line it gets (``lines``) and the commands it accepted (``accepted``), can
be stopped and started again on the same port (an emulator restart), close a connection in
the middle of a command (``close_mid_command(n)``) and refuse a sensor (``disabled``).

Run by hand: ``python3 -m simvid.emulator_console_testserver --port 5554 [--token-file F]``.
"""
import argparse
import math
import os
import socket
import threading
import time

# name -> number of values (android/hw-sensors.h)
SENSORS = {'acceleration': 3, 'gyroscope': 3, 'magnetic-field': 3, 'orientation': 3,
           'temperature': 1, 'proximity': 1, 'light': 1, 'pressure': 1, 'humidity': 1,
           'magnetic-field-uncalibrated': 3, 'gyroscope-uncalibrated': 3}
NET_SPEEDS = ('gsm', 'hscsd', 'gprs', 'edge', 'umts', 'hsdpa', 'lte', 'evdo', 'full')
HELP = "Android Console: type 'help' for a list of commands"


def _num(text):
    v = float(text)
    if not math.isfinite(v):
        raise ValueError(text)
    return v


class ConsoleTestServer(object):
    def __init__(self, port=0, host='127.0.0.1', token_file=None, disabled=()):
        self.host, self.port = host, int(port)
        self.token_file = token_file
        self.disabled = set(disabled)
        self.lines = []          # every line received (after the banner), in order
        self.accepted = []       # commands answered OK (auth excluded)
        self.connections = 0
        self.auth_failures = 0
        self._close_after = None  # close the connection on receiving the n-th next command
        self._lock = threading.Lock()
        self._srv = None
        self._clients = []
        self._thread = None

    # -- life cycle ----------------------------------------------------------------------
    def start(self):
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((self.host, self.port))
        s.listen(8)
        self.port = s.getsockname()[1]
        self._srv = s
        self._thread = threading.Thread(target=self._accept_loop, args=(s,), daemon=True)
        self._thread.start()
        return self

    def stop(self):
        """Close the listening socket and every connection (the emulator quits)."""
        s, self._srv = self._srv, None
        if s is not None:
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            s.close()
        with self._lock:
            clients, self._clients = self._clients, []
        for c in clients:
            try:
                c.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            c.close()
        if self._thread is not None:
            self._thread.join(2.0)

    def restart(self, pause=0.0):
        self.stop()
        time.sleep(pause)
        return self.start()

    def close_mid_command(self, n=1):
        """Close the connection on receiving the n-th next command (``auth`` not counted),
        without a reply; None: cancel."""
        with self._lock:
            self._close_after = None if n is None else int(n)

    # -- records -------------------------------------------------------------------------
    def commands(self, prefix=''):
        with self._lock:
            return [c for c in self.accepted if c.startswith(prefix)]

    def wait_for(self, prefix, count=1, timeout=10.0):
        deadline = time.time() + timeout
        while time.time() < deadline:
            got = self.commands(prefix)
            if len(got) >= count:
                return got
            time.sleep(0.01)
        return self.commands(prefix)

    # -- protocol ------------------------------------------------------------------------
    def _token(self):
        if not self.token_file:
            return ''
        try:
            with open(self.token_file) as f:
                return f.read().strip()
        except (IOError, OSError):
            return ''

    def _accept_loop(self, srv):
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            with self._lock:
                self._clients.append(conn)
                self.connections += 1
            threading.Thread(target=self._serve, args=(conn,), daemon=True).start()

    def _serve(self, conn):
        f = conn.makefile('rb')

        def out(text):
            conn.sendall((text + '\r\n').encode())

        try:
            token = self._token()
            authed = not token
            if token:
                out('Android Console: Authentication required')
                out("Android Console: type 'auth <auth_token>' to authenticate")
                out('Android Console: you can find your <auth_token> in')
                out("'%s'" % os.path.abspath(self.token_file))
            else:
                out(HELP)
            out('OK')
            for raw in f:
                line = raw.decode('utf-8', 'replace').strip()
                if not line:
                    continue
                with self._lock:
                    self.lines.append(line)
                    close = False
                    if self._close_after is not None and not line.startswith('auth'):
                        self._close_after -= 1
                        if self._close_after <= 0:
                            self._close_after, close = None, True
                if close:
                    return
                words = line.split()
                cmd = words[0].lower()
                if cmd in ('quit', 'exit'):
                    return
                if cmd == 'auth':
                    if not token or (len(words) == 2 and words[1] == token):
                        authed = True
                        out(HELP)
                        out('OK')
                    else:
                        with self._lock:
                            self.auth_failures += 1
                        out('KO: authentication token does not match %s'
                            % os.path.abspath(self.token_file))
                    continue
                if cmd in ('help', 'h', '?'):
                    out('Android console command help:')
                    out('OK')
                    continue
                if not authed:
                    out("KO: unknown command, try 'help'")
                    continue
                err = self._check(words)
                if err:
                    out('KO: ' + err)
                else:
                    with self._lock:
                        self.accepted.append(' '.join(words))
                    out('OK')
        except OSError:
            pass
        finally:
            with self._lock:
                if conn in self._clients:
                    self._clients.remove(conn)
            try:
                conn.close()
            except OSError:
                pass

    def _check(self, w):
        """None when the command is valid, else the KO reason."""
        cmd, args = w[0].lower(), w[1:]
        try:
            if cmd == 'ping':
                return None
            if cmd == 'sensor':
                if not args or args[0] not in ('set', 'get', 'status'):
                    return "bad sub-command, try 'help sensor'"
                if args[0] == 'status':
                    return None
                if len(args) < 2 or args[1] not in SENSORS:
                    return ("unknown sensor name: %s, run 'sensor status' to get available "
                            'sensors.' % (args[1] if len(args) > 1 else ''))
                if args[1] in self.disabled:
                    return 'sensor %s is not enabled on this virtual device' % args[1]
                if args[0] == 'get':
                    return None
                if len(args) != 3:
                    return 'Usage: "sensor set <sensorname> <value-a>[:<value-b>[:<value-c>]]"'
                vals = args[2].split(':')
                if len(vals) != SENSORS[args[1]]:
                    return 'sensor %s takes %d values, got %d' % (args[1], SENSORS[args[1]],
                                                                  len(vals))
                [_num(v) for v in vals]
                return None
            if cmd == 'geo':
                if not args or args[0] != 'fix':
                    return "bad sub-command, try 'help geo'"
                a = args[1:]
                if not 2 <= len(a) <= 5:
                    return 'geo fix takes 2 to 5 arguments'
                lon, lat = _num(a[0]), _num(a[1])
                if not (-180 <= lon <= 180) or not (-90 <= lat <= 90):
                    return 'invalid longitude or latitude'
                if len(a) > 2:
                    _num(a[2])
                if len(a) > 3 and not 1 <= int(a[3]) <= 12:
                    return 'invalid number of satellites. Must be an integer between 1 and 12'
                return None
            if cmd == 'power':
                if len(args) != 2:
                    return "bad power command, try 'help power'"
                sub, v = args
                choices = {'ac': ('on', 'off'),
                           'status': ('unknown', 'charging', 'discharging', 'not-charging',
                                      'full'),
                           'present': ('true', 'false'),
                           'health': ('unknown', 'good', 'overheat', 'dead', 'overvoltage',
                                      'failure')}
                if sub == 'capacity':
                    if not v.isdigit() or not 0 <= int(v) <= 100:
                        return 'Usage: "power capacity <percentage>"'
                    return None
                if sub in choices:
                    return None if v in choices[sub] else 'invalid %s value %s' % (sub, v)
                return "bad power command, try 'help power'"
            if cmd == 'gsm':
                if not args or args[0] != 'signal' or not 2 <= len(args) <= 3:
                    return "bad gsm command, try 'help gsm'"
                rssi = int(args[1])
                if not (0 <= rssi <= 31 or rssi == 99):
                    return 'invalid RSSI - must be 0..31 or 99'
                if len(args) == 3:
                    ber = int(args[2])
                    if not (0 <= ber <= 7 or ber == 99):
                        return 'invalid BER - must be 0..7 or 99'
                return None
            if cmd == 'network':
                if len(args) < 2 or args[0] != 'speed':
                    return "bad network command, try 'help network'"
                spec = ':'.join(args[1:])   # "up:down" or "up down"
                if spec in NET_SPEEDS:
                    return None
                parts = spec.split(':')
                if len(parts) > 2 or any(_num(p) < 0 for p in parts):
                    return 'invalid speed'
                return None
        except (ValueError, IndexError):
            return 'invalid arguments: ' + ' '.join(w)
        return "unknown command, try 'help'"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--port', type=int, default=5554)
    ap.add_argument('--host', default='127.0.0.1')
    ap.add_argument('--token-file', default=None)
    a = ap.parse_args(argv)
    srv = ConsoleTestServer(a.port, a.host, a.token_file).start()
    print('console test server on %s:%d' % (a.host, srv.port), flush=True)
    seen = 0
    try:
        while True:
            time.sleep(0.2)
            with srv._lock:
                new, seen = srv.lines[seen:], len(srv.lines)
            for line in new:
                print(line, flush=True)
    except KeyboardInterrupt:
        srv.stop()


if __name__ == '__main__':
    main()
