"""Results of a scenario run: the verdict set, exit codes, JUnit XML.

Pure (no ROS): used by the runner, replay and the farm (--jobs).
"""
import os
import re
import xml.etree.ElementTree as ET

EXIT_PASS, EXIT_FAIL, EXIT_ERROR = 0, 1, 2

__all__ = ['RunError', 'Result', 'write_junit', 'EXIT_PASS', 'EXIT_FAIL', 'EXIT_ERROR']


class RunError(Exception):
    """The scenario could not run (the verdict is ERROR, not FAIL)."""

    def __init__(self, text, log_lines=()):
        Exception.__init__(self, text)
        self.log_lines = list(log_lines)


class Result(object):
    def __init__(self, name, verdicts, error=None, log_lines=(), sim_time=0.0, wall=0.0):
        self.name = name
        self.verdicts = verdicts
        self.error = error
        self.log_lines = list(log_lines)
        self.sim_time = sim_time
        self.wall = wall

    @property
    def status(self):
        if self.error or any(v.error for v in self.verdicts):
            return 'ERROR'
        return 'PASS' if all(v.passed for v in self.verdicts) else 'FAIL'

    @property
    def exit_code(self):
        return {'PASS': EXIT_PASS, 'FAIL': EXIT_FAIL}.get(self.status, EXIT_ERROR)


# characters XML 1.0 cannot hold (log tails carry roslaunch's ANSI colour escapes)
_NOT_XML = re.compile('\x1b\\[[0-9;]*[A-Za-z]|[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]')


def xml_text(text):
    """text without terminal colour codes and the control characters XML cannot hold."""
    return _NOT_XML.sub('', text)


def write_junit(result, path, classname='scenario'):
    suite = ET.Element('testsuite', name=result.name, tests=str(max(1, len(result.verdicts))),
                       failures=str(sum(1 for v in result.verdicts
                                        if not v.passed and not v.error)),
                       errors=str(sum(1 for v in result.verdicts if v.error)
                                  + (1 if result.error else 0)),
                       time='%.3f' % result.wall)
    ET.SubElement(suite, 'properties')
    for v in result.verdicts:
        tc = ET.SubElement(suite, 'testcase', classname='%s.%s' % (classname, result.name),
                           name=v.name, time='0')
        if v.error:
            ET.SubElement(tc, 'error', message=xml_text(v.line())).text = xml_text(v.line())
        elif not v.passed:
            ET.SubElement(tc, 'failure', message=xml_text(v.line())).text = xml_text(v.line())
        ET.SubElement(tc, 'system-out').text = xml_text(v.line())
    if result.error:
        tc = ET.SubElement(suite, 'testcase', classname='%s.%s' % (classname, result.name),
                           name='run')
        text = result.error + ('\n' + '\n'.join(result.log_lines) if result.log_lines else '')
        ET.SubElement(tc, 'error', message=xml_text(result.error)).text = xml_text(text)
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    ET.ElementTree(suite).write(path, encoding='utf-8', xml_declaration=True)
