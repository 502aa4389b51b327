"""The studio's scenario editor in Chromium (static/ext/editor.js, sim_studio.editor), on the
shared studio and page (fixtures/studio.py): open a file, type into CodeMirror with the
real keyboard, the validator's problem marked on its line, Ctrl-Z and Ctrl-Y, save (also
invalid YAML, exactly as typed) and open again with the comments kept; the textarea
(scenario-yaml) holds the whole text all along."""
import os

import pytest

from fixtures.studio import png_pixels

pytestmark = pytest.mark.skipif(not os.path.isdir('/usr/share/javascript/codemirror'),
                                reason="Debian's libjs-codemirror is missing (tools/setup)")

SCENARIO = """\
# a scenario the editor test opens (this comment must survive a save)
name: editor_test
description: opened in the studio
real_time_factor: 0
duration: 2.0
world:
  launch: office
timeline:
  - {id: a1, at: 0.5, action: set_model_state, model: mobile_device,
     position: [3.3, -2.1, 1.0]}
expect: []
"""
YAML = "document.querySelector('[data-testid=scenario-yaml]').value"


def value(page):
    return page.get_by_test_id('scenario-yaml').input_value()


def settled(page, marks):
    """Wait until the editor's latest check is of its current text, with ``marks`` (the
    lines marked); returns the marks as the page shows them."""
    page.wait_for_function(
        '(want) => { const e = studio.editor; return e.checked === %s && '
        'JSON.stringify(e.marks.map((m) => m.line)) === JSON.stringify(want); }' % YAML,
        arg=marks, timeout=60000)
    return page.evaluate("[...document.querySelectorAll('[data-testid=editor-problem]')]"
                         ".map((e) => [Number(e.dataset.line), e.title])")


def test_type_see_the_mark_undo_save_and_reopen(shared_studio, shared_page):
    page = shared_page
    page.wait_for_function('window.studio.editor && window.studio.editor.ready',
                           timeout=30000)
    assert page.locator('.CodeMirror').count() == 1
    path = shared_studio['dir'] / 'editor_test.yaml'
    path.write_text(SCENARIO)

    page.get_by_test_id('scenario-path').fill(str(path))
    page.get_by_test_id('scenario-open').click()
    page.wait_for_function('(t) => %s === t' % YAML, arg=SCENARIO, timeout=60000)
    assert settled(page, []) == []
    assert 'opened ' + str(path) in page.get_by_test_id('scenario-file-status').text_content()

    # the real keyboard in CodeMirror: the duration's value typed over with -1 (line 5)
    line = SCENARIO.splitlines().index('duration: 2.0') + 1
    page.locator('.CodeMirror-line', has_text='duration: 2.0').click()
    page.keyboard.press('End')
    for _ in range(3):
        page.keyboard.press('Shift+ArrowLeft')
    page.keyboard.type('-1')
    assert value(page) == SCENARIO.replace('duration: 2.0', 'duration: -1')
    # the duration's own line, and the action that now lies after the end (line 9)
    at = SCENARIO.splitlines().index('  - {id: a1, at: 0.5, action: set_model_state, '
                                     'model: mobile_device,') + 1
    marks = settled(page, [line, at])
    assert marks[0][0] == line and 'scenario.duration' in marks[0][1], marks
    assert marks[1][0] == at and 'timeline[0].at' in marks[1][1], marks
    row = page.locator('.CodeMirror-code > div').nth(line - 1)
    assert row.locator('.CodeMirror-line').text_content() == 'duration: -1'
    assert row.locator('.ed-error-line').count() == 1
    mark = row.locator('[data-testid=editor-problem]')
    box = mark.bounding_box()                             # drawn, and red
    assert box and box['width'] > 2 and box['height'] > 2, box
    px = png_pixels(page.screenshot(clip=box, animations='disabled', timeout=60000))
    assert ((px[..., 0] > 180) & (px[..., 1] < 120)).sum() >= 4
    assert 'duration' in page.get_by_test_id('problems').text_content()   # studio.js's check

    # Ctrl-Z: CodeMirror joins keys typed within 1.25 s into one change, so on a busy
    # machine '-' and '1' may be two
    for _ in range(3):
        page.keyboard.press('Control+z')
        if value(page) == SCENARIO:
            break
    assert value(page) == SCENARIO
    assert settled(page, []) == []
    page.keyboard.press('Control+y')
    assert value(page) != SCENARIO and 'duration: -' in value(page)
    page.get_by_test_id('editor-undo').click()
    assert value(page) == SCENARIO

    # a comment typed at the end, saved, the editor emptied, the file opened again
    page.keyboard.press('Control+End')
    page.keyboard.type('# typed in the studio\n')
    typed = SCENARIO + '# typed in the studio\n'
    assert value(page) == typed
    page.keyboard.press('Control+s')
    page.wait_for_function("document.querySelector('[data-testid=scenario-file-status]')"
                           ".textContent.startsWith('saved ')", timeout=60000)
    assert path.read_text() == typed
    page.evaluate("studio.editor.setValue('')")
    page.get_by_test_id('scenario-open').click()
    page.wait_for_function('(t) => %s === t' % YAML, arg=typed, timeout=60000)
    assert '# a scenario the editor test opens' in value(page)

    # invalid YAML is saved exactly as typed, its problem marked
    page.locator('.CodeMirror-line', has_text='# typed in the studio').click()
    page.keyboard.press('Control+End')
    page.keyboard.type('timeline: [unclosed')
    page.get_by_test_id('scenario-save').click()
    page.wait_for_function("document.querySelector('[data-testid=scenario-file-status]')"
                           ".textContent.includes('problem')", timeout=60000)
    assert path.read_text() == typed + 'timeline: [unclosed'
    assert settled(page, [len(typed.splitlines()) + 1])
    assert [f for f in os.listdir(str(path.parent)) if f.endswith('.tmp')] == []

    # a bad path: one error on the page, the text kept
    page.get_by_test_id('scenario-path').fill(str(path.parent / 'no' / 'such.yaml'))
    page.get_by_test_id('scenario-save').click()
    page.wait_for_function("document.querySelector('[data-testid=scenario-file-status]')"
                           ".textContent.includes('no such folder')", timeout=60000)
    assert value(page).endswith('timeline: [unclosed')
    page.screenshot(path=str(shared_studio['dir'] / 'studio_editor.png'))
    assert page.errors == [] and page.outside == []
