#!/usr/bin/env python3
"""The C ABI of include/imap.h as a table, and the check that a table is compatible with a
baseline (scripts/abi-check.sh runs both).

  abi_layout.py probe HEADER > probe.c     # C code printing the table when run
  abi_layout.py compare BASELINE CURRENT   # exit 1 on an incompatible change

The table: `struct NAME size`, `field NAME.FIELD offset size TYPE` (as the compiler lays it
out), `enum NAME.ITEM value`, `define NAME value`, `fn NAME(PROTOTYPE)`, `soname NAME`.

Compatible within an ABI epoch (same soname): every baseline function keeps its
prototype; every baseline field keeps its offset, size and type; a struct may only grow,
by fields appended past its old size; every enumerator and macro keeps its value. New
functions, structs, fields at the end, enumerators and macros are additions.
"""
import re
import sys


def strip_comments(text):
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def parse(header):
    code = strip_comments(open(header, encoding="utf-8").read())
    structs = []  # (name, [(field, type)])
    for m in re.finditer(r"typedef struct (\w+) \{(.*?)\} \1;", code, flags=re.S):
        fields = []
        for decl in m.group(2).split(";"):
            decl = " ".join(decl.split())
            if not decl:
                continue
            fm = re.match(r"(.*?)(\w+)(\[\d+\])?$", decl)
            ctype, field, array = fm.group(1).strip(), fm.group(2), fm.group(3) or ""
            fields.append((field, (ctype + array).strip()))
        structs.append((m.group(1), fields))
    enums = []
    for m in re.finditer(r"typedef enum (\w+) \{(.*?)\} \1;", code, flags=re.S):
        for item in m.group(2).split(","):
            item = item.strip()
            if item:
                enums.append((m.group(1), item.split("=")[0].strip()))
    defines = re.findall(r"^#define (IMAP_\w+) (\S+)", code, flags=re.M)
    fns = []
    for m in re.finditer(r"^([A-Za-z][^;#{}()]*?\b(imap_\w+)\(([^;]*?)\));", code, flags=re.M | re.S):
        fns.append((m.group(2), " ".join(m.group(1).split())))
    return structs, enums, defines, fns


def probe(header):
    structs, enums, defines, fns = parse(header)
    out = ['#include "imap.h"', "#include <stddef.h>", "#include <stdio.h>", "int main(void) {"]
    for name, fields in structs:
        out.append(f'    printf("struct {name} %zu\\n", sizeof({name}));')
        for field, ctype in fields:
            out.append(
                f'    printf("field {name}.{field} %zu %zu {ctype}\\n", offsetof({name}, {field}), sizeof((({name} *)0)->{field}));'
            )
    for name, item in enums:
        out.append(f'    printf("enum {name}.{item} %lld\\n", (long long){item});')
    for name, value in defines:
        out.append(f'    printf("define {name} %s\\n", "{value}");')
    for name, proto in fns:
        out.append(f'    printf("fn {name} %s\\n", "{proto}");')
        # The declaration must match the library's symbol: take its address.
        out.append(f"    (void)(void *)&{name};")
    out.append("    return 0;\n}")
    return "\n".join(out)


def load(path):
    rows = {}
    for line in open(path, encoding="utf-8"):
        line = line.rstrip("\n")
        if not line:
            continue
        kind, rest = line.split(" ", 1)
        key, _, value = rest.partition(" ")
        rows[(kind, key)] = value
    return rows


def returns_value_now(name, old, new):
    """Whether prototype `old` returned void and `new` is the same call returning a value."""
    if not old.startswith("void "):
        return False
    params = lambda p: p[p.index(name + "(") :]
    return not new.startswith("void ") and params(old) == params(new)


def compare(base_path, cur_path):
    base, cur = load(base_path), load(cur_path)
    problems, additions = [], []
    bs, cs = base.get(("soname", "libimap")), cur.get(("soname", "libimap"))
    if bs != cs:
        print(f"ABI epoch changed: soname {bs} -> {cs}. If this is on purpose (a new version), record the new baseline: scripts/abi-check.sh --update")
        return 1
    for key, value in base.items():
        kind, name = key
        if key not in cur:
            problems.append(f"{kind} {name} was removed")
            continue
        now = cur[key]
        if kind == "struct":
            if int(now) < int(value):
                problems.append(f"struct {name} shrank from {value} to {now} bytes")
        elif kind == "define" and name in ("IMAP_VERSION_PATCH", "IMAP_VERSION"):
            # The patch level moves within an epoch (the soname check above guards the
            # epoch); it is reported, not refused.
            if now != value:
                additions.append(f"{kind} {name}: '{value}' -> '{now}'")
        elif kind == "fn" and now != value and returns_value_now(name, value, now):
            # A function that returned nothing now returns a status: callers built
            # against the old header ignore the return register, so the call is the same.
            additions.append(f"{kind} {name} returns a value now: '{now}'")
        elif now != value:
            problems.append(f"{kind} {name}: '{value}' became '{now}'")
    for key, value in cur.items():
        if key in base:
            continue
        kind, name = key
        if kind == "field":
            struct = name.split(".")[0]
            old = base.get(("struct", struct))
            if old is not None and int(value.split()[0]) < int(old):
                problems.append(f"field {name} was inserted at offset {value.split()[0]}, inside the old {old}-byte struct {struct}")
                continue
        additions.append(f"{kind} {name}")
    for a in additions:
        print(f"addition: {a}")
    for p in problems:
        print(f"INCOMPATIBLE: {p}")
    return 1 if problems else 0


if __name__ == "__main__":
    if sys.argv[1] == "probe":
        print(probe(sys.argv[2]))
    elif sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    else:
        sys.exit(f"usage: {sys.argv[0]} probe HEADER | compare BASELINE CURRENT")
