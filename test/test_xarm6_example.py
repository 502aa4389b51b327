"""The robot example (issue 48 part 6), run once as a user runs it: pybullet_data's xarm6
under a position JointTrajectoryController (xarm6_world.launch: spawn_model, the YAML, the
spawner) holds the phone (attach) and a trajectory swings it over the office's QR code;
every expectation passes: the code is out of view first, joint1 reaches its goal
(joint_states by joint name), the phone its pose over the code (model_states by model
name), the held phone's camera sees the code and the app decodes it. It lives in
examples/robots/ because it takes a minute of wall time or more under load (the examples
farm test runs examples/*.yaml); its parsing is checked in test_joint_actions.
"""
import os

import pytest

from fixtures.scenario_cli import EX, run_scenario

pytestmark = pytest.mark.rostest


def test_xarm6_hands_the_phone_over_the_qr_code():
    pytest.importorskip('pybullet_data')
    rc, out = run_scenario(os.path.join(EX, 'robots', 'xarm6_qr.yaml'))
    assert rc == 0, out
    for name in ('code_not_in_view_while_away', 'arm_at_the_goal', 'phone_over_the_code',
                 'camera_sees_code', 'app_decodes'):
        assert 'PASS %s:' % name in out, out
