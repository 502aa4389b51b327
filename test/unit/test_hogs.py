"""test/fixtures/hogs.py: the CPU hogs run while inside and are gone after, an error inside
included; a missing stress-ng is one clear error."""
import os
import time

import pytest

from fixtures import hogs


def _workers(parent):
    """The pids whose parent is ``parent`` (stress-ng's --cpu workers)."""
    out = []
    for d in os.listdir('/proc'):
        if d.isdigit():
            try:
                with open('/proc/%s/stat' % d) as f:
                    if int(f.read().rsplit(')', 1)[1].split()[1]) == parent:
                        out.append(int(d))
            except (OSError, IndexError, ValueError):
                pass
    return out


def test_the_hogs_run_inside_and_are_gone_after():
    with pytest.raises(ZeroDivisionError):
        with hogs.cpu_hogs(2, settle=0.5) as p:
            assert p.poll() is None
            # stress-ng forks its workers after it starts: on a fresh clone's first run (a
            # cold page cache) that once took longer than the hogs' 0.5 s settle
            deadline = time.monotonic() + 10.0
            while len(_workers(p.pid)) < 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert len(_workers(p.pid)) == 2
            1 / 0
    assert p.poll() is not None and _workers(p.pid) == []


def test_a_missing_stress_ng_is_named(monkeypatch):
    monkeypatch.setattr(hogs.shutil, 'which', lambda name: None)
    with pytest.raises(hogs.StressMissing) as e:
        with hogs.cpu_hogs():
            pass
    assert str(e.value) == 'stress-ng is not installed (tools/setup installs it)'
