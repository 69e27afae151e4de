#!/usr/bin/env bash
# Every link and image of README.md and the documents under docs/ resolves: a relative path names
# a file or folder of the package, and an anchor (#section) names a heading of the target document
# (GitHub's slugs). Links and images inside code spans and fenced code blocks are not links;
# http(s) and mailto links are not fetched (the tests run offline). Any argument is ignored (ctest
# passes the build folder).
set -u
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
exec /usr/bin/python3 - <<'PY'
import glob
import os
import re
import sys

FENCE = re.compile(r"^(```|~~~).*?^\1[^\n]*$", re.M | re.S)
CODE_SPAN = re.compile(r"(`+)(?:(?!\1).)+?\1", re.S)
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$", re.M)


def prose(text):
    """The text without fenced code blocks and code spans (their brackets are not links)."""
    return CODE_SPAN.sub("", FENCE.sub("", text))


def slugs(path):
    """GitHub's anchors for the headings of a markdown file, duplicates numbered -1, -2, ..."""
    seen, out = {}, set()
    with open(path, encoding="utf-8") as f:
        text = FENCE.sub("", f.read())
    for m in HEADING.finditer(text):
        title = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", m.group(2))  # a link's text only
        slug = re.sub(r"[^\w\- ]", "", title.lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        out.add(slug if n == 0 else "%s-%d" % (slug, n))
    return out


files = ["README.md"] + sorted(glob.glob("docs/**/*.md", recursive=True))
broken, checked = [], 0
for doc in files:
    with open(doc, encoding="utf-8") as f:
        text = prose(f.read())
    for m in LINK.finditer(text):
        target = m.group(1)
        if re.match(r"^(https?|mailto):", target):
            continue
        checked += 1
        path, _, anchor = target.partition("#")
        resolved = os.path.normpath(os.path.join(os.path.dirname(doc), path)) if path else doc
        if not os.path.exists(resolved):
            broken.append("%s: %s: no such file or folder %s" % (doc, target, resolved))
        elif anchor and resolved.endswith(".md") and anchor not in slugs(resolved):
            broken.append("%s: %s: %s has no heading with anchor #%s" % (doc, target, resolved, anchor))
print("doc links: %d files, %d local links checked, %d broken" % (len(files), checked, len(broken)))
for b in broken:
    print("BROKEN " + b)
# A checker that found no links at all would pass on anything.
sys.exit(1 if broken or checked == 0 else 0)
PY
