#!/usr/bin/python3
"""The figures the docs quote, regenerated from the commands that make them.

A figures block in README.md or docs/*.md is the text between two HTML comments (invisible once
rendered):

    <!-- figures: run="peha run --config configs/e5_max_force.yaml --no-plot" show="csv:summary.csv"
         table="case={case} | peak N={peak_force_N:.1f}" -->
    | case | peak N |
    ...
    <!-- /figures -->

The opening comment says how the block is made:
  run     the command (as a doc would show it; `peha` is the built binary). It runs in the scratch
          folder of tools/check_doc_commands.py, after the doc's own commands.
  show    `stdout`: the command's standard output, lines from the first matching `from` (a regex)
          up to, not including, the first later line matching `to` (default: to the end), in a
          ```text fence;
          `csv:FILE`: a Markdown table, one row per row of FILE in the run folder the command made
          (out/latest), the columns from `table`: `Header={field:format} | ...`, Python format
          fields over the CSV's columns (numbers as floats), `where` optionally `column=value`;
          `file:FILE`: FILE of that run folder as it is (a Markdown table a command writes),
          optionally only its lines from `from` up to `to`, as for stdout.
  mask    optional regex: what it matches is not compared (wall-clock figures such as the
          real-time factor); the block keeps the values of its last regeneration.
  long    optional: the block's command is too long for `make test` (`long="make robustness"`
          says what runs it): checked only with --long.
  exit    optional: the command's exit code when it is the documented outcome (default 0; e.g. 3,
          a matrix that reports a goal missed).

A block is current when its text equals what the command makes now, masks aside (the simulator is
deterministic for a seed, so figures are compared exactly). `check_doc_commands.py` (ctest
docs.commands) fails on a block that is not; `--update-figures` rewrites every block in place.

Standard library only; runs on /usr/bin/python3.
"""

import csv
import io
import re
import string
from dataclasses import dataclass, field
from pathlib import Path

OPEN_RE = re.compile(r"^<!-- figures:(.*)$")
CLOSE = "<!-- /figures -->"
ATTR_RE = re.compile(r'(\w+)="((?:[^"\\]|\\.)*)"')
KEYS = {"run", "show", "from", "to", "table", "where", "mask", "long", "exit"}


@dataclass
class Block:
    path: str                 # the doc, relative to the root
    line: int                 # line of the opening comment, 1-based
    attrs: dict
    body_start: int           # index (0-based) of the first body line
    body_end: int             # index of the closing comment
    body: list = field(default_factory=list)

    def where(self):
        return f"{self.path}:{self.line}"

    @property
    def command(self):
        return " ".join(self.attrs["run"].split())


def parse_blocks(root, rel):
    """The figures blocks of one Markdown file; ValueError names file:line for a malformed one."""
    lines = (Path(root) / rel).read_text().splitlines()
    blocks = []
    i = 0
    while i < len(lines):
        m = OPEN_RE.match(lines[i].strip())
        if not m:
            if lines[i].strip() == CLOSE:
                raise ValueError(f"{rel}:{i + 1}: {CLOSE} without an opening figures comment")
            i += 1
            continue
        start = i
        header = m.group(1)
        while "-->" not in header:  # the opening comment may span lines
            i += 1
            if i >= len(lines):
                raise ValueError(f"{rel}:{start + 1}: figures comment not closed with -->")
            header += " " + lines[i].strip()
        header = header[:header.index("-->")]
        attrs = {k: v.replace('\\"', '"') for k, v in ATTR_RE.findall(header)}
        unknown = set(attrs) - KEYS
        if unknown:
            raise ValueError(f"{rel}:{start + 1}: unknown figures attribute(s) {sorted(unknown)}; "
                             f"known: {sorted(KEYS)}")
        if "run" not in attrs or "show" not in attrs:
            raise ValueError(f"{rel}:{start + 1}: a figures block needs run=\"...\" and show=\"...\"")
        if not re.fullmatch(r"stdout|csv:\S+|file:\S+", attrs["show"]):
            raise ValueError(f"{rel}:{start + 1}: show must be stdout, csv:FILE or file:FILE, "
                             f"found {attrs['show']!r}")
        if attrs["show"].startswith("csv:") and "table" not in attrs:
            raise ValueError(f"{rel}:{start + 1}: show=\"csv:...\" needs table=\"Header={{field}} | ...\"")
        for key in ("from", "to", "mask"):
            if key in attrs:
                try:
                    re.compile(attrs[key])
                except re.error as err:
                    raise ValueError(f"{rel}:{start + 1}: {key}: not a regex: {err}") from None
        body_start = i + 1
        j = body_start
        while j < len(lines) and lines[j].strip() != CLOSE:
            if OPEN_RE.match(lines[j].strip()):
                raise ValueError(f"{rel}:{j + 1}: figures block opened inside the one of line {start + 1}")
            j += 1
        if j >= len(lines):
            raise ValueError(f"{rel}:{start + 1}: figures block not closed with {CLOSE}")
        blocks.append(Block(rel, start + 1, attrs, body_start, j, lines[body_start:j]))
        i = j + 1
    return blocks


