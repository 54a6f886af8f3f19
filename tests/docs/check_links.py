#!/usr/bin/env python3
"""Checks every relative link of the documentation: README.md, CHANGELOG.md and docs/*.md.

Usage: python3 tests/docs/check_links.py [REPOSITORY_ROOT]   (default: the current directory)

A link [text](target) or an image ![alt](target) whose target is not a URL (http:, https:,
mailto:, ...) must name a file or directory that exists, relative to the file that holds the link;
a '#anchor' (alone, or after a Markdown file) must be the GitHub slug of a heading of that file:
the heading's text lowercased, inline markup removed, spaces turned into '-', and every character
that is not a letter, a digit, '-' or '_' dropped; repeated headings get -1, -2, ... Links inside
code blocks and inline code are ignored. Exit status 1, and one line per broken link naming
file:line, when anything is broken; 0 otherwise.
"""
import os
import re
import sys

LINK = re.compile(r'!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\)')
REFDEF = re.compile(r'^\s{0,3}\[[^\]]+\]:\s+<?(\S+?)>?(?:\s+"[^"]*")?\s*$')
SCHEME = re.compile(r'^[A-Za-z][A-Za-z0-9+.-]*:')


def strip_inline_code(line):
    return re.sub(r'(`+)(.+?)\1', '', line)


def slug(heading):
    text = heading.strip()
    text = re.sub(r'!?\[([^\]]*)\]\([^)]*\)', r'\1', text)  # links: their text
    text = re.sub(r'<[^>]+>', '', text)                       # inline HTML
    text = text.lower()
    text = re.sub(r'[^\w\- ]', '', text)                      # punctuation (keeps _ and -)
    return text.replace(' ', '-')


def headings_and_links(path):
    """(set of anchors, list of (line number, target)) of one Markdown file."""
    anchors, links, counts = set(), [], {}
    fence = None
    with open(path, encoding='utf-8') as f:
        for number, line in enumerate(f, 1):
            stripped = line.lstrip()
            marker = re.match(r'(`{3,}|~{3,})', stripped)
            if marker:
                if fence is None:
                    fence = marker.group(1)[0] * len(marker.group(1))
                elif stripped.startswith(fence):
                    fence = None
                continue
            if fence is not None:
                continue
            heading = re.match(r'^#{1,6}\s+(.*?)\s*#*\s*$', line)
            if heading:
                s = slug(heading.group(1))
                n = counts.get(s, 0)
                counts[s] = n + 1
                anchors.add(s if n == 0 else f'{s}-{n}')
            text = strip_inline_code(line)
            for m in LINK.finditer(text):
                links.append((number, m.group(1)))
            ref = REFDEF.match(text)
            if ref:
                links.append((number, ref.group(1)))
            for m in re.finditer(r'<a\s[^>]*(?:name|id)="([^"]+)"', line):
                anchors.add(m.group(1))
    return anchors, links


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else '.')
    files = [os.path.join(root, 'README.md'), os.path.join(root, 'CHANGELOG.md')]
    docs = os.path.join(root, 'docs')
    if os.path.isdir(docs):
        files += sorted(os.path.join(docs, n) for n in os.listdir(docs) if n.endswith('.md'))
    files = [f for f in files if os.path.exists(f)]
    if not files:
        print(f'check_links: no README.md, CHANGELOG.md or docs/*.md under {root}', file=sys.stderr)
        return 1
    cache = {}

    def parsed(path):
        if path not in cache:
            cache[path] = headings_and_links(path)
        return cache[path]

    broken = 0
    checked = 0
    for path in files:
        _, links = parsed(path)
        rel = os.path.relpath(path, root)
        for number, target in links:
            if SCHEME.match(target) or target.startswith('//'):
                continue  # a URL: not checked here
            checked += 1
            file_part, _, anchor = target.partition('#')
            dest = path if file_part == '' else os.path.normpath(os.path.join(os.path.dirname(path), file_part))
            problem = None
            if not os.path.exists(dest):
                problem = 'no such file'
            elif anchor:
                if os.path.isdir(dest) or not dest.endswith('.md'):
                    problem = 'an anchor into a file that is not Markdown'
                elif anchor not in parsed(dest)[0]:
                    problem = f"no heading with the anchor '#{anchor}'"
            if problem:
                broken += 1
                print(f'{rel}:{number}: broken link ({target}): {problem}')
    if broken:
        print(f'check_links: {broken} broken link(s) of {checked} relative links in {len(files)} files')
        return 1
    print(f'check_links: {checked} relative links in {len(files)} files, all resolve')
    return 0


if __name__ == '__main__':
    sys.exit(main())
