#!/usr/bin/python3
"""Plot the per-cycle logs of a `peha run` (one column per experiment case).

Figure layout (in the spirit of Fig. 9 of Noda et al., IROS 2014):
one column per log file, four rows sharing the time axis:

  1. joint angle [deg] (measured, plus simulated plant angle thin/dashed),
     finger force [N] on a twin axis, finger-active intervals shaded grey,
     release instants annotated, fault samples shaded red;
  2. torques [Nm]: desired, PAM commanded, PAM measured (load cells), motor;
  3. PAM forces [N]: commanded and load-cell, agonist and antagonist, with the
     2000 N safety limit drawn when the data come within 50 % of it;
  4. pressures [MPa]: commanded and measured for both muscles, 0.8 MPa supply.

Must run on an interpreter with numpy + matplotlib (Debian: /usr/bin/python3).
Exit codes: 0 success, 1 malformed/unreadable log, 2 bad RUN_DIR or no logs
(and argparse usage errors).
"""

import argparse
import csv
import json
import math
import os
import re
import sys

SAFETY_LIMIT_N = 2000.0     # PAM force safety limit (line drawn when near)
NEAR_LIMIT_FRACTION = 0.5   # "near" = data reach 50 % of the limit
SUPPLY_MPA = 0.8            # supply line pressure
SUMMARY_NAME = "summary.csv"
DPI = 120

EXIT_OK = 0
EXIT_BAD_LOG = 1
EXIT_USAGE = 2

# (column, label, style kwargs) per panel
ANGLE_TRACES = [
    ("angle_rad", "angle (measured)", dict(color="C0", lw=1.6)),
    ("plant_angle_rad", "angle (plant)", dict(color="k", lw=0.9, ls="--")),
]
FINGER_FORCE = ("finger_force_N", "finger force", dict(color="C3", lw=1.0, alpha=0.8))
TORQUE_TRACES = [
    ("tau_desired_Nm", r"$\tau$ desired", dict(color="k", lw=1.4)),
    ("tau_pam_cmd_Nm", r"$\tau$ PAM cmd", dict(color="C0", lw=1.2, ls="--")),
    ("tau_pam_measured_Nm", r"$\tau$ PAM meas. (load cells)", dict(color="C0", lw=1.2)),
    ("tau_motor_cmd_Nm", r"$\tau$ motor", dict(color="C2", lw=1.2)),
]
FORCE_TRACES = [
    ("agonist_force_cmd_N", "agonist cmd", dict(color="C0", lw=1.2, ls="--")),
    ("agonist_loadcell_N", "agonist load cell", dict(color="C0", lw=1.2)),
    ("antagonist_force_cmd_N", "antagonist cmd", dict(color="C1", lw=1.2, ls="--")),
    ("antagonist_loadcell_N", "antagonist load cell", dict(color="C1", lw=1.2)),
]
PRESSURE_TRACES = [
    ("agonist_pressure_cmd_MPa", "agonist cmd", dict(color="C0", lw=1.2, ls="--")),
    ("agonist_pressure_MPa", "agonist meas.", dict(color="C0", lw=1.2)),
    ("antagonist_pressure_cmd_MPa", "antagonist cmd", dict(color="C1", lw=1.2, ls="--")),
    ("antagonist_pressure_MPa", "antagonist meas.", dict(color="C1", lw=1.2)),
]

CASE_RE = re.compile(r"^\s*#\s*case\s*:\s*(.*?)\s*$", re.IGNORECASE)
NOTE_CASE_RE = re.compile(r"^\s*case\s*:\s*(.*?)\s*$", re.IGNORECASE)


class LogError(Exception):
    """A log file cannot be read or is malformed (message names the file)."""


def warn(msg):
    print("plot_run.py: warning: " + msg, file=sys.stderr)


def natural_key(name):
    """Sort key that orders e1_payload_2.5kg before e1_payload_10.0kg."""
    return [int(p) if p.isdigit() else p.lower() for p in re.split(r"(\d+)", name)]


def find_logs(run_dir):
    names = [n for n in os.listdir(run_dir)
             if n.lower().endswith(".csv") and n.lower() != SUMMARY_NAME
             and os.path.isfile(os.path.join(run_dir, n))]
    return [os.path.join(run_dir, n) for n in sorted(names, key=natural_key)]


