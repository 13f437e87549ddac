#!/usr/bin/env python3
"""Bytes of 8051 code per C source line, biggest first, from SDCC listings.

usage: tools/codesize.py build/mcs51/planner.lst [N]
"""
import re
import sys


def main(path, top=25):
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


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 25)
