"""The compass example app's pairing of magnetometer and accelerometer readings: the same
azimuths in the same order whichever subscription's thread runs first (rospy runs each
subscription's callbacks in a thread of its own; bench/load found the app's outputs changed
under load when it used "the last accelerometer reading received")."""
import importlib.util
import itertools
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
spec = importlib.util.spec_from_file_location(
    'compass_app', os.path.join(ROOT, 'testing_instance', 'examples', 'compass_app.py'))
compass_app = importlib.util.module_from_spec(spec)
spec.loader.exec_module(compass_app)

MS = 1000000


def slice_events():
    """One 0.05 s slice of the world: the IMU at 100 Hz, the magnetometer at 50 Hz, stamped
    at the same ticks (ns)."""
    acc = [('acc', t * 10 * MS, (0.0, 0.1 * t, 9.8)) for t in range(1, 6)]
    mag = [('mag', t * 20 * MS, (2e-5 + t * 1e-6, 0.0, -4e-5)) for t in range(1, 3)]
    return acc, mag


def run(order):
    out = []
    p = compass_app.Pairing(lambda a, m: out.append((a, m)))
    for kind, t, v in order:
        (p.on_acc if kind == 'acc' else p.on_mag)(t, v)
    return out


def interleavings(a, b):
    """Every merge of the two sequences that keeps each one's own order (each
    subscription's messages arrive in order; the threads interleave anyhow)."""
    n = len(a) + len(b)
    for pos in itertools.combinations(range(n), len(a)):
        ai, bi, out = iter(a), iter(b), []
        for i in range(n):
            out.append(next(ai) if i in pos else next(bi))
        yield out


def test_every_interleaving_of_the_two_threads_gives_the_same_pairs():
    acc, mag = slice_events()
    results = {tuple(run(order)) for order in interleavings(acc, mag)}
    assert len(results) == 1
    pairs = results.pop()
    # each magnetometer reading with the accelerometer reading of its own tick
    assert pairs == ((acc[1][2], mag[0][2]), (acc[3][2], mag[1][2]))


def test_a_reading_waits_for_an_accelerometer_reading_at_or_after_it():
    out = []
    p = compass_app.Pairing(lambda a, m: out.append((a, m)))
    p.on_acc(10 * MS, 'a10')
    p.on_mag(20 * MS, 'm20')          # the 20 ms accelerometer reading is not here yet
    assert out == []
    p.on_acc(20 * MS, 'a20')
    assert out == [('a20', 'm20')]
    p.on_mag(5 * MS, 'm5')            # older than every kept reading but one: 'a10' is later
    assert out == [('a20', 'm20')]    # nothing at or before 5 ms: no azimuth for it
    p.on_acc(20 * MS, 'again')        # a repeated stamp is not a new reading
    p.on_mag(20 * MS, 'm20b')
    assert out[-1] == ('a20', 'm20b')