def _parse_float(text):
    text = text.strip()
    if text == "" or text.lower() in ("nan", "na", "none"):
        return math.nan
    return float(text)


def sidecar_case(path):
    """The 'case: TEXT' note of the log's sidecar PATH.meta.json (peha writes one beside every
    log); None without a sidecar or such a note. An unreadable sidecar is warned about, not fatal:
    the title is all it gives."""
    meta_path = path + ".meta.json"
    if not os.path.isfile(meta_path):
        return None
    try:
        with open(meta_path, encoding="utf-8") as fh:
            notes = json.load(fh).get("notes", [])
    except (OSError, UnicodeDecodeError, ValueError, AttributeError) as exc:
        warn("%s: ignored (%s)" % (meta_path, exc))
        return None
    for note in notes if isinstance(notes, list) else []:
        m = NOTE_CASE_RE.match(note) if isinstance(note, str) else None
        if m and m.group(1):
            return m.group(1)
    return None


def read_log(path):
    """Read one per-cycle log: the header first (older logs: after '#' lines), then rows.

    Returns dict(path, case, columns: {name: numpy array}). Raises LogError.
    """
    import numpy as np

    case = sidecar_case(path)
    header = None
    rows = []
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            lines = []
            for lineno, line in enumerate(fh, 1):
                if line.lstrip().startswith("#"):
                    m = CASE_RE.match(line)
                    if m and m.group(1) and case is None:
                        case = m.group(1)
                    continue
                if not line.strip():
                    continue
                lines.append((lineno, line))
    except (OSError, UnicodeDecodeError) as exc:
        raise LogError("%s: cannot read: %s" % (path, exc))

    if not lines:
        raise LogError("%s: malformed log: no header row" % path)
    try:
        parsed = list(csv.reader([l for _, l in lines]))
    except csv.Error as exc:
        raise LogError("%s: malformed CSV: %s" % (path, exc))

    header = [h.strip() for h in parsed[0]]
    if any(h == "" for h in header):
        raise LogError("%s line %d: malformed header (empty column name): %r"
                       % (path, lines[0][0], lines[0][1].rstrip()))
    try:
        [float(h) for h in header]
        raise LogError("%s line %d: header row expected, got numbers"
                       % (path, lines[0][0]))
    except ValueError:
        pass
    dupes = sorted({h for h in header if header.count(h) > 1})
    if dupes:
        warn("%s: duplicate column(s) %s; using the first occurrence"
             % (path, ", ".join(dupes)))
    if "t_s" not in header:
        raise LogError("%s: malformed log: no time column 't_s' in header %s"
                       % (path, header))

    ncol = len(header)
    for (lineno, _), fields in zip(lines[1:], parsed[1:]):
        # tolerate a trailing comma (one extra empty field)
        if len(fields) == ncol + 1 and fields[-1].strip() == "":
            fields = fields[:-1]
        if len(fields) != ncol:
            raise LogError("%s line %d: malformed row: %d fields, header has %d"
                           % (path, lineno, len(fields), ncol))
        try:
            rows.append([_parse_float(f) for f in fields])
        except ValueError:
            bad = next(i for i, f in enumerate(fields) if not _is_number(f))
            raise LogError("%s line %d: column '%s': not a number: %r"
                           % (path, lineno, header[bad], fields[bad]))
    if not rows:
        raise LogError("%s: malformed log: header but no data rows" % path)

    data = np.asarray(rows, dtype=float)
    columns = {}
    for i, name in enumerate(header):
        columns.setdefault(name, data[:, i])
    if not np.any(np.isfinite(columns["t_s"])):
        raise LogError("%s: malformed log: time column 't_s' has no finite values"
                       % path)
    return dict(path=path, case=case, columns=columns)


def _is_number(text):
    try:
        _parse_float(text)
        return True
    except ValueError:
        return False


