"""testing_instance.report without ROS processes: a Collector fed synthetic streams writes
a self-contained page whose verdict rows, plots (window, band, deciding message), frames
with outlined regions, non-numeric notes and farm index say what the run did; a report
folder that cannot be written is one line and nothing else changes."""
import json
import os
import re
import types

import numpy as np
import pytest

pytest.importorskip('rospy')

from testing_instance.scenario.expect import Expectation  # noqa: E402
from testing_instance.report import (Collector, band_of, decimate, nice_ticks,  # noqa: E402
                                     numeric_value, svg_plot, write_index, write_invalid)
from testing_instance.run.runner import Result  # noqa: E402
from testing_instance.scenario.format import load  # noqa: E402

SCENARIO = """\
name: synthetic
description: a report made from synthetic streams
seed: 7
duration: 2.0
world: {args: {camera_rate: 10, display_topic: /app/screen}}
timeline:
  - {id: turn, at: 1.0, action: log, text: turning now}
expect:
  - {name: heading, topic: /app/heading, field: data, always: {near: 10, tol: 2},
     window: [1.2, 2.0]}
  - {name: label, topic: /app/label, field: data, eventually: {equals: 'north'}}
  - {name: screen_green, topic: /app/screen, eventually: {region: [0, 0, 8, 4],
     colour: [0, 255, 0], tol: 10}}
  - {name: heading_rate, topic: /app/heading, rate: {near: 20, tol: 1}}
"""


class Msg(object):
    __slots__ = ('data',)

    def __init__(self, data):
        self.data = data


def _image(t, rgb):
    from simvid.imageconv import array_to_image
    arr = np.zeros((16, 24, 3), np.uint8)
    arr[:] = rgb
    return array_to_image(arr, 'rgb8')


def _run(tmp_path, out_dir):
    f = tmp_path / 'synthetic.yaml'
    f.write_text(SCENARIO)
    sc = load(str(f))
    exps = [Expectation(e, sc.duration) for e in sc.expect]
    lines = []
    r = types.SimpleNamespace(sc=sc, expectations=exps, event_times={'turn': 1.0}, seed=7,
                              rtf=0.0, replay=None, t0=0.0, loop_wall=(2.0, 2.0),
                              say=lines.append)
    c = Collector(r, str(out_dir))
    stream = []
    for i in range(41):                       # 20 Hz: 0 until 1.2 s, then 250 (a failure)
        t = i * 0.05
        stream.append((t, '/app/heading', Msg(0.0 if t < 1.0 else 250.0)))
    stream += [(0.3, '/app/label', Msg('south')), (1.1, '/app/label', Msg('west'))]
    stream += [(0.0, '/app/screen', _image(0.0, (80, 80, 80))),
               (1.5, '/app/screen', _image(1.5, (0, 255, 0)))]
    stream.sort(key=lambda x: x[0])
    by_topic = {}
    for e in exps:
        by_topic.setdefault(e.topic, []).append(e)
    for t, topic, msg in stream:
        for e in by_topic.get(topic, ()):
            e.feed(t, msg)
        c.feed(t, topic, msg)
    verdicts = [e.finish(2.0) for e in exps]
    res = Result('synthetic', verdicts, sim_time=2.0, wall=3.0)
    path = c.write(res)
    return res, path, lines


def test_report_page_and_data(tmp_path):
    res, path, lines = _run(tmp_path, tmp_path / 'rep')
    assert res.status == 'FAIL' and res.exit_code == 1
    assert path == str(tmp_path / 'rep' / 'index.html')
    page = open(path).read()
    d = json.load(open(str(tmp_path / 'rep' / 'report.json')))
    st = {v['name']: v['status'] for v in d['verdicts']}
    assert st == {'heading': 'FAIL', 'label': 'FAIL', 'screen_green': 'PASS',
                  'heading_rate': 'PASS'}
    for name, status in st.items():
        assert re.search(r'<tr class="verdict status-%s" data-status="%s" data-name="%s">'
                         % (status, status, name), page)
    # the failing plot: window shaded, band 8..12, the deciding message at 1.2 s, value 250
    p = d['plots']['heading']
    assert p['window'] == [1.2, 2.0] and p['band'] == ['band', 8.0, 12.0]
    assert p['decider'] == [1.2, 250.0]
    assert len(p['series'][0][1]) == 41
    block = page[page.index('id="plot-heading"'):]
    block = block[:block.index('</svg>')]
    assert 'class="window"' in block and 'class="band"' in block
    assert 'class="decide-line"' in block and 'FAIL t=1.200 s: 250' in block
    # a string field: no plot, its row and one output line say so, its values are listed
    row = [v for v in d['verdicts'] if v['name'] == 'label'][0]
    assert row['plot'] is None and 'is not numeric' in row['note']
    assert any(ln.startswith('report: label: no plot, /app/label.data is not numeric (str')
               for ln in lines), lines
    assert "'west'" in page
    # the rate's plot, the header, the command that reruns it
    assert d['plots']['heading_rate']['band'] == ['band', 19.0, 21.0]
    assert 'run_scenario' in d['command'] and '--seed 7' in d['command']
    assert 'turning now' in page
    # the display frame with the checked region outlined; files in the folder
    assert 'class="region"' in page
    for fr in d['frames']:
        assert os.path.isfile(str(tmp_path / 'rep' / fr['file']))
    assert any(fr.get('expectation') == 'screen_green' and fr['t'] == 1.5 for fr in d['frames'])
    # nothing from outside the folder
    assert not re.search(r'(src|href)="(https?:)?//', page)


