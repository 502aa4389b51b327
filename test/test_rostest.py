"""Runs every rostest launch file in test/rostest/ with a real roscore.

Each .test file gets its own `rostest` process (Debian's rostest starts its own master
on a free port, so these never touch a user's roscore). A file passes only when rostest
exits 0 *and* its summary reports at least one test run with no errors or failures.
"""
import glob
import os
import re
import subprocess

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
TESTS = sorted(glob.glob(os.path.join(HERE, 'rostest', '*.test')))
TIMEOUT = int(os.environ.get('MDS_ROSTEST_TIMEOUT', '300'))


def _summary(text):
    m = re.search(r'\* RESULT: (\w+).*?\* TESTS: (\d+).*?\* ERRORS: (\d+).*?\* FAILURES: (\d+)',
                  text, re.S)
    if not m:
        return None
    return m.group(1), int(m.group(2)), int(m.group(3)), int(m.group(4))


@pytest.mark.rostest
@pytest.mark.parametrize('launch', TESTS, ids=[os.path.basename(t) for t in TESTS])
def test_rostest(launch):
    try:
        proc = subprocess.run(['rostest', '--text', launch], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, timeout=TIMEOUT, text=True)
    except subprocess.TimeoutExpired as e:
        pytest.fail('rostest %s timed out after %d s\n%s' % (launch, TIMEOUT, e.stdout or ''))
    out = proc.stdout
    summary = _summary(out)
    assert summary is not None, 'no rostest summary in output:\n' + out[-6000:]
    result, ntests, nerr, nfail = summary
    assert proc.returncode == 0 and result == 'SUCCESS' and nerr == 0 and nfail == 0, out[-8000:]
    assert ntests > 0, 'rostest ran no test:\n' + out[-4000:]