def read_summary_cases(run_dir):
    """Map log file name -> case title from RUN_DIR/summary.csv, if usable.

    A summary row is matched to a log when one of its cells equals the log's
    file name or stem (e.g. a `file`/`log` column); its `case` cell is used.
    """
    path = os.path.join(run_dir, SUMMARY_NAME)
    if not os.path.isfile(path):
        return {}
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            lines = [l for l in fh if l.strip() and not l.lstrip().startswith("#")]
        reader = csv.DictReader(lines)
        if not reader.fieldnames or "case" not in [f.strip() for f in reader.fieldnames]:
            return {}
        mapping = {}
        for row in reader:
            row = {(k or "").strip(): (v or "").strip() if isinstance(v, str) else ""
                   for k, v in row.items()}
            case = row.get("case", "")
            if not case:
                continue
            for key, value in row.items():
                if key == "case" or not value:
                    continue
                base = os.path.basename(value)
                mapping.setdefault(base, case)
                mapping.setdefault(os.path.splitext(base)[0], case)
        return mapping
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        warn("%s: ignored (%s)" % (path, exc))
        return {}


def read_verdict_lines(run_dir):
    """Map case -> one line with the verdict's figures and thresholds from summary.csv (E1)."""
    path = os.path.join(run_dir, SUMMARY_NAME)
    if not os.path.isfile(path):
        return {}
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(l for l in fh if l.strip() and not l.startswith("#")))
    except (OSError, UnicodeDecodeError, csv.Error):
        return {}
    needed = ("static_torque_error_pct", "max_static_torque_error_pct", "drift_deg", "max_drift_deg",
              "min_wire_tension_N", "min_wire_tension_limit_N", "within_limits")
    by_case = {}
    for row in rows:
        if not all(k in row for k in needed):
            return {}
        by_case.setdefault(row["case"], []).append(row)
    lines = {}
    for case, rs in by_case.items():
        def worst(key):
            vals = [abs(float(r[key])) for r in rs if r[key] not in ("", "nan")]
            return max(vals) if vals else float("nan")
        r0 = rs[0]
        text = ("verdict %s: |tau err| %.1f %% (<= %s), |drift| %.3f deg (<= %s), T_min %.1f N (>= %s)"
                % ("OK" if r0["within_limits"] == "1" else "FAIL", worst("static_torque_error_pct"),
                   r0["max_static_torque_error_pct"], worst("drift_deg"), r0["max_drift_deg"],
                   float(r0["min_wire_tension_N"]), r0["min_wire_tension_limit_N"]))
        if r0.get("breakaway_static_error_pct", "nan") not in ("", "nan"):
            text += "\nbreakaway estimate %+.1f %% (truth %+.1f %%)" % (
                float(r0["breakaway_static_error_pct"]), float(r0["truth_static_error_at_probes_pct"]))
        lines[case] = text
    return lines


def case_title(log, summary_cases):
    if log["case"]:
        return log["case"]
    name = os.path.basename(log["path"])
    stem = os.path.splitext(name)[0]
    return summary_cases.get(name) or summary_cases.get(stem) or stem


def active_intervals(t, active):
    """[(t_start, t_end)] where active > 0.5; an interval ends at the first
    inactive sample (or the last sample if still active at the end)."""
    import numpy as np
    on = np.nan_to_num(active, nan=0.0) > 0.5
    out = []
    start = None
    for i in range(len(t)):
        if on[i] and start is None:
            start = t[i]
        elif not on[i] and start is not None:
            out.append((start, t[i]))
            start = None
    if start is not None:
        out.append((start, t[-1]))
    return out


def release_instants(t, active):
    """Times of the 1 -> 0 transitions of finger_active."""
    import numpy as np
    on = np.nan_to_num(active, nan=0.0) > 0.5
    idx = np.nonzero(on[:-1] & ~on[1:])[0] + 1
    return [(float(t[i]), int(i)) for i in idx]


def _plot_traces(ax, cols, t, traces, missing, scale=1.0):
    drawn = 0
    for name, label, style in traces:
        if name not in cols:
            missing.append(name)
            continue
        ax.plot(t, cols[name] * scale, label=label, **style)
        drawn += 1
    return drawn


def _no_data(ax, what):
    ax.text(0.5, 0.5, "no %s data" % what, transform=ax.transAxes,
            ha="center", va="center", color="0.5", fontsize=9)


