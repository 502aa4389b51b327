"""Every relative link of the documentation resolves (issue 45): README.md, docs/*.md and every
stack's README*.md (the pages test_readme_commands.py runs). A link to a file must name an
existing file or folder; a link with an anchor (``page.md#part`` or ``#part``) must name a
heading of that page (GitHub's slugs: lower case, punctuation dropped, spaces to hyphens,
``-1``, ``-2`` for repeats) or an ``id``/``name`` in its HTML. Links inside code are not
links. No roscore."""
import os
import re
import sys

import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from fixtures.readme_blocks import doc_pages  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
_LINK = re.compile(r'!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\)')
_REF = re.compile(r'^\s*\[[^\]]+\]:\s*(\S+)', re.M)
_HEADING = re.compile(r'^(#{1,6})\s+(.*?)\s*#*\s*$')
_FENCE = re.compile(r'^\s*(```|~~~)')


def _prose(text):
    """The page without fenced blocks and inline code spans."""
    out, fenced = [], False
    for line in text.split('\n'):
        if _FENCE.match(line):
            fenced = not fenced
            out.append('')
            continue
        out.append('' if fenced else re.sub(r'`[^`]*`', '', line))
    return '\n'.join(out)


def slug(heading):
    """GitHub's anchor of a heading."""
    text = re.sub(r'<[^>]+>', '', heading)
    text = re.sub(r'!?\[([^\]]*)\]\([^)]*\)', r'\1', text)     # links keep their text
    text = text.strip().lower().replace('`', '')
    text = re.sub(r'[^\w\- ]', '', text)
    return text.replace(' ', '-')


def anchors(path):
    with open(path, encoding='utf-8') as f:
        text = f.read()
    seen, found = {}, set()
    for line in _prose(text).split('\n'):
        m = _HEADING.match(line)
        if m:
            s = slug(m.group(2))
            n = seen.get(s, 0)
            seen[s] = n + 1
            found.add(s if n == 0 else '%s-%d' % (s, n))
    found.update(re.findall(r'<[^>]+\s(?:id|name)="([^"]+)"', text))
    return found


def links(path):
    with open(path, encoding='utf-8') as f:
        text = _prose(f.read())
    return _LINK.findall(text) + _REF.findall(text)


def broken_links(page):
    full = os.path.join(ROOT, page)
    bad = []
    for target in links(full):
        if re.match(r'^[a-z][a-z0-9+.-]*:', target, re.I):     # http:, https:, mailto: ...
            continue
        path, _, anchor = target.partition('#')
        dest = os.path.normpath(os.path.join(os.path.dirname(full), path)) if path else full
        if not os.path.exists(dest):
            bad.append('%s: no file %s' % (target, os.path.relpath(dest, ROOT)))
        elif anchor and dest.endswith('.md') and anchor not in anchors(dest):
            bad.append('%s: no heading #%s in %s' % (target, anchor, os.path.relpath(dest, ROOT)))
    return bad


@pytest.mark.parametrize('page', doc_pages(ROOT))
def test_readme_links_resolve(page):
    bad = broken_links(page)
    assert not bad, '%s has %d broken links:\n  %s' % (page, len(bad), '\n  '.join(bad))


def test_readme_link_checker_finds_what_is_broken(tmp_path, monkeypatch):
    (tmp_path / 'docs').mkdir()
    (tmp_path / 'docs' / 'a.md').write_text('# The world: and its API\n\n## Spawning\n\n## Spawning\n')
    (tmp_path / 'README.md').write_text(
        '[ok](docs/a.md) [ok](docs/a.md#the-world-and-its-api) [ok](docs/a.md#spawning-1)\n'
        '[bad](docs/b.md) [bad anchor](docs/a.md#nowhere) [here](#missing) [web](https://x.y)\n'
        '`[code](nowhere.md)`\n\n```\n[fenced](nowhere.md)\n```\n')
    monkeypatch.setattr(sys.modules[__name__], 'ROOT', str(tmp_path))
    assert broken_links('README.md') == [
        'docs/b.md: no file docs/b.md', 'docs/a.md#nowhere: no heading #nowhere in docs/a.md',
        '#missing: no heading #missing in README.md']
