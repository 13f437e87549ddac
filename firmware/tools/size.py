#!/usr/bin/env python3
"""Memory use of the 8051 image against the STC89C52RC, from SDCC's linker output.

usage: tools/size.py build/plotter [--stack N]

Reads build/plotter.map (segment sizes and addresses) and build/plotter.mem
(the linker's memory summary) and prints:
  code           HOME + GSINIT* + CSEG + CONST ... bytes of flash    (8 KB),
                 the free room up to the top address and counted from the
                 .ihx's data records (the gaps between the vectors hold nothing)
  internal RAM   register banks, bit and data segments (direct, 0x00-0x7F),
                 indirect data (ISEG) and the stack reserve           (256 B)
  XRAM           the on-chip expanded RAM (__pdata, __xdata)          (256 B)
Exits 1 if any of them is over the chip's limit, if the linker reported
an error, or if the image has initialised __xdata, which its start-up code
(hal/mcs51/startup.asm) does not copy: the build must not produce an image
that does not fit or does not start as written.

The stack grows up from the first free byte after the data; --stack N (40
by default) is the room it must have: the deepest call chain of the main
loop plus both interrupts measured in s51 (tests/test_firmware_sim.py) is
well below that.
"""
import re
import sys

CODE_LIMIT = 8192
IRAM_LIMIT = 256
XRAM_LIMIT = 256
STACK_RESERVE = 40


def parse_map(path):
    """{area: (start, size)} summed over the map's area table."""
    areas = {}
    for line in open(path):
        m = re.match(r"(\w+)\s+([0-9A-F]{8})\s+([0-9A-F]{8})\s+=\s+(\d+)\. bytes \(([^)]*)\)", line)
        if m:
            name, start, size = m.group(1), int(m.group(2), 16), int(m.group(4))
            attrs = m.group(5)
            prev = areas.get(name)
            if prev is None or size > prev[1]:
                areas[name] = (start, size, attrs)
    return areas


def parse_mem(path):
    text = open(path).read()
    info = {"errors": re.findall(r"^.*ERROR.*$", text, re.M)}
    m = re.search(r"Stack starts at: 0x([0-9a-fA-F]+)", text)
    info["stack_start"] = int(m.group(1), 16) if m else None
    m = re.search(r"ROM/EPROM/FLASH\s+0x([0-9a-fA-F]+)\s+0x([0-9a-fA-F]+)\s+(\d+)", text)
    info["code"] = int(m.group(3)) if m else None
    # __pdata (PAGED EXT. RAM) and __xdata (EXTERNAL RAM) share the chip's 256 bytes of XRAM.
    ends = [int(m.group(1), 16) + 1 for m in
            re.finditer(r"(?:PAGED EXT\. RAM|EXTERNAL RAM)\s+0x[0-9a-fA-F]+\s+0x([0-9a-fA-F]+)\s+\d+", text)]
    info["xram_end"] = max(ends, default=0)
    return info


def ihx_bytes(path):
    """The bytes the image's data records hold: what is written to flash,
    without the gaps between the interrupt vectors."""
    total = 0
    for line in open(path):
        line = line.strip()
        if line.startswith(":") and line[7:9] == "00":
            total += int(line[1:3], 16)
    return total


def main(argv):
    stack = STACK_RESERVE
    args = list(argv[1:])
    if "--stack" in args:
        k = args.index("--stack")
        stack = int(args[k + 1])
        del args[k:k + 2]
    if len(args) != 1:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    base = args[0]
    areas = parse_map(base + ".map")
    mem = parse_mem(base + ".mem")

    code = sum(size for start, size, attrs in areas.values() if "CODE" in attrs and "ABS" not in attrs)
    if mem["code"] is not None:
        code = mem["code"]           # the linker's figure, includes absolute areas
    direct_areas = ("REG_BANK_0", "REG_BANK_1", "REG_BANK_2", "REG_BANK_3", "BSEG_BYTES", "DSEG", "OSEG")
    direct_end = max((areas[a][0] + areas[a][1] for a in direct_areas if a in areas and areas[a][1]), default=0)
    iseg = areas.get("ISEG", (0, 0, ""))
    data_end = max(direct_end, iseg[0] + iseg[1])
    if mem["stack_start"] is not None:
        data_end = max(data_end, mem["stack_start"])
    banks = sum(areas[a][1] for a in direct_areas[:4] if a in areas)
    iram = data_end + stack
    xram = mem["xram_end"]

    rows = [
        ("code", code, CODE_LIMIT, f"bytes of flash ({CODE_LIMIT - code:+d} free; "
                                   f"{CODE_LIMIT - ihx_bytes(base + '.ihx')} counted from the .ihx's records)"),
        ("internal RAM", iram, IRAM_LIMIT,
         f"bytes: {banks} register banks + {data_end - banks} data up to 0x{data_end:02X} "
         f"(direct {direct_end}/128, ISEG {iseg[1]}) + {stack} stack reserve "
         f"({IRAM_LIMIT - data_end} free for the stack)"),
        ("XRAM", xram, XRAM_LIMIT, "bytes of on-chip expanded RAM"),
    ]
    over = False
    for name, used, limit, detail in rows:
        flag = "" if used <= limit else "   <-- OVER THE LIMIT"
        over |= used > limit
        print(f"{name:13s} {used:5d} / {limit:5d}  {detail}{flag}")
    for err in mem["errors"]:
        print("linker:", err.strip())
    xinit = areas.get("XINIT", (0, 0, ""))[1]
    if xinit:
        print(f"initialised __xdata ({xinit} bytes): hal/mcs51/startup.asm clears XRAM, it does not copy "
              f"initial values: give the variables their values in code", file=sys.stderr)
        return 1
    if over or mem["errors"]:
        print("the image does not fit the STC89C52RC", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
