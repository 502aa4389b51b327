"""The robot example (issue 48 part 6), run once as a user runs it: pybullet_data's xarm6
holds the phone (attach) and swings it over the office's QR code (set_joints); every
expectation passes: the code is out of view first, the phone reaches its pose over the
code (model_states by model name), the held phone's camera sees the code and the app
decodes it. It lives in examples/robots/ because it takes about 30 s of wall time (the
examples farm test runs examples/*.yaml); its parsing is checked in test_joint_actions.
"""
import os

import pytest

from fixtures.scenario_cli import EX, run_scenario

pytestmark = pytest.mark.rostest


def test_xarm6_hands_the_phone_over_the_qr_code():
    pytest.importorskip('pybullet_data')
    rc, out = run_scenario(os.path.join(EX, 'robots', 'xarm6_qr.yaml'))
    assert rc == 0, out
    for name in ('code_not_in_view_while_away', 'phone_over_the_code', 'camera_sees_code',
                 'app_decodes'):
        assert 'PASS %s:' % name in out, out