class _NumberFormatter(string.Formatter):
    """Formats CSV fields: a field that parses as a number is a float for the format spec."""

    def format_field(self, value, format_spec):
        if format_spec:
            try:
                value = float(value)
            except ValueError:
                pass
        return super().format_field(value, format_spec)


def _between(block, lines):
    """The lines from the first matching the block's `from` up to, not including, the first later
    one matching its `to` (defaults: the first line, the end), trailing blank lines dropped."""
    start = 0
    if "from" in block.attrs:
        hits = [k for k, l in enumerate(lines) if re.search(block.attrs["from"], l)]
        if not hits:
            raise ValueError(f"{block.where()}: no output line matches from={block.attrs['from']!r}")
        start = hits[0]
    end = len(lines)
    if "to" in block.attrs:
        hits = [k for k in range(start + 1, len(lines)) if re.search(block.attrs["to"], lines[k])]
        if not hits:
            raise ValueError(f"{block.where()}: no output line after the first matches "
                             f"to={block.attrs['to']!r}")
        end = hits[0]
    chosen = [l.rstrip() for l in lines[start:end]]
    while chosen and not chosen[-1]:
        chosen.pop()
    return chosen


def render(block, stdout, run_dir):
    """The block's body (list of lines) from the command's stdout and its run folder."""
    show = block.attrs["show"]
    if show == "stdout":
        return ["```text"] + _between(block, stdout.splitlines()) + ["```"]
    kind, name = show.split(":", 1)
    if run_dir is None:
        raise ValueError(f"{block.where()}: the command made no run folder (out/latest) to read {name} from")
    path = Path(run_dir) / name
    if not path.is_file():
        raise ValueError(f"{block.where()}: {path} does not exist after the command")
    if kind == "file":
        return _between(block, path.read_text().splitlines())
    rows = list(csv.DictReader(io.StringIO(path.read_text())))
    if "where" in block.attrs:
        column, _, value = block.attrs["where"].partition("=")
        rows = [r for r in rows if r.get(column) == value]
    columns = [c.strip() for c in block.attrs["table"].split("|")]
    headers, templates = [], []
    for column in columns:
        header, sep, template = column.partition("=")
        if not sep:
            raise ValueError(f"{block.where()}: table column {column!r} is not Header={{field}}")
        headers.append(header.strip())
        templates.append(template.strip())
    formatter = _NumberFormatter()
    out = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    for row in rows:
        try:
            cells = [formatter.format(t, **row) for t in templates]
        except (KeyError, ValueError) as err:
            raise ValueError(f"{block.where()}: table: {err!r} (columns of {name}: "
                             f"{', '.join(row)})") from None
        out.append("| " + " | ".join(cells) + " |")
    return out


def masked(lines, mask):
    if not mask:
        return list(lines)
    return [re.sub(mask, "…", l) for l in lines]


def first_difference(stored, fresh, mask):
    """None when the block is current, else a short description of the first differing line."""
    a, b = masked(stored, mask), masked(fresh, mask)
    for k in range(max(len(a), len(b))):
        old = a[k] if k < len(a) else "(no line)"
        new = b[k] if k < len(b) else "(no line)"
        if old != new:
            return f"line {k + 1} of the block:\n    doc: {old}\n    now: {new}"
    return None


def rewrite(root, blocks_with_bodies):
    """Writes new bodies into their docs; blocks of one file are replaced bottom-up."""
    by_file = {}
    for block, body in blocks_with_bodies:
        by_file.setdefault(block.path, []).append((block, body))
    for rel, items in by_file.items():
        path = Path(root) / rel
        lines = path.read_text().splitlines()
        for block, body in sorted(items, key=lambda item: -item[0].body_start):
            lines[block.body_start:block.body_end] = body
        path.write_text("\n".join(lines) + "\n")
