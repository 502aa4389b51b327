"""test/rostest/common.py's helpers that need no master: wait_connected names the counts
when the connections do not come (it once went on silently after 60 s, a minute of every
audio_device.test run spent waiting for a subscriber that never comes)."""
import os
import sys
import time
import types

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                'rostest'))
import common  # noqa: E402


def _end(name, counts):
    """A publisher or subscriber stand-in whose connection count follows ``counts``."""
    left = list(counts)

    def n():
        return left.pop(0) if len(left) > 1 else left[0]
    return types.SimpleNamespace(resolved_name=name, get_num_connections=n)


def test_wait_connected_returns_once_both_ends_are_connected():
    t0 = time.monotonic()
    common.wait_connected(_end('/spk', [0, 1]), _end('/mic', [0, 0, 1]), 1, timeout=10.0)
    assert time.monotonic() - t0 < 5.0


def test_wait_connected_names_what_is_missing_at_its_timeout():
    with pytest.raises(AssertionError) as e:
        common.wait_connected(_end('/spk', [1]), _end('/mic', [1]), 2, timeout=0.3)
    assert str(e.value) == ('/spk has 1 subscriber(s), not 2, and /mic 1 publisher(s) '
                            'after 0.3 s')