def test_unwritable_report_folder_is_one_line(tmp_path):
    blocker = tmp_path / 'file'
    blocker.write_text('x')
    res, path, lines = _run(tmp_path, blocker / 'rep')
    assert path is None
    assert res.exit_code == 1 and res.status == 'FAIL'
    bad = [ln for ln in lines if ln.startswith('report: cannot write the report to ')]
    assert len(bad) == 1 and str(blocker / 'rep') in bad[0], lines


def test_farm_index(tmp_path):
    _run(tmp_path, tmp_path / 'farm' / 'synthetic')
    path = write_index(str(tmp_path / 'farm'), [
        dict(name='synthetic', status='FAIL', wall=3.0, report=str(tmp_path / 'farm' /
                                                                   'synthetic')),
        dict(name='broken', status='ERROR', wall=1.0, report=str(tmp_path / 'none'))], 4.0)
    page = open(path).read()
    assert '2 runs: 0 PASS, 1 FAIL, 1 ERROR; 2 of 4 expectations passed' in page
    assert '<a href="synthetic/index.html">synthetic</a>' in page
    assert '<td>7</td>' in page        # the seed, from the run's report


def test_helpers():
    assert numeric_value(True) == 1.0 and numeric_value('x') is None
    assert numeric_value([1, 2, 3]) == [1.0, 2.0, 3.0]
    assert band_of({'gt': 3}) == ('above', 3.0, None)
    assert band_of({'le': 3}) == ('below', None, 3.0)
    assert band_of({'between': [1, 2]}) == ('band', 1.0, 2.0)
    assert band_of({'equals': 'x'}) is None
    assert nice_ticks(0, 3, 6) == [0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
    pts = [(i * 0.001, float(i % 7)) for i in range(10000)]
    dec = decimate(pts, 400)
    assert len(dec) <= 400 and max(v for _t, v in dec) == 6.0 and min(v for _t, v in dec) == 0
    svg = svg_plot([('x', [(0, 1), (1, 2)])], (0, 1), (0.2, 0.8), ('above', 1.5, None),
                   (0.5, 1.5), 'FAIL')
    assert svg.count('class="band"') == 1 and 'FAIL t=0.500 s: 1.5' in svg


def test_invalid_scenario_file_report_and_its_index_row(tmp_path):
    lines = []
    path = write_invalid(str(tmp_path / 'farm' / 'typo'), str(tmp_path / 'typo.yaml'),
                         ["typo.yaml:3: timeline[0].action: unknown action 'mvoe_model'"],
                         lines.append)
    page = open(path).read()
    assert "unknown action &#x27;mvoe_model&#x27;" in page and 'status-ERROR' in page
    assert lines == ['report: %s' % path]
    index = open(write_index(str(tmp_path / 'farm'), [dict(
        name='typo', status='ERROR', wall=0.1, report=str(tmp_path / 'farm' / 'typo'))])).read()
    assert '<a href="typo/index.html">typo</a>' in index
    (tmp_path / 'blocker').write_text('a file, not a folder')
    assert write_invalid(str(tmp_path / 'blocker' / 'x'), 'typo.yaml', ['p'],
                         lines.append) is None
    assert lines[-1].startswith('report: cannot write the report to ')


def test_a_message_the_report_cannot_read_is_one_line(tmp_path):
    f = tmp_path / 's.yaml'
    f.write_text('duration: 1\nexpect:\n  - {name: v, topic: /v, field: data, '
                 'always: {gt: 0}}\n')
    sc = load(str(f))
    exps = [Expectation(e, sc.duration) for e in sc.expect]
    lines = []
    r = types.SimpleNamespace(sc=sc, expectations=exps, event_times={}, seed=0, rtf=0.0,
                              replay=None, t0=0.0, loop_wall=None, say=lines.append)
    c = Collector(r, str(tmp_path / 'rep'))

    class Weird(object):
        __slots__ = ('data',)

        def __getattribute__(self, name):
            raise RuntimeError('unreadable')
    c.feed(0.1, '/v', Weird())                 # no exception reaches the runner
    c.feed(0.2, '/v', Msg(3.0))
    exps[0].feed(0.2, Msg(3.0))
    assert c.write(Result('s', [exps[0].finish(1.0)])) is not None
    assert 'report: messages of /v could not be collected (RuntimeError: unreadable)' in lines
    assert json.load(open(str(tmp_path / 'rep' / 'report.json')))['plots']['v']['series'][0][1] \
        == [[0.2, 3.0]]
