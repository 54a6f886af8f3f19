#!/usr/bin/env python3
"""The library's shape, checked: every stage under src/<stage>/ has its public headers under
include/ips/<stage>/ (and no header lives outside a stage), and includes only run downwards
through the layers below (docs/architecture.md draws them). A stage may use the stages of lower
layers, never one of a higher layer nor a sibling of its own layer; only the configuration's
assembly (config/) and the programs (apps/) include ips/config/config.h.

Usage: check_layers.py <source dir>. Prints every violation and exits 1 if there is one."""
import os
import re
import sys

# Lowest first. The pipeline, then the features built on it, then the simulator (it renders
# bodies and calibration boards), then the configuration that assembles them all.
LAYERS = [
    ["core"],
    ["capture"],
    ["geometry"],  # the lens and the marker-size formula: the detector refines edges through the lens
    ["detect"],
    ["mapping", "ranging"],  # camera -> world; positions from ranges
    ["fusion"],
    ["output"],
    ["body", "calib", "collect", "input", "insideout", "survey", "web"],  # input: network inputs of the daemon (ranges); insideout: a camera on a robot reading the ceiling
    ["sim"],
    ["config"],
]
RANK = {stage: rank for rank, stages in enumerate(LAYERS) for stage in stages}
INCLUDE = re.compile(r'^\s*#\s*include\s+"(?:ips/)?([a-z_0-9]+)/[^"]+"', re.M)


def main(root):
    problems = []
    src_stages = sorted(d for d in os.listdir(os.path.join(root, "src"))
                        if os.path.isdir(os.path.join(root, "src", d)))
    inc_root = os.path.join(root, "include", "ips")
    inc_stages = sorted(d for d in os.listdir(inc_root) if os.path.isdir(os.path.join(inc_root, d)))
    for f in os.listdir(inc_root):
        if os.path.isfile(os.path.join(inc_root, f)):
            problems.append(f"include/ips/{f}: a public header outside a stage folder")
    for stage in src_stages:
        if stage not in RANK:
            problems.append(f"src/{stage}/: a stage missing from the layers (tests/docs/check_layers.py)")
    for stage in inc_stages:
        if stage not in src_stages:
            problems.append(f"include/ips/{stage}/: no src/{stage}/ beside it")
    for top, stages in (("include/ips", inc_stages), ("src", src_stages)):
        for stage in stages:
            for dirpath, _, files in os.walk(os.path.join(root, top, stage)):
                for name in sorted(files):
                    if not name.endswith((".h", ".cpp")):
                        continue
                    path = os.path.join(dirpath, name)
                    rel = os.path.relpath(path, root)
                    text = open(path, encoding="utf-8").read()
                    for m in INCLUDE.finditer(text):
                        used = m.group(1)
                        line = text.count("\n", 0, m.start()) + 1
                        if used == stage or used not in RANK or stage not in RANK:
                            continue
                        if RANK[used] > RANK[stage]:
                            problems.append(f"{rel}:{line}: {stage} includes {used}, a higher layer")
                        elif RANK[used] == RANK[stage]:
                            problems.append(f"{rel}:{line}: {stage} includes {used}, a sibling of its layer")
                    if stage != "config" and re.search(r'#\s*include\s+"ips/config/config\.h"', text):
                        problems.append(f"{rel}: includes ips/config/config.h (only the assembly and the programs may)")
    for p in problems:
        print(p)
    print(f"{len(problems)} problem(s) in {len(src_stages)} stages")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "."))
