#!/usr/bin/python3
"""Layer (include-rule) checker for peha.

Every subfolder of include/peha/ and src/ is a layer. A file belongs to layer X if it lies
anywhere under include/peha/X/ or src/X/ (deeper subfolders included). An `#include "peha/Y/..."`
(or `<peha/Y/...>`) in a file of layer X is allowed only if Y == X or Y is in RULES[X]. A folder
that is not in RULES, a file directly in include/peha/ or src/, and an include of an unknown layer
are errors too.

Usage: check_layers.py [ROOT]      check the tree at ROOT (default: the parent of tools/)
       check_layers.py --print-rules
Exit code: 0 if clean, 1 on any violation, 2 on a usage error (e.g. ROOT has no include/peha or src).
Standard library only; runs on /usr/bin/python3.
"""

import argparse
import os
import re
import sys
from pathlib import Path

ALL = "*"  # may include every layer

# layer: (layers it may include besides itself, why)
RULES = {
    "config": (set(), "YAML reading and validation, atomic files, CSV sidecars: the foundation, depends on nothing of peha"),
    "models": ({"config"}, "physical models (muscles, tendons, joints): pure maths on configured parameters"),
    "calibration": ({"models", "config"}, "fits the parameters of the models from recorded data"),
    "control": ({"models", "io", "config"}, "controllers and allocation: from the models and the io value types (SensorState in, Command out); no runtime, no simulator"),
    "io": ({"config"}, "the hardware-agnostic backend interface and sensor/command types"),
    "safety": ({"io", "models", "config"}, "limits and monitors on io states, predicted with the models"),
    "sim": ({"io", "models", "config"}, "simulated plants behind the io backend interface"),
    "mfb": ({"io", "models", "config"}, "the MFB board protocol and its io backend"),
    "runtime": ({"io", "safety", "models", "config"}, "the real-time loop and telemetry: drives a backend under safety"),
    "hardware": ({"runtime", "mfb", "sim", "safety", "io", "models", "config"},
                 "the one hardware door: a backend chosen by URI (sim:, udp://, replay:), built in one place"),
    "experiments": ({"hardware", "runtime", "mfb", "sim", "safety", "io", "control", "calibration", "models", "config"},
                    "experiment procedures composed from every layer below the app"),
    "api": ({"experiments", "hardware", "runtime", "mfb", "sim", "safety", "io", "control", "calibration", "models", "config"},
            "the public API for a user's own controller (peha::api::Exoskeleton::control): every procedure's machinery around a callback"),
    "video": ({"sim", "io", "models", "config"},
              "offscreen MuJoCo rendering of a run's logs and ffmpeg encoding (peha run --video)"),
    "app": (ALL, "the command-line front end: wires everything together"),
}

SOURCE_SUFFIXES = {".h", ".hh", ".hpp", ".hxx", ".ipp", ".inl", ".tpp", ".c", ".cc", ".cpp", ".cxx"}
LAYER_ROOTS = (("include", "peha"), ("src",))

INCLUDE_RE = re.compile(r'^\s*#\s*include\s*([<"])([^">]+)[">]')


def describe_allowed(layer):
    deps = RULES[layer][0]
    if deps == ALL:
        return "everything"
    if not deps:
        return "nothing of peha"
    # Lowest layers last, in the order of the table.
    order = list(RULES)
    return ", ".join(sorted(deps, key=order.index, reverse=True))


def may_include(layer, target):
    deps = RULES[layer][0]
    return target == layer or deps == ALL or target in deps


def print_rules(out=sys.stdout):
    width = max(len(k) for k in RULES)
    for layer, (_, reason) in RULES.items():
        print(f"{layer:<{width}}  may include: {describe_allowed(layer)}", file=out)
        print(f"{'':<{width}}  why: {reason}", file=out)


def strip_block_comments(lines):
    """Yields (line_number, text) with // and /* ... */ comments removed, so a commented-out
    include is ignored. "..." literals are kept as they are (a "/*" in a string opens no comment)."""
    in_comment = False
    for number, line in enumerate(lines, start=1):
        out = []
        i, n = 0, len(line)
        while i < n:
            if in_comment:
                end = line.find("*/", i)
                if end < 0:
                    break
                in_comment = False
                i = end + 2
            elif line.startswith("//", i):
                break
            elif line.startswith("/*", i):
                in_comment = True
                out.append(" ")
                i += 2
            elif line[i] == '"':
                j = i + 1
                while j < n and line[j] != '"':
                    j += 2 if line[j] == "\\" else 1
                out.append(line[i:j + 1])
                i = j + 1
            else:
                out.append(line[i])
                i += 1
        yield number, "".join(out)


def layer_files(root):
    """Yields (path, layer_root, layer) for every source file under the layer roots."""
    for parts in LAYER_ROOTS:
        base = root.joinpath(*parts)
        if not base.is_dir():
            continue
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames.sort()
            for name in sorted(filenames):
                path = Path(dirpath) / name
                if path.suffix not in SOURCE_SUFFIXES:
                    continue
                rel = path.relative_to(base).parts
                yield path, base, (rel[0] if len(rel) > 1 else None)


