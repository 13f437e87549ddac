#!/usr/bin/env python3
"""Bytes of 8051 code, from SDCC's listings.

usage: tools/codesize.py build/mcs51/planner.lst [N]
           bytes per C source line, biggest first
       tools/codesize.py --functions build/mcs51 [N]
           bytes per module and per label (functions, and the tables and
           strings placed under their own labels), from the relocated
           listings *.rst; biggest first
"""
import re
import sys
from pathlib import Path


def by_line(path, top=25):
    sizes, cur = {}, None
    for line in open(path):
        m = re.match(r"\s+\d+\s+;\s*(\S+\.c):(\d+):\s*(.*)", line)
        if m:
            cur = (int(m.group(2)), m.group(3)[:80])
            sizes.setdefault(cur, 0)
            continue
        m = re.match(r"\s+[0-9A-F]{6}\s+((?:[0-9A-F]{2}[rs* ]?)+)\s", line)
        if m and cur:
            sizes[cur] += len(re.findall(r"[0-9A-F]{2}", m.group(1)))
    print(f"{sum(sizes.values())} bytes attributed")
    for k in sorted(sizes, key=lambda k: -sizes[k])[:top]:
        print(f"{sizes[k]:6d}  {k[0]:4d}: {k[1]}")


def by_label(directory, top=25):
    """The bytes after each label up to the next one, in every module."""
    labels = []
    for rst in sorted(Path(directory).glob("*.rst")):
        cur = None
        sizes = {}
        for line in open(rst):
            m = re.match(r"\s+[0-9A-F]{6}\s+\d+\s+(_\w+):", line)
            if m:
                cur = m.group(1)
                sizes.setdefault(cur, 0)
                continue
            m = re.match(r"\s+[0-9A-F]{6}\s+((?:[0-9A-F]{2} )+)", line)
            if m and cur:
                sizes[cur] += len(m.group(1).split())
        labels += [(n, rst.stem, name) for name, n in sizes.items() if n]
    modules = {}
    for n, module, _ in labels:
        modules[module] = modules.get(module, 0) + n
    print(f"{sum(modules.values())} bytes under labels")
    for module, n in sorted(modules.items(), key=lambda kv: -kv[1]):
        print(f"{n:6d}  {module}")
    print()
    for n, module, name in sorted(labels, reverse=True)[:top]:
        print(f"{n:6d}  {module}: {name}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--functions":
        by_label(sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 25)
    elif len(sys.argv) > 1:
        by_line(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 25)
    else:
        sys.exit(__doc__)
