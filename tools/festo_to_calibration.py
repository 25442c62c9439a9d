#!/usr/bin/python3
"""Convert the real Festo fluidic-muscle force maps into peha calibration CSVs (docs/calibration.md).

Sources (read in place from the reference data directory, by default ../shared/data/pam beside the
checkout; never copied into the repository):

  festo_datasheet_*.csv   pressure_kPa, contraction, force_N             (Festo datasheet curves)
  martens2017_*.csv       pressure_Pa, length_m, contraction, force_N    (Martens & Boblan 2017)

The format is recognised from the header row, not the file name.

Output: `pressure_MPa,contraction,force_N`, the header first, and beside it the sidecar
OUT.csv.meta.json (docs/runtime.md#log-files) whose notes name the source file (and its SHA-256),
its own comments, the unit conversion and what was dropped. Static maps carry no time or motion, so
no t_s / angle_rad / wire_velocity_mps columns are written.

Excluded explicitly (and counted in a note):
  * force_N <= --min-force (default 0): the muscle cannot pull there;
  * pressure = 0: the Tendon-spring inverse P = F / g is undefined / degenerate there.

Usage:
  /usr/bin/python3 tools/festo_to_calibration.py SOURCE.csv OUT.csv [--min-force N]
  /usr/bin/python3 tools/festo_to_calibration.py --all [--data-dir ../shared/data/pam] --out-dir DIR

Exit codes: 0 success; 1 a source file is malformed (bad number, wrong field count);
2 missing file, unknown format, or usage error.
"""

import argparse
import glob
import hashlib
import json
import math
import os
import sys

try:
    import numpy as np
except ImportError:  # pragma: no cover - depends on the interpreter
    sys.stderr.write("festo_to_calibration.py: needs numpy; run it with /usr/bin/python3\n")
    sys.exit(2)

EXIT_OK = 0
EXIT_MALFORMED = 1
EXIT_USAGE = 2

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_DATA_DIR = os.path.normpath(os.path.join(HERE, "..", "..", "shared", "data", "pam"))
SOURCE_PATTERNS = ("festo_datasheet_*.csv", "martens2017_*.csv")
OUT_COLUMNS = ("pressure_MPa", "contraction", "force_N")
OUT_UNITS = {"pressure_MPa": "MPa", "contraction": None, "force_N": "N"}  # as peha's sidecars name them
SIDECAR_FORMAT = "peha-log-1"  # peha::config::kCsvSidecarFormat
READER_MIN_ROWS = 50  # peha::calibration::DatasetRules{}.min_rows

# header -> (format name, column holding pressure, factor to MPa, unit text)
FORMATS = {
    ("pressure_kPa", "contraction", "force_N"): ("festo_datasheet", "pressure_kPa", 1e-3, "kPa"),
    ("pressure_Pa", "length_m", "contraction", "force_N"): ("martens2017", "pressure_Pa", 1e-6, "Pa"),
}


class ConvertError(Exception):
    """A conversion failure with the exit code it maps to."""

    def __init__(self, message, code):
        super().__init__(message)
        self.code = code


def _known_formats():
    return "; ".join(",".join(h) for h in FORMATS)