def include_target_layer(root, path, spec, delimiter):
    """The layer an include refers to: the first folder after peha/, or for a relative quoted
    include that resolves into include/peha/ or src/, the layer there. None for non-peha includes.
    Returns (layer or '' for 'peha/<file>' without a layer folder, shown include)."""
    if spec.startswith("peha/"):
        parts = spec.split("/")
        return (parts[1] if len(parts) > 2 else ""), spec
    if delimiter == '"' and not spec.startswith("/"):
        resolved = (path.parent / spec).resolve()
        if resolved.is_file():
            for parts in LAYER_ROOTS:
                base = root.joinpath(*parts).resolve()
                try:
                    rel = resolved.relative_to(base).parts
                except ValueError:
                    continue
                shown = "peha/" + "/".join(rel)
                return (rel[0] if len(rel) > 1 else ""), shown
    return None, spec


# The board core (firmware/, freestanding C for a microcontroller, docs/porting.md) sits below every
# layer: it may include nothing of peha; the mfb layer includes it, not the other way round.
FIRMWARE_ROOT = "firmware"


def check_firmware(root, out):
    """Counts the peha includes in firmware/ (each one a violation) and the files checked."""
    base = root / FIRMWARE_ROOT
    violations = files = 0
    if not base.is_dir():
        return 0, 0
    for dirpath, dirnames, filenames in os.walk(base):
        dirnames.sort()
        for name in sorted(filenames):
            path = Path(dirpath) / name
            if path.suffix not in SOURCE_SUFFIXES:
                continue
            files += 1
            lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
            for number, text in strip_block_comments(lines):
                m = INCLUDE_RE.match(text)
                if not m:
                    continue
                target, shown = include_target_layer(root, path, m.group(2).strip(), m.group(1))
                if target is not None:
                    print(f"{path.relative_to(root).as_posix()}:{number}: firmware may include nothing of peha, "
                          f"found {shown} (the board core is freestanding C, docs/porting.md)", file=out)
                    violations += 1
    return violations, files


def check(root, out=sys.stdout):
    """Checks the tree at `root`; prints violations and a summary to `out`. Returns the exit code."""
    root = Path(root)
    if not root.joinpath("include", "peha").is_dir() and not root.joinpath("src").is_dir():
        print(f"check_layers: {root} has neither include/peha/ nor src/", file=out)
        return 2
    known = ", ".join(RULES)
    violations = 0
    files = 0
    includes = 0
    for path, base, layer in layer_files(root):
        files += 1
        shown_path = path.relative_to(root).as_posix()
        if layer is None:
            print(f"{shown_path}:1: file is in no layer (put it under a subfolder of "
                  f"{base.relative_to(root).as_posix()}/: {known})", file=out)
            violations += 1
            continue
        if layer not in RULES:
            print(f"{shown_path}:1: unknown layer {layer} (known layers: {known}; "
                  f"add it to RULES in tools/check_layers.py)", file=out)
            violations += 1
            continue
        try:
            lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
        except OSError as e:
            print(f"{shown_path}:1: cannot read: {e}", file=out)
            violations += 1
            continue
        for number, text in strip_block_comments(lines):
            m = INCLUDE_RE.match(text)
            if not m:
                continue
            target, shown = include_target_layer(root, path, m.group(2).strip(), m.group(1))
            if target is None:
                continue
            includes += 1
            if target == "":
                print(f"{shown_path}:{number}: layer {layer} includes {shown}, which is in no layer", file=out)
                violations += 1
            elif target not in RULES:
                print(f"{shown_path}:{number}: layer {layer} includes {shown} of unknown layer {target} "
                      f"(known layers: {known})", file=out)
                violations += 1
            elif not may_include(layer, target):
                print(f"{shown_path}:{number}: layer {layer} may not include {shown} "
                      f"({layer} may include: {describe_allowed(layer)})", file=out)
                violations += 1
    firmware_violations, firmware_files = check_firmware(root, out)
    violations += firmware_violations
    files += firmware_files
    if violations:
        print(f"check_layers: FAILED, {violations} violation(s); {files} files checked, "
              f"{includes} peha includes checked", file=out)
        return 1
    print(f"check_layers: OK, {files} files checked, {includes} peha includes checked", file=out)
    return 0


def main(argv=None):
    default_root = Path(__file__).resolve().parent.parent
    parser = argparse.ArgumentParser(description="Check which peha layer may include which.")
    parser.add_argument("root", nargs="?", default=str(default_root),
                        help="repository root (default: the parent of tools/)")
    parser.add_argument("--print-rules", action="store_true", help="print the rule table and exit")
    args = parser.parse_args(argv)
    if args.print_rules:
        print_rules()
        return 0
    return check(args.root)


if __name__ == "__main__":
    sys.exit(main())
