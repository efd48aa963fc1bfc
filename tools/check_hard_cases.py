#!/usr/bin/env python3
"""Checks docs/hard-cases.md against the test suite: every numbered case names at least one
CPU test (label cpu) and one GPU test (label gpu), every test it names exists in the build with
that label, and there are at least 30 cases. Run by ctest as HardCases.Catalogue.

Usage: check_hard_cases.py DOC BUILD_DIR"""
import json
import re
import subprocess
import sys


def main():
    doc, build = sys.argv[1], sys.argv[2]
    listing = subprocess.run(["ctest", "--test-dir", build, "--show-only=json-v1"],
                             capture_output=True, text=True, check=True).stdout
    labels = {}
    for t in json.loads(listing)["tests"]:
        for p in t.get("properties", []):
            if p["name"] == "LABELS":
                labels[t["name"]] = set(p["value"])
    # ctest prints some parameterised names with a "  # GetParam() = ..." comment: the doc
    # drops it, so match on the name before it.
    by_short = {name.split("  #")[0]: lab for name, lab in labels.items()}
    cases, errors = re.split(r"^### ", open(doc).read(), flags=re.M)[1:], []
    numbered = 0
    for case in cases:
        title = case.splitlines()[0]
        if not re.match(r"\d+\. ", title):
            continue
        numbered += 1
        for side in ("cpu", "gpu"):
            m = re.search(r"^- \*\*%s tests:\*\* (.*)$" % side.upper(), case, flags=re.M)
            names = re.findall(r"`([^`]+)`", m.group(1)) if m else []
            if not names:
                errors.append("%s: no %s test" % (title, side.upper()))
            for n in names:
                if n not in by_short:
                    errors.append("%s: %s test %s does not exist" % (title, side.upper(), n))
                elif side not in by_short[n]:
                    errors.append("%s: %s is labelled %s, not %s" %
                                  (title, n, ",".join(sorted(by_short[n])), side))
    print("%d numbered cases, %d problems" % (numbered, len(errors)))
    for e in errors:
        print("  " + e)
    if numbered < 30:
        errors.append("fewer than 30 cases")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