def read_map(path):
    """Return (format, pressure column, factor, unit, comments, columns dict of numpy arrays, n_rows)."""
    if not os.path.isfile(path):
        raise ConvertError(f"{path}: no such file", EXIT_USAGE)
    comments = []
    header = None
    header_line = 0
    rows = []
    with open(path, "r", encoding="utf-8-sig") as fh:
        for line_no, raw in enumerate(fh, start=1):
            line = raw.strip()
            if not line:
                continue
            if line.startswith("#"):
                if header is None:
                    comments.append(line.lstrip("#").strip())
                continue
            fields = [f.strip() for f in line.split(",")]
            if header is None:
                header = tuple(fields)
                header_line = line_no
                if header not in FORMATS:
                    raise ConvertError(
                        f"{path}:{line_no}: unknown format: header '{line}'; expected one of: "
                        f"{_known_formats()}", EXIT_USAGE)
                continue
            if len(fields) != len(header):
                raise ConvertError(
                    f"{path}:{line_no}: expected {len(header)} fields (header line {header_line}), "
                    f"found {len(fields)}", EXIT_MALFORMED)
            values = []
            for name, text in zip(header, fields):
                try:
                    v = float(text)
                except ValueError:
                    raise ConvertError(f"{path}:{line_no}: column '{name}': not a number '{text}'",
                                       EXIT_MALFORMED) from None
                if not math.isfinite(v):
                    raise ConvertError(f"{path}:{line_no}: column '{name}': not finite '{text}'",
                                       EXIT_MALFORMED)
                values.append(v)
            rows.append(values)
    if header is None:
        raise ConvertError(f"{path}: unknown format: no header row; expected one of: {_known_formats()}",
                           EXIT_USAGE)
    if not rows:
        raise ConvertError(f"{path}: no data rows after the header on line {header_line}", EXIT_MALFORMED)
    fmt, p_col, factor, unit = FORMATS[header]
    data = np.array(rows, dtype=float)
    columns = {name: data[:, i] for i, name in enumerate(header)}
    return fmt, p_col, factor, unit, comments, columns, len(rows)


def _sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 16), b""):
            h.update(chunk)
    return h.hexdigest()


def sidecar_path(csv_path):
    return csv_path + ".meta.json"


def write_sidecar(csv_path, rows, notes):
    """The CSV's metadata in CSV_PATH.meta.json, as peha writes it: through a temporary renamed into place."""
    meta = {"format": SIDECAR_FORMAT, "file": os.path.basename(csv_path), "rows": rows,
            "columns": [{"name": c, "unit": OUT_UNITS[c]} for c in OUT_COLUMNS], "notes": notes}
    tmp = sidecar_path(csv_path) + ".tmp"
    with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        json.dump(meta, fh, indent=2, ensure_ascii=False)
        fh.write("\n")
    os.replace(tmp, sidecar_path(csv_path))


def convert(source, out, min_force=0.0):
    """Convert one map; return a dict with counts. Raises ConvertError."""
    if not math.isfinite(min_force) or min_force < 0:
        raise ConvertError(f"--min-force must be a finite number >= 0, got {min_force}", EXIT_USAGE)
    fmt, p_col, factor, unit, src_comments, cols, n_total = read_map(source)
    if os.path.exists(out) and os.path.samefile(source, out):
        raise ConvertError(f"{out}: refusing to overwrite the source map", EXIT_USAGE)

    pressure_MPa = cols[p_col] * factor
    contraction = cols["contraction"]
    force = cols["force_N"]
    no_pull = ~(force > min_force)
    zero_p = (force > min_force) & ~(pressure_MPa > 0.0)
    keep = ~no_pull & ~zero_p
    n_keep = int(keep.sum())
    if n_keep == 0:
        raise ConvertError(f"{source}: no rows left after excluding force_N <= {min_force:g} and pressure = 0",
                           EXIT_MALFORMED)

    lines = [
        f"peha calibration data converted by tools/festo_to_calibration.py from {os.path.abspath(source)}",
        f"source sha256 {_sha256(source)}; source format {fmt} ({', '.join(cols)})",
    ]
    lines += [f"source comment: {c}" for c in src_comments]
    lines.append(f"pressure converted {unit} -> MPa (x {factor:g}); gauge pressure")
    if "length_m" in cols:
        lines.append("dropped column length_m (contraction = (L0 - L) / L0 already carries it)")
    lines += [
        f"kept {n_keep} of {n_total} rows; excluded {int(no_pull.sum())} rows with force_N <= {min_force:g} "
        "(muscle cannot pull there) and "
        f"{int(zero_p.sum())} further rows with pressure = 0 "
        "(the Tendon-spring inverse P = F / g is undefined there)",
        "static force map: no time or motion, so no t_s, angle_rad or wire_velocity_mps columns",
        "contraction here is the muscle's own contraction u (no wire in a bench map); it is fine as eps "
        "for the fit: u = eps + eps0 + F/k, the wire terms (k, eps0) absorb nothing here "
        "(expect eps0 ~ 0 and k large, i.e. poorly determined)",
    ]

    out_dir = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(out_dir):
        raise ConvertError(f"{out}: output directory {out_dir} does not exist", EXIT_USAGE)
    tmp = out + ".tmp"
    with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(",".join(OUT_COLUMNS) + "\n")  # the header first: numpy, pandas open it as it is
        for p, e, f in zip(pressure_MPa[keep], contraction[keep], force[keep]):
            fh.write(f"{p:.9g},{e:.9g},{f:.9g}\n")
    # An old sidecar goes first, so a stop before the new one never pairs it with the new data.
    if os.path.exists(sidecar_path(out)):
        os.remove(sidecar_path(out))
    os.replace(tmp, out)
    write_sidecar(out, n_keep, lines)
    return {"source": source, "out": out, "format": fmt, "rows_in": n_total, "rows_out": n_keep,
            "dropped_force": int(no_pull.sum()), "dropped_zero_pressure": int(zero_p.sum()),
            "max_pressure_MPa": float(pressure_MPa[keep].max())}


