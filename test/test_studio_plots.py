"""Plots picked by field and assert mode on a plot point and the LED (static/ext/plots.js) in
Chromium on the shared studio, with real clicks: the `+` of a device value puts that field
into the plot panel, whose canvas then holds a line in the field's colour; in assert mode a
click on the line opens the assert form with that field and the clicked point's value, and
`add` makes it an `expect` entry of the scenario YAML that the validator accepts; a click on
the LED adds one expectation per colour component; the field's remove button empties the
plot. Assert mode is left off."""
import json
import re

import numpy as np
import pytest

from fixtures.studio import data_url, png_pixels, post

pytestmark = pytest.mark.rostest

TOPIC, FIELD = '/mobile_device/imu_sensor_data', 'linear_acceleration.z'
PICK = '[data-testid=plot-pick][data-topic="%s"][data-field="%s"]' % (TOPIC, FIELD)


@pytest.fixture(scope='module')
def page(shared_studio, shared_page):
    pg = shared_page
    post(shared_studio, json.dumps({'v': 1, 'op': 'play'}))
    pg.wait_for_selector(PICK, state='attached', timeout=90000)
    yield pg
    if pg.evaluate('studio.asserting'):
        pg.get_by_test_id('assert').click(no_wait_after=True)


def _yaml(page):
    return page.get_by_test_id('scenario-yaml').input_value()


def test_a_picked_field_is_plotted_and_a_clicked_point_becomes_an_expectation(page):
    page.locator(PICK).click(no_wait_after=True)
    # the history starts at the pick (4 values a second): wait until the drawn points span
    # 30 px of the 30 s axis, so that a line, not a dot, is there to be seen
    page.wait_for_function(
        "(() => { const ps = studio.plots.points.filter((p) => p[2].field === %r); "
        "if (studio.plots.fields.length !== 1 || ps.length < 3) return false; "
        "const xs = ps.map((p) => p[0]); return Math.max(...xs) - Math.min(...xs) >= 30; })()"
        % FIELD, timeout=60000)
    legend = page.get_by_test_id('plot-legend').text_content()
    assert TOPIC + ' ' + FIELD in legend, legend
    color = page.evaluate('studio.plots.fields[0].color')           # '#rgb'
    rgb = np.array([int(c, 16) * 17 for c in color[1:]])
    px = png_pixels(data_url(page, "document.querySelector('[data-testid=field-plot]')"))
    line = np.all(np.abs(px - rgb) <= 12, axis=2)
    assert line.sum() >= 20, 'no line of %s in the plot (%d pixels)' % (color, line.sum())
    assert line.any(axis=0).sum() >= 10             # it spans the canvas, not a dot

    # assert mode: a real click on the line's latest point
    page.get_by_test_id('assert').click(no_wait_after=True)
    x, y, value = page.evaluate("(() => { const p = studio.plots.points.filter("
                                "(q) => q[2].field === %r).pop(); return [p[0], p[1], p[4]]; })()"
                                % FIELD)
    page.get_by_test_id('field-plot').click(position={'x': x, 'y': y}, no_wait_after=True)
    form = page.get_by_test_id('assert-form')
    assert form.is_visible()
    clicked = page.evaluate('studio.plots.clicked')
    assert clicked['topic'] == TOPIC and clicked['field'] == FIELD, clicked
    # the nearest point to the click: the one aimed at, or a neighbour drawn at the same place
    assert abs(clicked['value'] - value) <= 0.05 * abs(value) + 1e-9, (clicked, value)
    assert float(form.locator('input[name=a]').input_value()) == pytest.approx(clicked['value'])
    page.get_by_test_id('assert-add').click(no_wait_after=True)
    page.wait_for_function("document.querySelector('[data-testid=scenario-yaml]').value"
                           ".includes('field: %s')" % FIELD, timeout=30000)
    entry = [ln for ln in _yaml(page).splitlines() if 'field: %s' % FIELD in ln][-1]
    m = re.search(r'topic: %s, field: %s, eventually: \{near: ([-\de.]+), tol: ([-\de.]+)\}'
                  % (re.escape(TOPIC), re.escape(FIELD)), entry)
    assert m, entry
    assert abs(float(m.group(1)) - clicked['value']) <= 1e-6 * abs(clicked['value']) + 1e-9

    # the LED: one expectation per colour component, its current values
    led = page.evaluate("studio.device['/mobile_device/led/state']")
    assert led, 'the device stream has no LED state'
    comp = dict(led['fields'])
    page.get_by_test_id('out-led').click(no_wait_after=True)
    page.wait_for_function("document.querySelector('[data-testid=scenario-yaml]').value"
                           ".includes('name: led_b')", timeout=30000)
    yaml = _yaml(page)
    for k in 'rgb':
        m = re.search(r'name: led_%s, topic: /mobile_device/led/state, field: %s, '
                      r'eventually: \{near: ([-\de.]+), tol: 0.002\}' % (k, k), yaml)
        assert m, yaml
        assert abs(float(m.group(1)) - comp[k]) < 1e-6
    page.get_by_test_id('assert').click(no_wait_after=True)
    rep = page.evaluate("studio.send({op: 'check', yaml: document.querySelector("
                        "'[data-testid=scenario-yaml]').value})")
    assert rep['ok'] and rep['problems'] == [], rep

    # removed: the legend entry goes and nothing is drawn
    page.get_by_test_id('plot-remove').click(no_wait_after=True)
    page.wait_for_function('studio.plots.fields.length === 0 && '
                           'studio.plots.points.length === 0', timeout=10000)
    assert page.get_by_test_id('plot-legend').text_content().strip() == ''
