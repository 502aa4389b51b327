"""The doc test's reading of shell blocks (test/fixtures/readme_blocks.py): markers, expected
output, exit status, written files, console transcripts, continuations, what runs until
Ctrl-C and what starts a world of its own. No roscore."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from fixtures.readme_blocks import (doc_pages, leaves_the_shared_world_alone,  # noqa: E402
                                    shell_blocks, runs_until_interrupted, starts_a_world)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

PAGE = '''# A page

```sh
rosservice call /gazebo/reset_world
rostopic echo -n1 /barcode    # -> data: "QR-Code,http://x"
rosrun mobile_device_sim run_scenario a.yaml --junit out/a.xml \\
    --report out/r   # -> exit 1
# -> FAIL
# writes: out/extra.txt
some_server &
```

<!-- not-run: a screen -->
```bash
rosrun image_view image_view image:=/x
```

```python
print('not a shell block')
```

```console
$ echo hello
hello
$ echo '# -> inside quotes'
```
'''


def _blocks(tmp_path, text=PAGE):
    (tmp_path / 'README.md').write_text(text)
    return shell_blocks(str(tmp_path), 'README.md')


def test_blocks_markers_and_commands(tmp_path):
    blocks = _blocks(tmp_path)
    assert [(b.lang, b.line, b.not_run) for b in blocks] == [
        ('sh', 3, None), ('bash', 14, 'a screen'), ('console', 22, None)]
    cmds = blocks[0].commands
    assert [c.line for c in cmds] == [4, 5, 6, 10]
    assert cmds[1].expects == ['data: "QR-Code,http://x"']
    assert cmds[1].text == 'rostopic echo -n1 /barcode'
    run = cmds[2]
    assert run.text.startswith('rosrun mobile_device_sim run_scenario a.yaml --junit out/a.xml')
    assert '--report out/r' in run.text and '->' not in run.text
    assert run.exit == 1 and run.expects == ['FAIL']
    assert run.writes == ['out/a.xml', 'out/r/index.html', 'out/extra.txt']
    assert cmds[3].background and cmds[3].text == 'some_server'
    assert not cmds[0].background


def test_console_transcripts(tmp_path):
    console = _blocks(tmp_path)[2]
    assert [c.text for c in console.commands] == ['echo hello', "echo '# -> inside quotes'"]
    assert console.commands[0].expects == ['hello']
    assert console.commands[1].expects == []


def test_a_marker_must_be_right_before_the_fence(tmp_path):
    blocks = _blocks(tmp_path, '<!-- not-run: x -->\n\n```sh\nls\n```\n')
    assert blocks[0].not_run is None


def test_what_runs_until_ctrl_c():
    long = ['roslaunch mobile_device_sim office.launch', 'roscore', 'tools/demo',
            'tools/demo physics:=bullet', 'rostopic echo /barcode', 'rostopic hz /x',
            "rostopic pub -r 20 /joy sensor_msgs/Joy '{}'", 'rostopic pub /x std_msgs/Bool true',
            'rosrun mobile_device_sim barcode_reader image:=/x',
            'rosrun image_view image_view image:=/x']
    finite = ['tools/demo --exit', 'rostopic echo -n1 /barcode', 'rostopic echo -n 1 /x',
              'rostopic pub -1 /x std_msgs/Bool true', 'rosservice call /gazebo/reset_world',
              'rosrun mobile_device_sim spawn_model -file x -model y',
              'rosrun mobile_device_sim run_scenario a.yaml', 'pytest -n 2 a.yaml',
              'rosparam set robot_description "$(xacro f.xacro)"']
    assert [c for c in long if not runs_until_interrupted(c)] == []
    assert [c for c in finite if runs_until_interrupted(c)] == []


def test_what_starts_a_world_of_its_own():
    assert starts_a_world('roslaunch mobile_device_sim office.launch', ROOT)
    assert starts_a_world('tools/demo --exit', ROOT)
    assert starts_a_world('roscore')
    assert starts_a_world('rosrun mobile_device_sim sim_world x.world')
    assert starts_a_world('rosrun mobile_device_sim studio --port 0')
    assert not starts_a_world('rosrun mobile_device_sim studio --attach')
    assert not starts_a_world('roslaunch mobile_device_sim audio_device.launch', ROOT)
    assert not starts_a_world('rosrun mobile_device_sim barcode_reader', ROOT)
    assert not starts_a_world('rostopic echo /clock')


def test_what_leaves_the_shared_world_alone():
    """The doc test pauses its office world only for commands that cannot reach it."""
    alone = leaves_the_shared_world_alone
    assert alone('rosrun mobile_device_sim run_scenario testing_instance/examples/qr_code.yaml', ROOT)
    assert alone('rosrun mobile_device_sim replay_scenario out/qr.bag', ROOT)
    assert alone('pytest -n 2 testing_instance/examples/compass_sweep.yaml -k 90', ROOT)
    assert alone('roslaunch mobile_device_sim office.launch', ROOT)
    assert not alone('rosrun mobile_device_sim run_scenario x.yaml --attach', ROOT)
    assert not alone('rostopic echo -n1 /clock', ROOT)
    assert not alone('rosservice call /gazebo/reset_world', ROOT)
    assert not alone('rosrun mobile_device_sim studio --attach', ROOT)
    assert not alone('', ROOT)


def test_the_pages_are_found_anew():
    pages = doc_pages(ROOT)
    assert pages[0] == 'README.md'
    assert 'docs/consumers.md' in pages
    assert 'sim_world/README.md' in pages
    assert 'sim_world/src/sim_world/physics/README.md' in pages
    assert not any(p.startswith('build/') for p in pages)


def test_a_here_document_belongs_to_its_command(tmp_path):
    blocks = _blocks(tmp_path, "```sh\ncat > /tmp/x.urdf <<'URDF'\n<robot name=\"x\"/>\nURDF\n"
                               "rosrun mobile_device_sim spawn_model -file /tmp/x.urdf -model x\n```\n")
    cmds = blocks[0].commands
    assert [c.text.split('\n')[0] for c in cmds] == [
        "cat > /tmp/x.urdf <<'URDF'", 'rosrun mobile_device_sim spawn_model -file /tmp/x.urdf -model x']
    assert cmds[0].text.split('\n')[1:] == ['<robot name="x"/>', 'URDF']
