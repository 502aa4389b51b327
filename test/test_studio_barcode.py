"""The decoded barcode and the display's own image stream (sim_studio/barcode.py,
static/ext/barcode.js, the `display` stream) in Chromium on the shared studio: the phone put
over the office desk's QR paper (where testing_instance/examples/qr_code.yaml has it), the
runner's decoder's text appears under the camera view; in assert mode a click on it and
`add` make the runner's image expectation, which the validator accepts; the display view
shows its image topic's pixels, not textvid's blue. Assert mode is left off. The clicks are
forced (no wait for the element to keep still over animation frames: the page draws a frame
a second on a busy machine with its software WebGL, and the elements here do not move)."""
import json

import numpy as np
import pytest

from fixtures.studio import data_url, png_pixels, post

pytestmark = pytest.mark.rostest

URL = 'http://vmi.lmt.ei.tum.de'
CAMERA = '/mobile_device/image_raw'


@pytest.fixture(scope='module')
def page(shared_studio, shared_page):
    pg = shared_page
    post(shared_studio, json.dumps({'v': 1, 'op': 'play'}))
    # office.launch's spawn pose: over the QR paper on the desk (3.32, -2.10), camera down
    st, rep = post(shared_studio, json.dumps({'v': 1, 'op': 'set_pose', 'model': 'mobile_device',
                                              'position': [3.288, -2.11, 1.0],
                                              'rpy': [0, 0, 0]}))
    assert st == 200, rep
    yield pg
    if pg.evaluate('studio.asserting'):
        pg.get_by_test_id('assert').click(no_wait_after=True, force=True)


def test_the_decoded_barcode_is_shown_and_a_click_in_assert_mode_expects_it(page):
    code = page.locator('[data-testid=barcode-code][data-data="%s"]' % URL)
    code.wait_for(timeout=60000)
    page.get_by_test_id('assert').click(no_wait_after=True, force=True)
    code.click(no_wait_after=True, force=True)
    shown, hidden, what = page.evaluate(
        "[document.querySelector('[data-testid=barcode]').textContent, "
        "document.querySelector('[data-testid=barcode-form]').hidden, "
        "document.querySelector('[data-testid=barcode-form] .what').textContent]")
    assert shown.strip() == URL and not hidden and what == '%s barcode "%s"' % (CAMERA, URL)
    form = page.get_by_test_id('barcode-form')
    page.get_by_test_id('barcode-add').click(no_wait_after=True, force=True)
    entry = '{name: barcode, topic: %s, eventually: {barcode: "%s"}, window: [0, 1]}' \
        % (CAMERA, URL)
    page.wait_for_function("document.querySelector('[data-testid=scenario-yaml]').value"
                           ".includes(%s)" % json.dumps(entry), timeout=30000)
    assert form.is_hidden()
    rep = page.evaluate("studio.send({op: 'check', yaml: document.querySelector("
                        "'[data-testid=scenario-yaml]').value})")
    assert rep['ok'] and rep['problems'] == [], rep


def test_the_display_view_shows_its_image_topic(page):
    page.wait_for_function('studio.displayFrames > 0', timeout=30000)
    px = png_pixels(data_url(page, "document.querySelector('[data-testid=display-view]')"))
    blue = np.all(px == [0, 0, 255], axis=2)
    assert blue.mean() < 0.05, 'the display view is %.0f %% textvid blue' % (100 * blue.mean())
    assert px.std() > 10                 # the camera's picture of the paper, not one colour