def _legend(ax, handles=None, labels=None, **kw):
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return
    opts = dict(fontsize=7, framealpha=0.85, loc="best", ncol=2,
                handlelength=2.2, borderaxespad=0.3, columnspacing=1.0)
    opts.update(kw)
    ax.legend(handles, labels, **opts)


def plot_column(axes, log, title, draw_limit, ff_ylim):
    import numpy as np
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    # A column that is NaN throughout carries nothing to draw: over the multifunction board the
    # simulator's truth (plant_*, finger force) is unknown and logged as NaN. Leave such traces out
    # quietly rather than draw empty legend entries.
    unknown = [k for k, v in log["columns"].items() if k != "t_s" and np.all(np.isnan(v))]
    cols = {k: v for k, v in log["columns"].items() if k not in unknown}
    t = cols["t_s"]
    missing = []
    ax_ang, ax_tau, ax_f, ax_p = axes

    # --- finger-active shading, releases, faults (all rows) ---
    intervals, releases = [], []
    if "finger_active" in cols:
        intervals = active_intervals(t, cols["finger_active"])
        releases = release_instants(t, cols["finger_active"])
    else:
        missing.append("finger_active")
    for ax in axes:
        for a, b in intervals:
            ax.axvspan(a, b, color="0.85", alpha=0.6, lw=0, zorder=0)
        for tr, _ in releases:
            ax.axvline(tr, color="0.35", lw=0.8, ls=":", zorder=1)
    fault_intervals = []
    if "fault" in cols:
        fault_intervals = active_intervals(t, (np.nan_to_num(cols["fault"]) != 0) * 1.0)
        for a, b in fault_intervals:
            ax_ang.axvspan(a, b, color="red", alpha=0.15, lw=0, zorder=0)
    # 'fault' is optional: only runs with a safety supervisor log it, so its absence is not a warning.

    # --- row 1: angle + finger force ---
    n = _plot_traces(ax_ang, cols, t, ANGLE_TRACES, missing, scale=180.0 / math.pi)
    ax_ang.set_ylabel("joint angle [deg]")
    ax_ang.set_title(title, fontsize=10 if "\n" in title else 11, fontweight="bold")
    handles, labels = ax_ang.get_legend_handles_labels()
    ax_ff = ax_ang.twinx()
    fname, flabel, fstyle = FINGER_FORCE
    if fname in cols:
        ax_ff.plot(t, cols[fname], label=flabel + " [N]", **fstyle)
        ax_ff.set_ylabel("finger force [N]", color=fstyle["color"])
        ax_ff.tick_params(axis="y", colors=fstyle["color"])
        if ff_ylim is not None:
            ax_ff.set_ylim(*ff_ylim)
        h2, l2 = ax_ff.get_legend_handles_labels()
        handles += h2
        labels += l2
    else:
        missing.append(fname)
        ax_ff.set_yticks([])
    if intervals:
        handles.append(Patch(color="0.85", alpha=0.6))
        labels.append("finger active")
    if fault_intervals:
        handles.append(Patch(color="red", alpha=0.15))
        labels.append("fault")
    if n == 0:
        _no_data(ax_ang, "angle")
    elif "angle_rad" in cols:
        ang = cols["angle_rad"] * 180.0 / math.pi
        max_labels = 6
        for k, (tr, i) in enumerate(releases):
            if k >= max_labels:
                break
            y = ang[i] if np.isfinite(ang[i]) else np.nanmean(ang)
            ax_ang.annotate("release\n%.2f s" % tr, xy=(tr, y),
                            xytext=(-8, -26), textcoords="offset points",
                            ha="right", va="top", fontsize=7, color="0.2",
                            arrowprops=dict(arrowstyle="->", color="0.3", lw=0.8),
                            bbox=dict(boxstyle="round,pad=0.2", fc="white",
                                      ec="0.6", alpha=0.85))
        if len(releases) > max_labels:
            ax_ang.text(0.99, 0.02, "%d releases (first %d labelled)"
                        % (len(releases), max_labels), transform=ax_ang.transAxes,
                        ha="right", va="bottom", fontsize=7, color="0.3")
    # the twin axis is drawn above ax_ang: put the legend on it, in the
    # headroom reserved above the traces (see make_figure)
    _legend(ax_ff, handles, labels, loc="upper right", ncol=3)

    # --- row 2: torques ---
    if _plot_traces(ax_tau, cols, t, TORQUE_TRACES, missing) == 0:
        _no_data(ax_tau, "torque")
    ax_tau.axhline(0.0, color="0.6", lw=0.6, zorder=1)
    ax_tau.set_ylabel("torque [Nm]")
    _legend(ax_tau)

    # --- row 3: PAM forces ---
    if _plot_traces(ax_f, cols, t, FORCE_TRACES, missing) == 0:
        _no_data(ax_f, "PAM force")
    peak = _peak(cols, [c for c, _, _ in FORCE_TRACES])
    ax_f.set_ylabel("PAM force [N]")
    if draw_limit:
        ax_f.axhline(SAFETY_LIMIT_N, color="red", ls="--", lw=1.2,
                     label="safety limit %.0f N" % SAFETY_LIMIT_N)
        _legend(ax_f)
    else:
        handles, labels = ax_f.get_legend_handles_labels()
        handles.append(Line2D([], [], color="red", ls="--", lw=1.2))
        labels.append("safety limit %.0f N (off scale, peak %.0f N)"
                      % (SAFETY_LIMIT_N, peak))
        _legend(ax_f, handles, labels)

    # --- row 4: pressures ---
    if _plot_traces(ax_p, cols, t, PRESSURE_TRACES, missing) == 0:
        _no_data(ax_p, "pressure")
    ax_p.axhline(SUPPLY_MPA, color="0.3", ls="--", lw=1.0,
                 label="supply %.1f MPa" % SUPPLY_MPA)
    ax_p.set_ylabel("pressure [MPa]")
    ax_p.set_xlabel("time [s]")
    _legend(ax_p)

    for ax in axes:
        ax.grid(True, color="0.9", lw=0.6)
        ax.margins(x=0)

    for name in missing:
        if name not in unknown:
            warn("%s: column '%s' missing; trace skipped"
                 % (log["path"], name))


