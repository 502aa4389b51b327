"""The live images panel (sim_studio/images.py, static/ext/images.js) in Chromium on the
shared studio (its world runs without the flycam: flycam:=false): the list holds the
master's image topics; the phone camera's topic picked with the mouse streams its images
into the panel, drawn as a picture with detail (not one colour); a topic that is not an
image topic is one error and the page keeps its stream."""
import json

import numpy as np
import pytest

from fixtures.studio import data_url, png_pixels, post

pytestmark = pytest.mark.rostest

CAMERA = '/mobile_device/image_raw'

DRAWN = """(() => { const i = document.querySelector('[data-testid=image-view]');
  if (!i.naturalWidth) return null;
  const c = document.createElement('canvas');
  c.width = i.naturalWidth; c.height = i.naturalHeight;
  c.getContext('2d').drawImage(i, 0, 0);
  return c; })()"""


def test_a_picked_topic_streams_into_the_panel(shared_studio, shared_page):
    page = shared_page
    post(shared_studio, json.dumps({'v': 1, 'op': 'play'}))
    select = page.get_by_test_id('image-topic')
    page.wait_for_function("[...document.querySelectorAll('[data-testid=image-topic] option')]"
                           ".some(o => o.value === %r)" % CAMERA, timeout=90000)
    options = select.evaluate("s => [...s.options].map(o => o.value)")
    assert '/flycam/image_raw' not in options and CAMERA in options
    select.select_option(CAMERA)
    page.wait_for_function("studio.images.topic === %r && studio.images.frames > 0" % CAMERA,
                           timeout=60000)
    frames = page.evaluate('studio.images.frames')
    px = png_pixels(data_url(page, DRAWN))
    assert px.shape[0] > 20 and px.shape[1] > 20
    assert px.reshape(-1, 3).std(axis=0).max() > 10, 'one colour: no picture'
    assert page.get_by_test_id('image-stamp').inner_text().endswith(' s')
    # a topic that is not an image topic: one error, the stream goes on
    _status, rep = post(shared_studio, json.dumps({'v': 1, 'op': 'watch_image',
                                                   'topic': '/clock'}))
    assert not rep['ok'] and '/clock is not an image topic' in rep['error'], rep
    rep = page.evaluate("studio.send({op: 'watch_image', topic: '/clock'})")
    assert not rep['ok'] and '/clock' in rep['error']
    page.wait_for_function('studio.images.frames > %d' % frames, timeout=60000)
    assert page.evaluate('studio.images.topic') == CAMERA
    select.select_option(index=0)              # (none): the stream stops
    page.wait_for_function('studio.images.topic === null', timeout=30000)
