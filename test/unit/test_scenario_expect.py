"""Expectation semantics on synthetic message streams (sim time, no ROS master)."""
import numpy as np
import pytest
from sensor_msgs.msg import Image, Imu
from std_msgs.msg import String

from testing_instance.scenario.expect import Expectation, FieldError, Predicate, get_field


def imu(z):
    m = Imu()
    m.linear_acceleration.z = z
    return m


def run(spec, stream, t_end=10.0):
    e = Expectation(dict(spec, name='e', topic='/imu'), duration=t_end)
    for t, m in stream:
        e.feed(t, m)
    return e.finish(t_end)


def test_eventually_passes_at_the_first_matching_message():
    s = [(t * 0.1, imu(9.0 + t * 0.1)) for t in range(100)]
    v = run({'field': 'linear_acceleration.z', 'eventually': {'ge': 9.5}}, s)
    assert v.passed and v.t == pytest.approx(0.5)
    assert v.actual == '9.5' and v.line().startswith('PASS e: expected eventually')


def test_eventually_fails_at_window_end_with_last_value():
    s = [(t * 0.1, imu(9.0)) for t in range(100)]
    v = run({'field': 'linear_acceleration.z', 'eventually': {'near': 5.0, 'tol': 0.1},
             'window': [1.0, 2.0]}, s)
    assert not v.passed and v.t == pytest.approx(2.0)
    assert 'none matched' in v.actual and '5 +- 0.1' in v.expected


def test_window_excludes_messages_outside():
    s = [(0.5, imu(1.0)), (1.5, imu(9.8)), (2.5, imu(1.0))]
    v = run({'field': 'linear_acceleration.z', 'always': {'near': 9.8, 'tol': 0.1},
             'window': [1.0, 2.0]}, s)
    assert v.passed and v.actual.startswith('last 9.8 (1 messages)')
    v = run({'field': 'linear_acceleration.z', 'always': {'near': 9.8, 'tol': 0.1},
             'window': [1.0, 3.0]}, s)
    assert not v.passed and v.t == 2.5


def test_always_needs_a_message():
    v = run({'field': 'linear_acceleration.z', 'always': {'gt': 0}, 'window': [1, 2]},
            [(0.5, imu(1.0))])
    assert not v.passed and v.actual.startswith('no message in the window')


def test_never():
    s = [(t * 0.1, imu(9.8)) for t in range(50)] + [(5.0, imu(20.0))]
    assert not run({'field': 'linear_acceleration.z', 'never': {'gt': 15}}, s).passed
    assert run({'field': 'linear_acceleration.z', 'never': {'gt': 15},
                'window': [0, 4.9]}, s).passed
    assert run({'field': 'linear_acceleration.z', 'never': {'gt': 15}}, []).passed


def test_tolerances_vectors_and_comparisons():
    m = imu(9.81)
    assert Predicate({'near': [0, 0, 9.8], 'tol': 0.02}).test(m.linear_acceleration)
    assert not Predicate({'near': [0, 0, 9.8], 'tol': 0.001}).test(m.linear_acceleration)
    assert Predicate({'between': [9, 10]}).test(9.5)
    assert not Predicate({'between': [9, 10]}).test(10.5)
    assert Predicate({'equals': 'a b'}).test('a b')
    assert Predicate({'contains': 'tum.de'}).test('http://vmi.lmt.ei.tum.de')
    assert Predicate({'gt': 1, 'lt': 3}).test(2) and not Predicate({'gt': 1, 'lt': 3}).test(3)
    assert not Predicate({'gt': 1}).test('text')     # a type mismatch is false, not an error
    assert Predicate({'not_equals': 0}).test(1)


def test_count_and_rate_in_sim_time():
    s = [(i * 0.01, imu(0)) for i in range(301)]   # 100 Hz over 3 s
    assert run({'rate': {'near': 100, 'tol': 0.5}, 'window': [1, 2]}, s).passed
    v = run({'rate': {'near': 50, 'tol': 1}, 'window': [1, 2]}, s)
    assert not v.passed and v.actual.startswith('100 Hz')
    assert run({'count': {'equals': 101}, 'window': [1, 2]}, s).passed
    assert not run({'count': {'max': 10}, 'window': [1, 2]}, s).passed


