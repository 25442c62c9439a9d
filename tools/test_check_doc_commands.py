"""Tests of tools/check_doc_commands.py on small fake docs.

Run: /usr/bin/python3 -m unittest -q tools/test_check_doc_commands.py
"""

import sys
import tempfile
import unittest
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent / "check_doc_commands.py"
sys.path.insert(0, str(SCRIPT.parent))
import check_doc_commands as cdc  # noqa: E402

DOC = """# A page

```sh
peha check-config --config a.yaml      # validates
peha run --config a.yaml \\
  --case x                             # long: make run
peha run --config b.yaml --backend udp://10.0.0.2:50000   # the real board; needs hardware
cp out/g.yaml configs/g.yaml           # by hand: writes the shipped file

for t in 1 2; do
  echo $t
done
peha run --config c.yaml
```

```python
not_a_command()
```
"""


class CheckDocCommandsTest(unittest.TestCase):
    def setUp(self):
        self._tmp = tempfile.TemporaryDirectory()
        self.root = Path(self._tmp.name)
        (self.root / "docs").mkdir()
        (self.root / "docs" / "page.md").write_text(DOC)

    def tearDown(self):
        self._tmp.cleanup()

    def commands(self):
        return cdc.extract_commands(self.root, "docs/page.md")

    def test_extracts_joined_lines_loops_and_comments_and_skips_other_blocks(self):
        got = [(c.line, c.text, c.comment) for c in self.commands()]
        self.assertEqual(got, [
            (4, "peha check-config --config a.yaml", "validates"),
            (5, "peha run --config a.yaml --case x", "long: make run"),
            (7, "peha run --config b.yaml --backend udp://10.0.0.2:50000", "the real board; needs hardware"),
            (8, "cp out/g.yaml configs/g.yaml", "by hand: writes the shipped file"),
            (10, "for t in 1 2; do echo $t ; done", ""),
            (13, "peha run --config c.yaml", ""),
        ])

    def test_an_unlisted_unmarked_command_fails_naming_file_line_and_command(self):
        registry = {"peha check-config --config a.yaml": "run",
                    "for t in 1 2; do echo $t ; done": "test:Some.Test"}
        errors, groups = cdc.classify(self.commands(), registry, {"Some.Test"})
        self.assertEqual(len(errors), 1)
        self.assertIn("docs/page.md:13:", errors[0])
        self.assertIn("peha run --config c.yaml", errors[0])
        self.assertEqual([len(groups[k]) for k in ("run", "test", "hardware", "long", "by hand")], [1, 1, 1, 1, 1])

    def test_a_mapping_to_a_test_ctest_does_not_list_fails(self):
        registry = {"peha run --config c.yaml": "test:No.SuchTest"}
        errors, _ = cdc.classify(self.commands(), registry, {"Some.Test"})
        self.assertTrue(any("docs/page.md:13: mapped to test 'No.SuchTest'" in e for e in errors), errors)

    def test_a_stale_registry_entry_and_a_listed_marked_command_fail(self):
        registry = {"peha gone --config z.yaml": "run", "peha run --config a.yaml --case x": "run"}
        errors, _ = cdc.classify(self.commands(), registry, set())
        self.assertTrue(any("stale entry" in e and "peha gone" in e for e in errors), errors)
        self.assertTrue(any("docs/page.md:5: both in the registry" in e for e in errors), errors)

    def test_a_run_command_that_exits_otherwise_fails_and_one_that_matches_passes(self):
        cmds = [c for c in self.commands() if c.line in (10,)]
        build = self.root / "build"
        build.mkdir()
        self.assertEqual(cdc.run_commands(cmds, self.root, build, {cmds[0].text: "run"}), ([], []))
        errors, _ = cdc.run_commands(cmds, self.root, build, {cmds[0].text: "run:3"})
        self.assertEqual(len(errors), 1)
        self.assertIn("docs/page.md:10: exit 0, expected 3", errors[0])

    def test_the_runnable_form_uses_the_build_leaves_optional_parts_out_and_keeps_out_of_system_paths(self):
        line = cdc.runnable("peha keygen --out /etc/peha/k.key [--force] && ./build/release/peha run", "/s")
        self.assertEqual(line, "build/release/peha keygen --out /s/etc/peha/k.key && build/release/peha run")

    def test_an_option_the_help_does_not_list_or_a_missing_config_fails_whatever_the_category(self):
        build = self.root / "build"
        build.mkdir()
        fake = build / "peha"
        fake.write_text('#!/bin/sh\n[ "$1" = run ] && echo "  -c,--config TEXT  --case TEXT  --backend TEXT"\n'
                        '[ "$1" = check-config ] && echo "  --config TEXT"\nexit 0\n')
        fake.chmod(0o755)
        (self.root / "configs").mkdir()
        (self.root / "configs" / "b.yaml").write_text("")
        errors = cdc.check_invocations(self.commands(), self.root, build)
        # a.yaml and c.yaml are not in configs/ (and named without it): only options are checked
        self.assertEqual(errors, [])
        bad = [cdc.Command("docs/page.md", 3, "peha run -c configs/b.yaml --bogus 1 [--case x]", "long: x"),
               cdc.Command("docs/page.md", 4, "X=1 peha run --config configs/gone.yaml", "")]
        errors = cdc.check_invocations(bad, self.root, build)
        self.assertEqual(len(errors), 2, errors)
        self.assertIn("docs/page.md:3: `peha run` has no option --bogus", errors[0])
        self.assertIn("docs/page.md:4: no file configs/gone.yaml", errors[1])

    def test_a_bad_registry_line_is_refused_with_its_line(self):
        reg = self.root / "commands.tsv"
        reg.write_text("# comment\nrunn\tpeha x\n")
        with self.assertRaisesRegex(ValueError, "commands.tsv:2: expected"):
            cdc.read_registry(reg)