def _peak(cols, names):
    """max |value| over the given columns (0 if none present/finite)."""
    import numpy as np
    peak = 0.0
    for name in names:
        if name in cols and np.any(np.isfinite(cols[name])):
            peak = max(peak, float(np.nanmax(np.abs(cols[name]))))
    return peak


def _finite_range(arrays):
    import numpy as np
    lo, hi = math.inf, -math.inf
    for a in arrays:
        a = a[np.isfinite(a)]
        if a.size:
            lo, hi = min(lo, float(a.min())), max(hi, float(a.max()))
    return (lo, hi) if lo <= hi else None


def make_figure(logs, titles, suptitle):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ncols = len(logs)
    # rows share y across columns so the cases compare at a glance
    fig, axes = plt.subplots(4, ncols, sharex="col", sharey="row", squeeze=False,
                             figsize=(max(8.0, 7.0 * ncols), 11.0))

    # decisions common to all columns
    force_names = [c for c, _, _ in FORCE_TRACES]
    draw_limit = max(_peak(l["columns"], force_names) for l in logs) \
        >= NEAR_LIMIT_FRACTION * SAFETY_LIMIT_N
    ff = _finite_range([l["columns"][FINGER_FORCE[0]] for l in logs
                        if FINGER_FORCE[0] in l["columns"]])
    ff_ylim = None
    if ff is not None:
        # keep the finger force in the lower ~45 % so it does not hide the angle
        base = min(ff[0], 0.0)
        span = max(ff[1] - base, 1e-6)
        ff_ylim = (base - 0.05 * span, base + 2.2 * span)

    for j, log in enumerate(logs):
        plot_column(list(axes[:, j]), log, titles[j], draw_limit, ff_ylim)

    # angle row: reserve headroom above the traces for the legend
    ang = _finite_range([l["columns"][c] * 180.0 / math.pi for l in logs
                         for c, _, _ in ANGLE_TRACES if c in l["columns"]])
    if ang is not None:
        span = max(ang[1] - ang[0], 1e-3)
        axes[0, 0].set_ylim(ang[0] - 0.08 * span, ang[1] + 0.45 * span)
    if draw_limit:
        lo, hi = axes[2, 0].get_ylim()
        axes[2, 0].set_ylim(lo, max(hi, 1.05 * SAFETY_LIMIT_N))
    for ax in axes[:, 1:].ravel():
        ax.set_ylabel("")
    fig.suptitle(suptitle, fontsize=13)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    return fig


