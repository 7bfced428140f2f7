#!/usr/bin/env python3
"""Writes a PNML net made of N independent copies of the mixer (examples/mixer/mixer.pnml),
copy k's ids and names suffixed _k, for the engine's scan benchmark: mixer_copies.py N OUT"""
import re
import sys

n, out = int(sys.argv[1]), sys.argv[2]
src = open("examples/mixer/mixer.pnml").read()
head, rest = src.split("<page id=\"page0\">", 1)
body, tail = rest.rsplit("</page>", 1)
copies = []
for k in range(n):
    b = re.sub(r'(id|source|target)="([^"]+)"', lambda m: f'{m.group(1)}="{m.group(2)}_{k}"', body)
    b = re.sub(r"<text>([A-Z][A-Z0-9]*)</text>", lambda m: f"<text>{m.group(1)}_{k}</text>", b)
    copies.append(b)
open(out, "w").write(head + '<page id="page0">' + "".join(copies) + "</page>" + tail)