FIGURES_DOC = """# Results

<!-- figures: run="printf 'noise\\ncase x 1.50 RTF 30.1\\ncase y 2.25 RTF 12.0\\nwritten: out\\n'"
     show="stdout" from="^case" to="^written" mask="RTF [0-9.]+" -->
```text
case x 1.50 RTF 99.0
case y 2.25 RTF 99.0
```
<!-- /figures -->

Text between.

<!-- figures: run="mkdir -p out/r1 && ln -sfn r1 out/latest && printf 'case,f_N,stop\\na,1.234,ceiling\\nb,20,supply\\n' > out/r1/summary.csv"
     show="csv:summary.csv" table="case={case} | force N={f_N:.1f} | stopped by={stop}" -->
| case | force N | stopped by |
|---|---|---|
| a | 1.2 | ceiling |
| b | 20.0 | supply |
<!-- /figures -->
"""


class DocFiguresTest(unittest.TestCase):
    def setUp(self):
        self._tmp = tempfile.TemporaryDirectory()
        self.root = Path(self._tmp.name)
        (self.root / "docs").mkdir()
        (self.root / "build").mkdir()
        self.page = self.root / "docs" / "results.md"
        self.page.write_text(FIGURES_DOC)

    def tearDown(self):
        self._tmp.cleanup()

    def regenerate(self):
        blocks = cdc.doc_figures.parse_blocks(self.root, "docs/results.md")
        errors, rendered = cdc.run_commands([], self.root, self.root / "build", {}, blocks)
        self.assertEqual(errors, [])
        return rendered

    def test_blocks_made_by_their_commands_are_current_masks_aside(self):
        rendered = self.regenerate()
        self.assertEqual(len(rendered), 2)
        self.assertEqual(cdc.check_figures(rendered), [])  # RTF differs, masked

    def test_a_figure_the_command_no_longer_makes_fails_naming_the_block_and_the_line(self):
        self.page.write_text(FIGURES_DOC.replace("| a | 1.2 | ceiling |", "| a | 1.3 | ceiling |"))
        errors = cdc.check_figures(self.regenerate())
        self.assertEqual(len(errors), 1)
        self.assertIn("docs/results.md:13: figures out of date", errors[0])
        self.assertIn("doc: | a | 1.3 | ceiling |", errors[0])
        self.assertIn("now: | a | 1.2 | ceiling |", errors[0])

    def test_update_rewrites_every_block_in_place_and_leaves_the_text_around(self):
        self.page.write_text(FIGURES_DOC.replace("case y 2.25 RTF 99.0", "case y 9.99 RTF 99.0").replace("| b | 20.0", "| b | 0"))
        cdc.doc_figures.rewrite(self.root, self.regenerate())
        text = self.page.read_text()
        self.assertIn("case y 2.25 RTF 12.0", text)   # the mask compares, the update writes
        self.assertIn("| b | 20.0 | supply |", text)
        self.assertIn("Text between.", text)
        self.assertEqual(cdc.check_figures(self.regenerate()), [])

    def test_a_file_block_shows_its_lines_between_from_and_to_and_takes_its_documented_exit(self):
        doc = ("# R\n\n<!-- figures: run=\"mkdir -p out/r1 && ln -sfn r1 out/latest && printf '# T\\n\\n| a |\\n|---|\\n| 1 |\\n\\n## E4\\n' "
               "> out/r1/t.md && exit 3\"\n     show=\"file:t.md\" from=\"^[|]\" to=\"^## \" exit=\"3\" -->\n<!-- /figures -->\n")
        self.page.write_text(doc)
        blocks = cdc.doc_figures.parse_blocks(self.root, "docs/results.md")
        errors, rendered = cdc.run_commands([], self.root, self.root / "build", {}, blocks)
        self.assertEqual(errors, [])
        self.assertEqual(rendered[0][1], ["| a |", "|---|", "| 1 |"])
        self.page.write_text(doc.replace('exit="3"', 'exit="0"'))
        blocks = cdc.doc_figures.parse_blocks(self.root, "docs/results.md")
        errors, _ = cdc.run_commands([], self.root, self.root / "build", {}, blocks)
        self.assertEqual(len(errors), 1)
        self.assertIn("exit 3, expected 0", errors[0])

    def test_malformed_blocks_are_refused_with_their_line(self):
        cases = {
            "<!-- figures: show=\"stdout\" -->\n<!-- /figures -->\n": "needs run=",
            "<!-- figures: run=\"x\" show=\"png\" -->\n<!-- /figures -->\n": "show must be",
            "<!-- figures: run=\"x\" show=\"csv:s.csv\" -->\n<!-- /figures -->\n": "needs table=",
            "<!-- figures: run=\"x\" show=\"stdout\" colour=\"red\" -->\n<!-- /figures -->\n": "unknown figures attribute",
            "<!-- figures: run=\"x\" show=\"stdout\" -->\nno end\n": "not closed",
            "text\n<!-- /figures -->\n": "without an opening",
        }
        for text, message in cases.items():
            self.page.write_text("# P\n" + text)
            with self.assertRaises(ValueError) as caught:
                cdc.doc_figures.parse_blocks(self.root, "docs/results.md")
            self.assertIn(message, str(caught.exception))
            self.assertIn("docs/results.md:", str(caught.exception))

    def test_a_table_naming_a_column_the_csv_lacks_says_which_columns_it_has(self):
        self.page.write_text(FIGURES_DOC.replace("{f_N:.1f}", "{force_N:.1f}"))
        blocks = cdc.doc_figures.parse_blocks(self.root, "docs/results.md")
        errors, _ = cdc.run_commands([], self.root, self.root / "build", {}, blocks)
        self.assertEqual(len(errors), 1)
        self.assertIn("force_N", errors[0])
        self.assertIn("columns of summary.csv: case, f_N, stop", errors[0])


if __name__ == "__main__":
    unittest.main()