def build_parser():
    p = argparse.ArgumentParser(
        prog="plot_run.py",
        description=(
            "Plot the per-cycle CSV logs of a `peha run`: one column per log "
            "(RUN_DIR/*.csv except summary.csv, sorted by name), four rows "
            "sharing the time axis: (1) joint angle [deg] with finger force [N] "
            "on a twin axis, finger-active intervals shaded and releases "
            "annotated; (2) torques [Nm]: desired, PAM cmd, PAM measured, motor; "
            "(3) PAM forces [N]: cmd and load cell, agonist/antagonist, with the "
            "%.0f N safety limit drawn if the data come within 50%% of it; "
            "(4) pressures [MPa]: cmd and measured, %.1f MPa supply line."
            % (SAFETY_LIMIT_N, SUPPLY_MPA)),
        epilog=(
            "Logs: header row first (older logs: after '#' comment lines), time "
            "column t_s; a 'case: TEXT' note in the log's sidecar LOG.meta.json "
            "(older logs: a '# case: TEXT' comment) sets the column title (else a "
            "matching row of summary.csv's 'case' column, else the file stem). Unknown "
            "columns are ignored; missing expected columns are skipped with a "
            "warning. Exit status: 0 ok, 1 malformed log, 2 RUN_DIR missing or "
            "without logs. Needs numpy + matplotlib (use /usr/bin/python3)."),
    )
    p.add_argument("run_dir", metavar="RUN_DIR",
                   help="directory written by `peha run` holding *.csv logs")
    p.add_argument("--out", metavar="FILE.png", default=None,
                   help="output image (default: RUN_DIR/plot.png); parent "
                        "directories are created")
    p.add_argument("--title", metavar="TEXT", default=None,
                   help="figure title (default: 'peha run: <RUN_DIR name>')")
    return p


def main(argv=None):
    args = build_parser().parse_args(argv)
    run_dir = args.run_dir

    if not os.path.isdir(run_dir):
        print("plot_run.py: error: RUN_DIR '%s' does not exist or is not a "
              "directory" % run_dir, file=sys.stderr)
        return EXIT_USAGE
    paths = find_logs(run_dir)
    if not paths:
        print("plot_run.py: error: no logs (*.csv other than %s) in '%s'"
              % (SUMMARY_NAME, run_dir), file=sys.stderr)
        return EXIT_USAGE

    try:
        import numpy  # noqa: F401
        import matplotlib  # noqa: F401
    except ImportError as exc:
        print("plot_run.py: error: %s; run with an interpreter that has numpy "
              "and matplotlib (e.g. /usr/bin/python3)" % exc, file=sys.stderr)
        return EXIT_BAD_LOG

    try:
        logs = [read_log(p) for p in paths]
    except LogError as exc:
        print("plot_run.py: error: %s" % exc, file=sys.stderr)
        return EXIT_BAD_LOG

    summary_cases = read_summary_cases(run_dir)
    titles = [case_title(log, summary_cases) for log in logs]
    verdicts = read_verdict_lines(run_dir)
    for i, log in enumerate(logs):  # E1 logs are e1_<case>.csv
        stem = os.path.splitext(os.path.basename(log["path"]))[0]
        case = stem[3:] if stem.startswith("e1_") else stem
        if case in verdicts:
            titles[i] += "\n" + verdicts[case]
    suptitle = args.title if args.title is not None else (
        "peha run: " + os.path.basename(os.path.normpath(os.path.abspath(run_dir))))

    out = args.out or os.path.join(run_dir, "plot.png")
    out_parent = os.path.dirname(os.path.abspath(out))
    os.makedirs(out_parent, exist_ok=True)

    fig = make_figure(logs, titles, suptitle)
    try:
        fig.savefig(out, dpi=DPI)
    except (OSError, ValueError) as exc:
        print("plot_run.py: error: cannot write '%s': %s" % (out, exc),
              file=sys.stderr)
        return EXIT_BAD_LOG
    print(out)
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
