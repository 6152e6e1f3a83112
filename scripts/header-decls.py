#!/usr/bin/env python3
"""Prints a C header's declarations without comments, one per line, sorted: two headers
that print the same declare the same API, whatever their order or comments.

    scripts/header-decls.py include/imap.h > after.txt
"""
import re
import sys

text = open(sys.argv[1]).read()
text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
text = re.sub(r"//[^\n]*", "", text)
decls = []
depth = 0
current = ""
in_extern = False
for line in text.splitlines():
    s = line.strip()
    if not s:
        continue
    if s.startswith("#"):
        decls.append(s)
        continue
    # The body of `extern "C" { ... }` is a list of declarations: read them one by one.
    if s == 'extern "C" {':
        in_extern = True
        continue
    if s == "}" and depth == 0 and in_extern:
        in_extern = False
        continue
    current += " " + s
    depth += s.count("{") - s.count("}")
    if depth == 0 and (s.endswith(";") or s.endswith("}")):
        decls.append(re.sub(r"\s+", " ", current).strip())
        current = ""
for d in sorted(decls):
    print(d)
