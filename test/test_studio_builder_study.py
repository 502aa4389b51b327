"""The studio's device builder (static/ext/builder.js, sim_studio.builder) and study mode
(static/ext/study.js, sim_studio.study) in Chromium, on the shared studio and page
(fixtures/studio.py).

Builder: the form of the phone's plugins is loaded; a bad value typed into a field is named
at that field by the plugin's own check and nothing is written; a good value is saved, and
the file is spawned into the shared world by the project's own spawn_model (-urdf -file, in
a robot namespace of its own) as a second phone whose IMU then publishes at the new rate
(its stamps, sim time, 0.05 s apart instead of 0.01), then deleted again.

Study: two tasks typed in, a session for a person; in the first task a pose is set with the
pose form, a step without a sim time is refused (an error), the pose is undone with the
study's undo (an undo), then the task is done; the second task is given up. The CSV downloaded with the page's
link has one row per task with the right result, success, error and undo counts."""
import csv
import io
import subprocess

import pytest

T = 120000        # ms: generous for a loaded machine (nothing here measures speed)


def _run(studio, args, timeout=180):
    return subprocess.run(args, env=studio['env'], stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, universal_newlines=True, timeout=timeout)


def _stamps(text):
    """Seconds of each 'secs: / nsecs:' pair rostopic echo printed."""
    out, secs = [], None
    for ln in text.splitlines():
        k, _, v = ln.partition(':')
        if k.strip() == 'secs':
            secs = int(v)
        elif k.strip() == 'nsecs' and secs is not None:
            out.append(secs + int(v) * 1e-9)
            secs = None
    return out


def saved(page, click):
    """Click save and wait for its reply."""
    n = page.evaluate('studio.builder.saves || 0')
    click()
    try:
        page.wait_for_function('(n) => studio.builder.saves === n + 1', arg=n, polling=250,
                               timeout=T)
    except Exception:
        print('builder:', page.evaluate('[studio.builder.saves, studio.builder.lastSave, '
                                        'document.querySelector("[data-testid=status]")'
                                        '.textContent]'))
        raise


def test_build_a_phone_bad_value_named_good_one_spawned(shared_studio, shared_page):
    page, d = shared_page, shared_studio['dir']
    page.get_by_test_id('builder-load').click()
    page.wait_for_function("document.querySelectorAll('[data-testid=builder-form] details')"
                           ".length >= 20", polling=250, timeout=T)
    imu = page.locator('[data-testid=builder-form] details[data-group="imu_controller"]')
    imu.locator('summary').click()
    field = imu.locator('input[data-key="imu_controller/updateRate"]')
    assert field.input_value() == '100.0'          # the phone's description's value
    # a bad value, typed: named at its field in the world's words; nothing written
    field.fill('')
    field.press_sequentially('-5')
    bad = d / 'phone_bad.urdf'
    page.get_by_test_id('builder-path').fill(str(bad))
    saved(page, lambda: page.get_by_test_id('builder-save').click())
    err = imu.locator('[data-testid=builder-error][data-key="imu_controller/updateRate"]')
    assert err.is_visible() and err.text_content() == (
        "plugin libgazebo_ros_imu.so of model mobile_device: "
        "updateRate must be a number >= 0, got '-5'")
    assert page.evaluate("[...document.querySelectorAll('[data-testid=builder-error]')]"
                         ".filter((e) => e.textContent).length") == 1
    assert 'nothing written' in page.get_by_test_id('builder-status').text_content()
    assert not bad.exists()
    page.get_by_test_id('builder').scroll_into_view_if_needed()
    page.screenshot(path=str(d / 'builder_bad_value.png'))
    # a good value: written, and the project's spawn_model loads it as another phone
    field.fill('')
    field.press_sequentially('20')
    good = d / 'phone_imu20.urdf'
    page.get_by_test_id('builder-path').fill(str(good))
    saved(page, lambda: page.get_by_test_id('builder-save').click())
    assert page.get_by_test_id('builder-status').text_content().startswith(
        'written %s (1 changed)' % good)
    assert err.text_content() == '' and good.exists()
    spawn = _run(shared_studio, ['rosrun', 'mobile_device_sim', 'spawn_model', '-urdf', '-file',
                                 str(good), '-model', 'phone2', '-robot_namespace', '/phone2',
                                 '-x', '4.2', '-y', '-3.5', '-z', '1.0'])
    try:
        assert spawn.returncode == 0, spawn.stdout
        echo = _run(shared_studio, ['rostopic', 'echo', '-n', '4',
                                    '/phone2/imu_sensor_data/header/stamp'])
        t = _stamps(echo.stdout)
        assert len(t) == 4, echo.stdout
        assert [round(b - a, 6) for a, b in zip(t, t[1:])] == [0.05] * 3, t
    finally:
        gone = _run(shared_studio, ['rosservice', 'call', '/gazebo/delete_model',
                                    '{model_name: phone2}'])
        assert 'success: True' in gone.stdout, gone.stdout


def test_study_two_tasks_exported_as_csv(shared_studio, shared_page):
    page = shared_page
    q = page.get_by_test_id
    q('study-tasks-text').fill('put the phone on the desk\nturn it face down')
    q('study-set-tasks').click()
    q('study-person').fill('P1')
    q('study-start').click()
    # the page sends its commands in order on one WebSocket and the studio carries out a
    # client's commands one after another: no waiting between the clicks
    q('study-task-start').click()
    q('set-pose').click()          # set_pose of the selected model where it is: an action
    page.fill('#until', '')
    q('step').click()                                      # no sim time: refused, an error
    q('study-undo').click()                                # the phone back: an undo
    q('study-task-finish').click()
    q('study-task-start').click()
    q('study-task-give-up').click()
    page.fill('#until', '1')
    q('study-end').click()
    page.wait_for_function("studio.study.state && studio.study.state.sessions.length && "
                           "!studio.study.state.running", polling=250, timeout=T)
    assert 'P1: success 1 err 1 undo, gave up' in q('study-sessions').text_content()
    with page.expect_download(timeout=T) as dl:
        q('study-csv').click()
    text = open(dl.value.path()).read()
    rows = [r for r in csv.DictReader(io.StringIO(text)) if r['person'] == 'P1']
    assert [(r['task_name'], r['result'], r['success'], r['errors'], r['undos'])
            for r in rows] == [('put the phone on the desk', 'success', '1', '1', '1'),
                               ('turn it face down', 'gave_up', '0', '0', '0')], text
    assert int(rows[0]['actions']) >= 3 and float(rows[0]['time_on_task_s']) > 0
    assert float(rows[0]['sim_time_on_task_s']) >= 0
    page.get_by_test_id('study').scroll_into_view_if_needed()
    page.screenshot(path=str(shared_studio['dir'] / 'study.png'))


@pytest.fixture(autouse=True)
def _page(shared_page):
    shared_page.set_default_timeout(T)
    yield
    shared_page.set_default_timeout(30000)          # Playwright's default, for the others
    assert not [e for e in shared_page.errors if 'builder' in e or 'study' in e]