def _report(info):
    print(f"{os.path.basename(info['source'])}: kept {info['rows_out']} of {info['rows_in']} rows "
          f"(excluded {info['dropped_force']} force<=min, {info['dropped_zero_pressure']} P=0) -> {info['out']}")
    if info["rows_out"] < READER_MIN_ROWS:
        sys.stderr.write(
            f"note: {info['out']} has {info['rows_out']} rows, fewer than read_dataset's default "
            f"min_rows {READER_MIN_ROWS}; read it with DatasetRules.min_rows <= {info['rows_out']}\n")


def main(argv=None):
    ap = argparse.ArgumentParser(
        description="Convert Festo force maps (festo_datasheet_*.csv, martens2017_*.csv) into peha "
                    "calibration CSVs (pressure_MPa,contraction,force_N). Points with force <= --min-force "
                    "and with zero pressure are excluded and counted in the notes of the output's sidecar OUT.csv.meta.json.",
        epilog="Exit codes: 0 ok, 1 malformed source, 2 missing file / unknown format / usage.")
    ap.add_argument("source", nargs="?", help="a force-map CSV (e.g. ../shared/data/pam/festo_datasheet_DMSP-40_digitized.csv)")
    ap.add_argument("out", nargs="?", help="the calibration CSV to write")
    ap.add_argument("--min-force", type=float, default=0.0, metavar="N",
                    help="exclude points with force_N <= N (default 0: the muscle cannot pull)")
    ap.add_argument("--all", action="store_true",
                    help="convert every map in --data-dir to OUT_DIR/<stem>_calibration.csv")
    ap.add_argument("--data-dir", default=DEFAULT_DATA_DIR,
                    help=f"where the maps are (with --all; default {DEFAULT_DATA_DIR})")
    ap.add_argument("--out-dir", help="output directory (with --all; created if missing)")
    args = ap.parse_args(argv)

    try:
        if args.all:
            if args.source or args.out:
                ap.error("--all takes no SOURCE/OUT; use --data-dir and --out-dir")
            if not args.out_dir:
                ap.error("--all needs --out-dir DIR")
            if not os.path.isdir(args.data_dir):
                raise ConvertError(f"{args.data_dir}: data directory does not exist", EXIT_USAGE)
            sources = sorted(p for pat in SOURCE_PATTERNS for p in glob.glob(os.path.join(args.data_dir, pat)))
            if not sources:
                raise ConvertError(f"{args.data_dir}: no force maps ({', '.join(SOURCE_PATTERNS)})", EXIT_USAGE)
            os.makedirs(args.out_dir, exist_ok=True)
            worst = EXIT_OK
            for src in sources:
                stem = os.path.splitext(os.path.basename(src))[0]
                try:
                    _report(convert(src, os.path.join(args.out_dir, f"{stem}_calibration.csv"), args.min_force))
                except ConvertError as e:
                    sys.stderr.write(f"error: {e}\n")
                    worst = max(worst, e.code)
            return worst
        if not args.source or not args.out:
            ap.error("give SOURCE.csv OUT.csv, or --all --out-dir DIR")
        _report(convert(args.source, args.out, args.min_force))
        return EXIT_OK
    except ConvertError as e:
        sys.stderr.write(f"error: {e}\n")
        return e.code
    except OSError as e:
        sys.stderr.write(f"error: {e}\n")
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
