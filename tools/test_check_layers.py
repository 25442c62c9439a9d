"""Tests of tools/check_layers.py on small temporary trees.

Run: /usr/bin/python3 -m unittest -q tools/test_check_layers.py
"""

import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent / "check_layers.py"
sys.path.insert(0, str(SCRIPT.parent))
import check_layers  # noqa: E402


class CheckLayersTest(unittest.TestCase):
    def setUp(self):
        self._tmp = tempfile.TemporaryDirectory()
        self.root = Path(self._tmp.name)
        (self.root / "include" / "peha").mkdir(parents=True)
        (self.root / "src").mkdir()

    def tearDown(self):
        self._tmp.cleanup()

    def write(self, rel, text):
        path = self.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)

    def run_checker(self, *extra):
        return subprocess.run([sys.executable, str(SCRIPT), str(self.root), *extra],
                              capture_output=True, text=True, timeout=60)

    def assert_ok(self):
        r = self.run_checker()
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("OK", r.stdout)
        return r

    def assert_fails(self):
        r = self.run_checker()
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        return r

    def test_allowed_includes_pass(self):
        self.write("include/peha/config/reader.hpp", "#pragma once\n#include <string>\n")
        self.write("include/peha/models/joint.hpp", '#pragma once\n#include "peha/config/reader.hpp"\n')
        self.write("src/models/joint.cpp", '#include "peha/models/joint.hpp"\n#include "peha/config/reader.hpp"\n')
        self.write("src/runtime/loop.cpp",
                   '#include "peha/io/backend.hpp"\n#include <peha/safety/limits.hpp>\n'
                   '#include "peha/runtime/loop.hpp"\n')
        self.write("src/app/main.cpp", "".join(f'#include "peha/{layer}/x.hpp"\n' for layer in check_layers.RULES))
        r = self.assert_ok()
        self.assertIn("5 files checked", r.stdout)
        self.assertIn(f"{1 + 2 + 3 + len(check_layers.RULES)} peha includes checked", r.stdout)

    def test_models_including_sim_fails_with_file_and_line(self):
        self.write("include/peha/models/joint.hpp",
                   '#pragma once\n#include "peha/config/reader.hpp"\n#include "peha/sim/x.hpp"\n')
        r = self.assert_fails()
        self.assertIn("include/peha/models/joint.hpp:3: layer models may not include peha/sim/x.hpp "
                      "(models may include: config)", r.stdout)
        self.assertNotIn(":2:", r.stdout)
        self.assertIn("FAILED", r.stdout)

    def test_control_including_runtime_fails_with_file_and_line(self):
        self.write("src/control/allocation.cpp",
                   '#include "peha/control/allocation.hpp"\n\n#include <vector>\n#include "peha/runtime/x.hpp"\n')
        r = self.assert_fails()
        self.assertIn("src/control/allocation.cpp:4: layer control may not include peha/runtime/x.hpp", r.stdout)

    def test_config_may_include_nothing_of_peha(self):
        self.write("src/config/reader.cpp", '#include "peha/models/joint.hpp"\n')
        r = self.assert_fails()
        self.assertIn("src/config/reader.cpp:1: layer config may not include peha/models/joint.hpp "
                      "(config may include: nothing of peha)", r.stdout)

    def test_every_violation_is_reported(self):
        self.write("src/io/a.cpp", '#include "peha/sim/x.hpp"\n#include "peha/mfb/y.hpp"\n')
        self.write("src/sim/b.cpp", '#include "peha/mfb/z.hpp"\n')
        r = self.assert_fails()
        self.assertIn("src/io/a.cpp:1:", r.stdout)
        self.assertIn("src/io/a.cpp:2:", r.stdout)
        self.assertIn("src/sim/b.cpp:1:", r.stdout)
        self.assertIn("3 violation(s)", r.stdout)

    def test_unknown_layer_folder_fails(self):
        self.write("src/gui/window.cpp", "#include <string>\n")
        r = self.assert_fails()
        self.assertIn("src/gui/window.cpp", r.stdout)
        self.assertIn("unknown layer gui", r.stdout)

    def test_unknown_layer_in_include_tree_fails(self):
        self.write("include/peha/gui/window.hpp", "#pragma once\n")
        r = self.assert_fails()
        self.assertIn("include/peha/gui/window.hpp", r.stdout)
        self.assertIn("unknown layer gui", r.stdout)

    def test_include_of_unknown_layer_fails(self):
        self.write("src/app/main.cpp", '#include "peha/gui/window.hpp"\n')
        r = self.assert_fails()
        self.assertIn("src/app/main.cpp:1:", r.stdout)
        self.assertIn("unknown layer gui", r.stdout)

    def test_file_outside_any_layer_fails(self):
        self.write("src/main.cpp", "int main() {}\n")
        r = self.assert_fails()
        self.assertIn("src/main.cpp", r.stdout)

    def test_deeper_subfolders_belong_to_their_top_level_layer(self):
        # Allowed: experiments may include runtime; the deep file is layer experiments.
        self.write("include/peha/experiments/e1_gravity/e1_gravity.hpp",
                   '#pragma once\n#include "peha/runtime/loop.hpp"\n#include "peha/experiments/common/x.hpp"\n')
        self.write("src/experiments/e1_gravity/deep/e1.cpp", '#include "peha/mfb/udp_backend.hpp"\n')
        self.assert_ok()
        # Forbidden: experiments may not include app; the message names layer experiments.
        self.write("src/experiments/e1_gravity/deep/e1.cpp", '#include "peha/app/cli.hpp"\n')
        r = self.assert_fails()
        self.assertIn("src/experiments/e1_gravity/deep/e1.cpp:1: layer experiments may not include "
                      "peha/app/cli.hpp", r.stdout)
        # And a deep include path is attributed to its top-level target layer.
        self.write("src/experiments/e1_gravity/deep/e1.cpp", "")
        self.write("src/models/a/b/c.cpp", '#include "peha/sim/plants/one_dof/rig.hpp"\n')
        r = self.assert_fails()
        self.assertIn("src/models/a/b/c.cpp:1: layer models may not include peha/sim/plants/one_dof/rig.hpp",
                      r.stdout)

    def test_commented_out_includes_and_other_files_are_ignored(self):
        self.write("src/models/joint.cpp",
                   '// #include "peha/sim/x.hpp"\n/*\n#include "peha/sim/y.hpp"\n*/\n'
                   'const char* s = "/*";\n#include "peha/config/reader.hpp"\n')
        self.write("src/models/notes.md", '#include "peha/sim/x.hpp"\n')
        r = self.assert_ok()
        self.assertIn("1 files checked", r.stdout)
        self.assertIn("1 peha includes checked", r.stdout)
        # The "/*" in the string literal opened no comment: a later violation is still found.
        self.write("src/models/joint.cpp", 'const char* s = "/*";\n#include "peha/sim/x.hpp"\n')
        r = self.assert_fails()
        self.assertIn("src/models/joint.cpp:2:", r.stdout)

    def test_relative_include_into_another_layer_fails(self):
        self.write("include/peha/sim/x.hpp", "#pragma once\n")
        self.write("include/peha/models/joint.hpp", '#pragma once\n#include "../sim/x.hpp"\n')
        r = self.assert_fails()
        self.assertIn("include/peha/models/joint.hpp:2: layer models may not include peha/sim/x.hpp", r.stdout)

    def test_root_without_layers_is_a_usage_error(self):
        with tempfile.TemporaryDirectory() as empty:
            r = subprocess.run([sys.executable, str(SCRIPT), empty], capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)

    def test_print_rules_lists_every_layer_with_a_reason(self):
        r = self.run_checker("--print-rules")
        self.assertEqual(r.returncode, 0, r.stderr)
        for layer, (_, reason) in check_layers.RULES.items():
            self.assertIn(layer, r.stdout)
            self.assertIn(reason, r.stdout)
        self.assertIn("may include: nothing of peha", r.stdout)
        self.assertIn("may include: everything", r.stdout)

    def test_rule_table_is_as_specified_and_acyclic(self):
        rules = {k: v[0] for k, v in check_layers.RULES.items()}
        self.assertEqual(list(rules), ["config", "models", "calibration", "control", "io", "safety", "sim",
                                       "mfb", "runtime", "hardware", "experiments", "api", "video", "app"])
        self.assertEqual(rules["config"], set())
        # The door sits between the experiments and every kind of hardware below it.
        self.assertIn("hardware", rules["experiments"])
        self.assertEqual(rules["hardware"], {"runtime", "mfb", "sim", "safety", "io", "models", "config"})
        self.assertEqual(rules["video"], {"sim", "io", "models", "config"})
        self.assertEqual(rules["runtime"], {"io", "safety", "models", "config"})
        self.assertEqual(rules["app"], check_layers.ALL)
        for layer, deps in rules.items():
            if deps == check_layers.ALL:
                continue
            self.assertNotIn(layer, deps)
            self.assertLessEqual(deps, set(rules), layer)
            self.assertNotIn("app", deps, layer)

        # No cycles among the explicit sets (app, which may include everything, is the top).
        state = {}

        def visit(layer, path):
            self.assertNotEqual(state.get(layer), "visiting", f"cycle: {' -> '.join(path + [layer])}")
            if state.get(layer) == "done":
                return
            state[layer] = "visiting"
            deps = rules[layer]
            for dep in ([] if deps == check_layers.ALL else sorted(deps)):
                visit(dep, path + [layer])
            state[layer] = "done"

        for layer in rules:
            visit(layer, [])


if __name__ == "__main__":
    unittest.main()
