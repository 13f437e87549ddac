#!/usr/bin/env python3
"""Link the 8051 image with every call and jump as short as it can be.

usage: tools/relax.py --link "sdcc ... -Wl-u" --code-size 8192 -o build/plotter.ihx build/mcs51/a.rel ...

`lcall` and `ljmp` take three bytes; `acall` and `ajmp` take two and the
same two machine cycles, but reach only their own 2 KB page (the page of the
instruction after them).  Which page a target lands in is known only once
the image is linked, so, as a linker relaxing its branches would:

1. every `lcall` / `ljmp` in the code area (CSEG) of every module's
   assembly (build/mcs51/<module>.asm: SDCC's output, or the hand-written
   source the Makefile copies there) is written short, and the modules are
   assembled and linked;
2. in the relocated listings (*.rst) each short one whose target lies in
   another page is marked to stay long;
3. again from 1 with those long, until none is out of its page (marking
   only lengthens code, so this ends).

The vectors, the start-up areas and anything outside CSEG keep their long
forms, as do the entries of a jump table: their layout is fixed.  The image the linker writes at the end is
checked once more: it must report no page error.  An image over
--code-size is linked once more without the limit, to say by how much.
"""
import argparse
import re
import shlex
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import s51sim  # noqa: E402
import size  # noqa: E402

LONG = {"lcall": "acall", "ljmp": "ajmp"}
INSN = re.compile(r"^(\s*(?:[\w$]+:\s*)?)(lcall|ljmp)(\s+)([^;\s]+)(.*)$")
AREA = re.compile(r"^\s*\.area\s+(\w+)")
RST_LINE = re.compile(r"^\s+([0-9A-F]{6})\s((?:[0-9A-F]{2}[rs* ]?\s?)*)\s*(?:\[\s*\d+\])?\s+(\d+)\s(.*)$")
LABEL = re.compile(r"^\s*([A-Za-z_.$][\w.$]*|\d+\$)::?")


def candidates(text):
    """Line numbers (0-based) of the long calls and jumps in CSEG, but for
    the entries of a jump table: the run of `ljmp` after a label that is
    loaded into DPTR (SDCC's switch: `mov dptr,#table` ... `jmp @a+dptr`
    indexes it in steps of three bytes)."""
    lines = text.splitlines()
    tables = set(re.findall(r"\bmov\s+dptr\s*,\s*#\s*([\w$]+)", text, re.I))
    out, area, in_table = [], None, False
    for k, line in enumerate(lines):
        m = AREA.match(line)
        if m:
            area = m.group(1)
            continue
        code = line.split(";", 1)[0]
        lab = LABEL.match(code)
        if lab:
            in_table = lab.group(1) in tables
        ins = INSN.match(code)
        if in_table and not (ins and ins.group(2) == "ljmp") and code.strip() and not lab:
            in_table = False
        if area == "CSEG" and ins and not in_table:
            out.append(k)
    return out


def shorten(text, lines):
    """The text with the instructions on the given lines in their short form."""
    out = text.splitlines()
    for k in lines:
        code, sep, comment = out[k].partition(";")
        m = INSN.match(code)
        out[k] = m.group(1) + LONG[m.group(2)] + m.group(3) + m.group(4) + m.group(5) + sep + comment
    return "\n".join(out) + "\n"


def out_of_page(rst_path, globals_):
    """Source line numbers (1-based, the listing's) of the short calls and
    jumps whose target is in another 2 KB page than the next instruction;
    globals_: the image's addresses of other modules' symbols
    (s51sim.Symbols)."""
    labels, scope = {}, 0
    rows = []
    for line in open(rst_path):
        m = RST_LINE.match(line)
        if not m:
            continue
        addr, srcno, src = int(m.group(1), 16), int(m.group(3)), m.group(4)
        lab = LABEL.match(src)
        if lab and not src.lstrip().startswith("."):
            name = lab.group(1)
            if not name.endswith("$"):
                scope += 1            # sdas: n$ labels live between two ordinary labels
                labels[(None, name)] = addr
            else:
                labels[(scope, name)] = addr
        code = src.split(";", 1)[0]
        ins = re.search(r"\b(acall|ajmp)\s+([^\s;]+)", code)
        if ins:
            rows.append((addr, srcno, scope, ins.group(2)))
    bad = []
    for addr, srcno, scope, target in rows:
        if target.endswith("$"):
            t = labels[(scope, target)]
        elif (None, target) in labels:
            t = labels[(None, target)]
        else:
            t = globals_[target]
        if (addr + 2) & 0xF800 != t & 0xF800:
            bad.append(srcno)
    return bad


def main(argv):
    ap = argparse.ArgumentParser()
    ap.add_argument("--link", required=True, help="the SDCC link command, without the objects and -o")
    ap.add_argument("--code-size", type=int, required=True)
    ap.add_argument("-o", dest="out", required=True)
    ap.add_argument("rels", nargs="+")
    args = ap.parse_args(argv[1:])
    rels = [Path(r) for r in args.rels]
    sources = {r: r.with_suffix(".asm").read_text() for r in rels}
    cands = {r: candidates(t) for r, t in sources.items()}
    long_ = {r: set() for r in rels}
    for _ in range(50):
        for r in rels:
            short = [k for k in cands[r] if k not in long_[r]]
            work = r.with_suffix(".relax.asm")
            work.write_text(shorten(sources[r], short))
            subprocess.run(["sdas8051", "-plosgffw", str(r), str(work)], check=True)
        link = subprocess.run(shlex.split(args.link) + ["--code-size", "65536"] +
                              [str(r) for r in rels] + ["-o", args.out], capture_output=True, text=True)
        more = 0
        if Path(args.out).with_suffix(".map").exists():
            globals_ = s51sim.Symbols(Path(args.out).with_suffix(""))
            for r in rels:
                for srcno in out_of_page(r.with_suffix(".rst"), globals_):
                    k = srcno - 1
                    if k in cands[r] and k not in long_[r]:
                        long_[r].add(k)
                        more += 1
        if more:
            continue                  # the linker's page errors are those just marked
        sys.stdout.write(link.stdout)
        sys.stderr.write(link.stderr)
        if link.returncode or "2K Page" in link.stdout + link.stderr:
            sys.stderr.write("relax.py: the link failed\n")
            return link.returncode or 1
        used = size.parse_mem(str(Path(args.out).with_suffix(".mem")))["code"]
        if used > args.code_size:
            sys.stderr.write(f"relax.py: the code takes {used} bytes, {used - args.code_size} more "
                             f"than the {args.code_size} of flash\n")
            Path(args.out).unlink()
            return 1
        kept = sum(len(v) for v in long_.values())
        total = sum(len(v) for v in cands.values())
        print(f"relax.py: {total - kept} of {total} calls and jumps short")
        return 0
    sys.stderr.write("relax.py: no fixed point after 50 links\n")
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
