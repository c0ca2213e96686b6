#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Checks the documentation: every relative link and image in the Markdown files resolves to a
file of the tree, and every page under docs/ is reachable from README.md's documentation index.
Usage: check_links.py ROOT"""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1]).resolve()
pages = [root / "README.md", root / "CHANGELOG.md", root / "examples" / "README.md"]
for pattern in ("docs/*.md", "tools/README.md", "src/README.md", "backends/*/README.md",
                "bindings/*/README.md", "tests/*/README.md"):
    pages += sorted(root.glob(pattern))
link = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
fence = re.compile(r"^\s*```")
bad = []
for page in pages:
    if not page.exists():
        continue
    inside = False
    for n, line in enumerate(page.read_text().splitlines(), 1):
        if fence.match(line):
            inside = not inside
        if inside:
            continue
        for target in link.findall(line):
            if re.match(r"^(https?:|mailto:|#)", target):
                continue
            path = (page.parent / target.split("#")[0]).resolve()
            if not path.exists():
                bad.append(f"{page.relative_to(root)}:{n}: broken link {target}")
readme = (root / "README.md").read_text()
for doc in sorted((root / "docs").glob("*.md")):
    if f"docs/{doc.name}" not in readme:
        bad.append(f"README.md: docs/{doc.name} is not in the documentation index")
for line in bad:
    print(line)
print(f"{len(pages)} pages checked, {len(bad)} problems")
sys.exit(1 if bad else 0)