def test_after_an_event_shifts_the_window():
    e = Expectation({'name': 'e', 'topic': '/s', 'field': 'data', 'after': 'go',
                     'eventually': {'equals': 'x'}, 'window': [0, 1]})
    e.feed(0.5, String('x'))        # before the event: not in any window
    e.start(3.0)
    e.feed(3.5, String('y'))
    e.feed(4.2, String('x'))        # after the window [3, 4]
    v = e.finish(10)
    assert not v.passed and v.t == 3.5
    e2 = Expectation({'name': 'e', 'topic': '/s', 'after': 'go', 'eventually': {'equals': 1}})
    v = e2.finish(10)
    assert v.error and "never happened" in v.actual


def test_a_world_not_at_sim_time_0_shifts_every_window():
    """An attached world that ran before starts the scenario at its t0: a window without
    'after' is relative to it, as the timeline is (it was absolute: a second scenario on a
    rostest world saw no message in [0, 1])."""
    e = Expectation({'name': 'e', 'topic': '/s', 'field': 'data',
                     'eventually': {'equals': 'x'}, 'window': [0, 1]}, duration=2.0)
    e.begin(2.0)
    e.feed(0.5, String('x'))        # before the scenario: not in its window [2, 3]
    e.feed(2.5, String('x'))
    v = e.finish(4.0)
    assert v.passed and v.t == 2.5 and '[2.000, 3.000] s' in v.expected
    a = Expectation({'name': 'a', 'topic': '/s', 'after': 'go', 'eventually': {'equals': 1}})
    a.begin(2.0)                    # 'after' windows wait for their event
    assert a.window is None


def test_missing_field_is_an_error_naming_it():
    v = run({'field': 'linear_acceleraton.z', 'eventually': {'gt': 0}}, [(1, imu(1))])
    assert v.error and v.status == 'ERROR'
    assert "has no field 'linear_acceleraton'" in v.actual
    with pytest.raises(FieldError):
        get_field(imu(0), 'orientation_covariance[12]')
    assert get_field(imu(0), 'orientation_covariance[8]') == 0.0


def test_scenario_ending_early_is_an_error():
    v = run({'field': 'linear_acceleration.z', 'always': {'gt': 0}, 'window': [1, 20]},
            [(1, imu(1))], t_end=5)
    assert v.error


def rgb_image(arr):
    m = Image()
    m.height, m.width = arr.shape[:2]
    m.encoding = 'rgb8'
    m.step = m.width * 3
    m.data = arr.astype(np.uint8).tobytes()
    return m


def test_image_region_colour_and_led():
    a = np.zeros((40, 60, 3), np.uint8)
    a[10:20, 10:20] = (250, 20, 20)
    msg = rgb_image(a)
    p = Predicate({'region': [10, 10, 10, 10], 'colour': [255, 0, 0], 'tol': 30})
    assert p.test(p.image_facts(msg))
    p = Predicate({'region': [30, 10, 10, 10], 'colour': [255, 0, 0], 'tol': 30})
    assert not p.test(p.image_facts(msg))
    on = Predicate({'region': [10, 10, 10, 10], 'led': 'on', 'threshold': 80})
    off = Predicate({'region': [40, 25, 10, 10], 'led': 'on', 'threshold': 80})
    assert on.test(on.image_facts(msg)) and not off.test(off.image_facts(msg))
    e = Expectation({'name': 'led', 'topic': '/img', 'never': {
        'region': [10, 10, 10, 10], 'threshold': 80, 'led': 'off'}}, duration=5)
    e.feed(1.0, msg)
    assert e.finish(5).passed
    e = Expectation({'name': 'led', 'topic': '/img', 'eventually': {
        'region': [100, 100, 5, 5], 'led': 'on'}}, duration=5)
    e.feed(1.0, msg)
    v = e.finish(5)
    assert v.error and 'outside' in v.actual


def test_image_barcode():
    import os
    import cv2
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    from glob import glob
    pngs = sorted(glob(os.path.join(root, 'sim_world', 'worlds', 'media', '**', '*qr*.png'),
                       recursive=True))
    if not pngs:
        pytest.skip('no QR picture in sim_world/worlds/media')
    bgr = cv2.imread(pngs[0])
    msg = rgb_image(bgr[:, :, ::-1])
    p = Predicate({'barcode': 'no such payload'})
    facts = p.image_facts(msg)
    assert facts['barcodes'], 'the QR picture decodes'
    assert not p.test(facts)
    assert Predicate({'barcode': facts['barcodes'][0]}).test(facts)
    assert Predicate({'barcode': facts['barcode_texts'][0]}).test(facts)
