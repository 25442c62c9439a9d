#!/usr/bin/python3
"""Every shell command in README.md and docs/*.md is checked, or says why it cannot be.

A command is a line of a ```sh, ```bash or ```console block (a line ending in `\\` is joined with
the next; a `for ...` line with the lines up to its `done`; blank lines and `#` lines are skipped).
Each command must be in exactly one of these categories:

  run      listed in docs/commands.tsv as `run` (or `run:N`, expecting exit code N): this checker
           runs it (in document order, each distinct command once), in one scratch folder where configs/, examples/, tools/, fuzz/ and
           build/release/ point into the checkout and the build, so `out/...` is written there and
           never into the checkout; `peha` alone means build/release/peha; `[optional ...]` parts
           are left out; /tmp/caldoc and /etc/peha are moved into the scratch folder;
  test     listed in docs/commands.tsv as `test:NAME`: the ctest test NAME runs it (NAME must be
           in `ctest -N` of the build);
  marked   its trailing comment says `needs hardware` (a real board, a real machine) or
           `long: WHAT` (too long to run here; WHAT says what runs it, e.g. `long: make robustness`)
           or `by hand: WHY` (must not run unattended: it writes a shipped file, or needs data
           outside the repository).

Anything else fails, naming file:line and the command. Whatever its category, every option of a
`peha ...` or `pd_gravity_example ...` in a command must be one its --help lists, and every
configs/... file it names must exist, so a command too long to run cannot go stale unnoticed.

Then the figures blocks (`<!-- figures: run="..." show="..." -->` ... `<!-- /figures -->`,
tools/doc_figures.py): each block's command runs (once, if a doc command already ran it) and the
block must equal what it makes now; --update-figures rewrites the blocks instead, --long also runs
the blocks marked long="...".

Usage: check_doc_commands.py --build-dir BUILD [--root ROOT] [--registry FILE] [--no-run] [--list]
                             [--docs FILE...] [--update-figures] [--long]
Exit code: 0 if every command is accounted for, 1 otherwise, 2 on a usage error.
Standard library only; runs on /usr/bin/python3.
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import doc_figures  # noqa: E402  (beside this file)

SHELL_LANGS = {"sh", "bash", "console", "shell"}
HARDWARE_RE = re.compile(r"\bneeds hardware\b")
LONG_RE = re.compile(r"\blong:\s*\S")
BY_HAND_RE = re.compile(r"\bby hand:\s*\S")
# Folders of the checkout a command may read, linked into the scratch folder.
LINKED_DIRS = ("configs", "examples", "tools", "fuzz", "data", "python", "scripts")
RUN_TIMEOUT_S = 120
LONG_TIMEOUT_S = 4 * 3600  # a long figures block: a whole matrix


@dataclass
class Command:
    path: str      # as given (relative to the root)
    line: int      # first line of the command, 1-based
    text: str      # the command without its comment, whitespace collapsed
    comment: str   # the trailing comment, without `#`

    def where(self):
        return f"{self.path}:{self.line}"


def split_comment(line):
    """(code, comment) of one shell line: a `#` outside quotes, at the start or after a blank."""
    quote = None
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip(), line[i + 1:].strip()
    return line.rstrip(), ""


def normalise(code):
    return " ".join(code.split())


def extract_commands(root, rel):
    """The commands of the shell blocks of one Markdown file."""
    commands = []
    in_block = False
    pending = None  # [first line, code parts, comments, kind]: kind "cont" or "loop"
    for number, raw in enumerate((Path(root) / rel).read_text().splitlines(), 1):
        stripped = raw.strip()
        if stripped.startswith("```"):
            lang = stripped[3:].strip().lower()
            in_block = (not in_block) and lang in SHELL_LANGS
            if not in_block and pending:
                raise ValueError(f"{rel}:{pending[0]}: command not ended before the block ends")
            continue
        if not in_block:
            continue
        if stripped.startswith("$ "):  # console prompt
            stripped = stripped[2:]
        code, comment = split_comment(stripped)
        if pending is None:
            if not code:
                continue
            pending = [number, [], [], None]
        if code.endswith("\\"):
            pending[1].append(code[:-1])
            pending[2].append(comment)
            pending[3] = pending[3] or "cont"
            continue
        pending[1].append(code)
        pending[2].append(comment)
        if re.match(r"(for|while)\b", pending[1][0].strip()) and code != "done":
            pending[3] = "loop"
            continue
        joiner = " ; " if pending[3] == "loop" else " "
        text = normalise(joiner.join(pending[1])).replace("do ;", "do")
        commands.append(Command(rel, pending[0], text, " ".join(c for c in pending[2] if c)))
        pending = None
    if pending:
        raise ValueError(f"{rel}:{pending[0]}: command not ended at the end of the file")
    return commands


def doc_files(root):
    root = Path(root)
    files = ["README.md"] if (root / "README.md").exists() else []
    files += sorted(str(p.relative_to(root)) for p in (root / "docs").glob("*.md"))
    return files


def read_registry(path):
    """{normalised command: how}, how = "run", "run:N" or "test:NAME"."""
    registry = {}
    for number, raw in enumerate(Path(path).read_text().splitlines(), 1):
        if not raw.strip() or raw.startswith("#"):
            continue
        how, sep, command = raw.partition("\t")
        if not sep or not re.fullmatch(r"run(:\d+)?|test:\S+", how):
            raise ValueError(f"{path}:{number}: expected `run`, `run:N` or `test:NAME`, a tab, "
                             f"then the command; found {raw!r}")
        key = normalise(command)
        if key in registry:
            raise ValueError(f"{path}:{number}: command listed twice: {key}")
        registry[key] = how
    return registry


def ctest_names(build_dir):
    out = subprocess.run(["ctest", "-N", "--test-dir", str(build_dir)], capture_output=True,
                         text=True, check=True).stdout
    return set(re.findall(r"^\s*Test\s+#\d+:\s+(\S+)\s*$", out, re.M))


def classify(commands, registry, test_names):
    """(errors, {category: [Command]}); category is run, test, hardware or long."""
    errors = []
    groups = {"run": [], "test": [], "hardware": [], "long": [], "by hand": []}
    for cmd in commands:
        how = registry.get(cmd.text)
        marked = ("hardware" if HARDWARE_RE.search(cmd.comment)
                  else "long" if LONG_RE.search(cmd.comment)
                  else "by hand" if BY_HAND_RE.search(cmd.comment) else None)
        if how and marked:
            errors.append(f"{cmd.where()}: both in the registry ({how}) and marked `{marked}`: {cmd.text}")
        elif how and how.startswith("test:"):
            name = how[5:]
            if name not in test_names:
                errors.append(f"{cmd.where()}: mapped to test {name!r}, which ctest -N does not list: {cmd.text}")
            else:
                groups["test"].append(cmd)
        elif how:
            groups["run"].append(cmd)
        elif marked:
            groups[marked].append(cmd)
        else:
            errors.append(f"{cmd.where()}: neither run, mapped to a test in docs/commands.tsv, nor "
                          f"marked `# needs hardware` / `# long: WHAT` / `# by hand: WHY`: {cmd.text}")
    used = {c.text for c in commands}
    for key in registry:
        if key not in used:
            errors.append(f"docs/commands.tsv: lists a command no doc has (stale entry): {key}")
    return errors, groups


def runnable(text, scratch):
    """The command as the checker runs it in the scratch folder."""
    text = re.sub(r"\s*\[[^\]]*\]", "", text)  # optional parts of a usage line
    text = re.sub(r"(^|;\s*|&&\s*)(\./)?peha\b", r"\1build/release/peha", text)
    text = re.sub(r"(^|\s)\./build/", r"\1build/", text)
    text = text.replace("/tmp/caldoc", f"{scratch}/caldoc").replace("/etc/peha", f"{scratch}/etc/peha")
    return text


def run_commands(cmds, root, build_dir, registry, blocks=()):
    """Runs the commands in document order (README, then docs/ by name) in one scratch folder, so
    a command finds what an earlier one wrote (a run its replay reads); a command already run
    with the same text is not run again. Then the figures blocks' commands (those not run yet),
    each block rendered from its command's output and run folder (tools/doc_figures.py).
    Returns (errors, [(block, fresh body)])."""
    errors = []
    rendered = []
    outputs = {}  # command text -> (stdout, run folder or None)
    with tempfile.TemporaryDirectory(prefix="peha-doc-") as scratch:
        for name in LINKED_DIRS:
            if (Path(root) / name).exists():
                os.symlink(Path(root).resolve() / name, Path(scratch) / name)
        (Path(scratch) / "build").mkdir()
        os.symlink(Path(build_dir).resolve(), Path(scratch) / "build" / "release")
        (Path(scratch) / "etc" / "peha").mkdir(parents=True)
        env = dict(os.environ, MPLBACKEND="Agg")
        latest = Path(scratch) / "out" / "latest"
        jobs = ([(c.text, c.where(), None, RUN_TIMEOUT_S) for c in cmds]
                + [(b.command, b.where(), int(b.attrs.get("exit", "0")),
                    LONG_TIMEOUT_S if "long" in b.attrs else RUN_TIMEOUT_S) for b in blocks])
        for text, where, block_exit, timeout_s in jobs:
            line = runnable(text, scratch)
            if line in outputs:  # the same command as run: once
                continue
            how = registry.get(text, "run")
            expected = block_exit if block_exit is not None else int(how.split(":")[1]) if ":" in how else 0
            before = os.path.realpath(latest) if latest.is_symlink() else None
            start = time.monotonic()
            try:
                done = subprocess.run(["bash", "-c", line], cwd=scratch, env=env, capture_output=True,
                                      text=True, timeout=timeout_s)
                code, tail, stdout = done.returncode, (done.stdout + done.stderr)[-1500:], done.stdout
            except subprocess.TimeoutExpired:
                code, tail, stdout = None, f"timed out after {timeout_s} s", ""
            after = os.path.realpath(latest) if latest.is_symlink() else None
            outputs[line] = (stdout, after if after and after != before else None)
            print(f"  ran {where} in {time.monotonic() - start:.1f} s, exit {code}: {line}")
            if code != expected:
                errors.append(f"{where}: exit {code}, expected {expected}: {text}\n{tail}")
            for block in blocks:
                if runnable(block.command, scratch) == line:
                    try:
                        rendered.append((block, doc_figures.render(block, *outputs[line])))
                    except ValueError as err:
                        errors.append(str(err))
    return errors, rendered


def check_figures(rendered):
    """Errors for every figures block whose text is not what its command makes now."""
    errors = []
    for block, body in rendered:
        diff = doc_figures.first_difference(block.body, body, block.attrs.get("mask"))
        if diff:
            errors.append(f"{block.where()}: figures out of date ({block.command}), {diff}\n"
                          f"  regenerate: tools/check_doc_commands.py --build-dir build/release --update-figures")
    return errors


PROGRAM_RE = re.compile(r"(?:^|/)(peha|pd_gravity_example)$")


def check_invocations(commands, root, build_dir):
    """Every command, whatever its category: each option of a peha (or pd_gravity_example)
    invocation is one its --help lists, and each configs/... file it names exists. Catches a doc
    gone stale even where the command is too long to run here. Returns the errors."""
    errors = []
    helps = {}
    checked = 0

    def help_text(program, sub):
        if (program, sub) not in helps:
            argv = [str(Path(build_dir) / program)] + ([sub] if sub else []) + ["--help"]
            done = subprocess.run(argv, capture_output=True, text=True, timeout=30)
            helps[(program, sub)] = done.stdout + done.stderr if done.returncode == 0 else None
        return helps[(program, sub)]

    for cmd in commands:
        for segment in re.split(r"\s*(?:;|&&|\|\||\||&)\s*", re.sub(r"\[|\]|\.\.\.", " ", cmd.text)):
            words = segment.split()
            while words and "=" in words[0] and not words[0].startswith("-"):
                words = words[1:]  # VAR=value prefixes
            if not words or not PROGRAM_RE.search(words[0]):
                continue
            program = PROGRAM_RE.search(words[0]).group(1)
            sub = words[1] if program == "peha" and len(words) > 1 and not words[1].startswith("-") else ""
            text = help_text(program, sub)
            checked += 1
            if text is None:
                errors.append(f"{cmd.where()}: `{program} {sub} --help` fails: {cmd.text}")
                continue
            for word in words[1:]:
                option = word.split("=", 1)[0]
                if re.fullmatch(r"--?[A-Za-z][\w-]*", option) and not re.search(
                        r"(^|[\s,])" + re.escape(option) + r"\b", text):
                    errors.append(f"{cmd.where()}: `{program} {sub}` has no option {option}: {cmd.text}")
                if word.startswith("configs/") and not (Path(root) / word).exists():
                    errors.append(f"{cmd.where()}: no file {word}: {cmd.text}")
    print(f"checked the options and configs/ files of {checked} invocations against their --help")
    return errors


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build-dir", required=True, help="the build folder (holds peha and CTestTestfile.cmake)")
    parser.add_argument("--root", default=str(Path(__file__).resolve().parent.parent))
    parser.add_argument("--registry", help="default: ROOT/docs/commands.tsv")
    parser.add_argument("--no-run", action="store_true", help="classify only, run nothing")
    parser.add_argument("--list", action="store_true", help="print every command and its category")
    parser.add_argument("--update-figures", action="store_true",
                        help="rewrite every figures block with what its command makes now (tools/doc_figures.py)")
    parser.add_argument("--docs", nargs="+", metavar="FILE",
                        help="only these docs (e.g. docs/python.md): their commands and figures blocks")
    parser.add_argument("--long", action="store_true",
                        help="also run the figures blocks marked long=\"...\" (minutes each)")
    args = parser.parse_args(argv)
    root = Path(args.root)
    registry_path = Path(args.registry) if args.registry else root / "docs" / "commands.tsv"
    try:
        files = doc_files(root)
        if args.docs:
            unknown = [d for d in args.docs if d not in files]
            if unknown:
                raise ValueError(f"--docs: {', '.join(unknown)} not among README.md and docs/*.md")
            files = args.docs
        commands = [c for rel in files for c in extract_commands(root, rel)]
        registry = read_registry(registry_path)
        blocks = [b for rel in files for b in doc_figures.parse_blocks(root, rel)]
        names = ctest_names(args.build_dir)
    except (ValueError, OSError, subprocess.CalledProcessError) as err:
        print(f"check_doc_commands: {err}", file=sys.stderr)
        return 2
    errors, groups = classify(commands, registry, names)
    if args.docs:  # the other docs' registry entries are not stale
        errors = [e for e in errors if "(stale entry)" not in e]
    errors += check_invocations(commands + [Command(b.path, b.line, b.command, "") for b in blocks],
                                root, args.build_dir)
    if args.list:
        for category, cmds in groups.items():
            for cmd in cmds:
                print(f"{category:8} {cmd.where()}: {cmd.text}")
    long_blocks = [b for b in blocks if "long" in b.attrs]
    chosen = [b for b in blocks if args.long or "long" not in b.attrs]
    if not args.no_run:
        start = time.monotonic()
        run_errors, rendered = run_commands(groups["run"], root, args.build_dir, registry, chosen)
        errors += run_errors
        print(f"ran {len(groups['run'])} commands in {time.monotonic() - start:.1f} s")
        if args.update_figures:
            doc_figures.rewrite(root, rendered)
            print(f"rewrote {len(rendered)} figures blocks")
        else:
            errors += check_figures(rendered)
        print(f"{len(blocks)} figures blocks: {len(rendered)} regenerated"
              + ("" if args.long else f", {len(long_blocks)} long not run (--long runs them: "
                 + ", ".join(sorted({b.attrs['long'] for b in long_blocks})) + ")"))
    print(f"{len(commands)} commands: {len(groups['run'])} run here, {len(groups['test'])} run by a test, "
          f"{len(groups['hardware'])} need hardware, {len(groups['long'])} long, "
          f"{len(groups['by hand'])} by hand")
    for err in errors:
        print(f"error: {err}")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
