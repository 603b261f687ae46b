"""The units scripts/check-thread-safety analyses, read from CMake's compile_commands.json.

Usage: thread_safety_units.py COMPILE_COMMANDS JOBS_DIR TARGET...

Writes one clang response file per unit of the TARGETs into JOBS_DIR (NNN.rsp, the largest
first, so that two at a time end together): the flags the analysis needs of the unit's compile
command (the language, where headers are, the macros: not GCC's warnings, optimisation or
precompiled header), then the unit. A unity batch (Unity/unity_N_cxx.cxx) is a unit as listed:
it includes its target's sources by absolute path, so the headers they share are parsed once
and each diagnostic names the source it is in.
"""
import json
import os
import re
import shlex
import sys

KEEP_JOINED = ("-D", "-U", "-I", "-std=")
KEEP_SEPARATE = {"-isystem", "-iquote", "-idirafter", "-D", "-U", "-I"}


def analysis_flags(args):
    flags, i = [], 1
    while i < len(args):
        if args[i] in KEEP_SEPARATE and i + 1 < len(args):
            flags += args[i:i + 2]
            i += 2
            continue
        if args[i].startswith(KEEP_JOINED):
            flags.append(args[i])
        i += 1
    return flags


def main(commands, jobs, targets):
    units = []
    for entry in json.load(open(commands)):
        args = entry.get("arguments") or shlex.split(entry["command"])
        output = entry.get("output") or args[args.index("-o") + 1]
        target = re.search(r"CMakeFiles/([^/]+)\.dir/", output)
        if not target or target.group(1) not in targets:
            continue
        unit = os.path.join(entry["directory"], entry["file"])
        sources = [unit]
        if "/Unity/" in unit:
            sources = re.findall(r'^#include "([^"]+)"', open(unit).read(), re.M)
        units.append((sum(os.path.getsize(s) for s in sources), unit, analysis_flags(args)))
    if not units:
        sys.exit("check-thread-safety: %s names no source of %s" %
                 (commands, " ".join(sorted(targets))))
    for n, (_, unit, flags) in enumerate(sorted(units, reverse=True)):
        with open(os.path.join(jobs, "%03d.rsp" % n), "w") as out:
            out.write("\n".join(shlex.quote(a) for a in flags + [unit]) + "\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], set(sys.argv[3:]))
