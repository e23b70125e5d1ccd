"""Every document the sources cite exists, and every section they cite by title is in it (files and text only).

A citation is ``docs/<path>.md`` in the RTL, the model, the tools, the tests or the documents; a section is cited
as ``docs/<path>.md, "Title"`` or ``docs/<path>.md ("Title")``, and must be a heading of that document or the
lead of one of its bullets (``- Title.``).
"""

from __future__ import annotations

import re

from hdl_text import REPO

SOURCES = ("rtl", "model/fringe", "sim", "tb", "tests", "docs")
SUFFIXES = {".v", ".vh", ".vhd", ".sv", ".py", ".md"}
CITE = re.compile(r"(docs/[\w/.-]+?\.md)(?:,\s+\"([^\"]{2,80})\"|\s+\(\"([^\"]{2,80})\"\))?")
#: names this test and tests/test_block_names.py make up for planted cases
PLANTED = {"docs/blocks/fringe_new.md", "docs/blocks/fringe_good.md"}


def citations():
    for top in SOURCES:
        for path in sorted((REPO / top).rglob("*")):
            if path.suffix in SUFFIXES and path.is_file():
                text = re.sub(r"\s+", " ", path.read_text(encoding="utf-8", errors="replace"))
                for m in CITE.finditer(text):
                    yield path.relative_to(REPO), m.group(1), m.group(2) or m.group(3)


def titles(doc: str) -> set[str]:
    text = (REPO / doc).read_text(encoding="utf-8")
    heads = {h.strip() for h in re.findall(r"^#+\s+(.*)$", text, re.M)}
    leads = {b.strip() for b in re.findall(r"^\s*- ([^.:\n]{2,60})[.:]", text, re.M)}
    return heads | leads


def test_cited_documents_and_sections_exist():
    bad, n = [], 0
    for where, doc, section in citations():
        n += 1
        if doc in PLANTED:
            continue
        if not (REPO / doc).is_file():
            bad.append(f"{where}: {doc} does not exist")
        elif section and not any(t == section or t.startswith(section + " ") or t.startswith(section + " (")
                                 for t in titles(doc)):
            bad.append(f"{where}: {doc} has no section \"{section}\"")
    assert n > 100
    assert not bad, "\n".join(bad)
