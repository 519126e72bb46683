"""scripts/check-layers: the real tree passes, and each kind of violation is caught."""
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, 'scripts', 'check-layers')


def run(root):
    p = subprocess.run([SCRIPT, '--root', root], capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


class CheckLayers(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp()
        os.makedirs(os.path.join(self.tmp, 'docs'))
        shutil.copy(os.path.join(ROOT, 'docs', 'architecture.md'), os.path.join(self.tmp, 'docs'))
        self.write('src/engine/Renderer.h', '#pragma once\n')
        self.write('src/render/Film.h', '#pragma once\n#include "../core/Vec.h"\n')
        self.write('src/core/Vec.h', '#pragma once\n')
        self.write('src/abi/nimbus.h', '#pragma once\n')

    def tearDown(self):
        shutil.rmtree(self.tmp)

    def write(self, rel, text):
        path = os.path.join(self.tmp, rel)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, 'w') as f:
            f.write(text)

    def test_the_real_tree_passes(self):
        code, out = run(ROOT)
        self.assertEqual(code, 0, out)
        self.assertIn('engine -> wkb', out)

    def test_a_clean_small_tree_passes(self):
        code, out = run(self.tmp)
        self.assertEqual(code, 0, out)

    def test_an_upward_relative_include_fails(self):
        self.write('src/render/Bad.cpp', '#include "../engine/Renderer.h"\n')
        code, out = run(self.tmp)
        self.assertEqual(code, 1, out)
        self.assertIn('src/render/Bad.cpp:1: render includes engine', out)

    def test_an_upward_rooted_include_fails(self):
        self.write('src/core/Bad.h', '#pragma once\n#include "render/Film.h"\n')
        code, out = run(self.tmp)
        self.assertEqual(code, 1, out)
        self.assertIn('src/core/Bad.h:2: core includes render', out)

    def test_siblings_may_not_include_each_other(self):
        self.write('src/pathtracer/Pt.h', '#pragma once\n')
        self.write('src/wkb/Bad.cpp', '#include "../pathtracer/Pt.h"\n')
        code, out = run(self.tmp)
        self.assertEqual(code, 1, out)
        self.assertIn('wkb includes pathtracer', out)

    def test_a_plugin_includes_only_the_abi(self):
        self.write('plugins/python/Ok.cpp', '#include "nimbus.h"\n')
        self.assertEqual(run(self.tmp)[0], 0)
        self.write('plugins/python/Bad.cpp', '#include "render/Film.h"\n')
        code, out = run(self.tmp)
        self.assertEqual(code, 1, out)
        self.assertIn('plugins includes render', out)

    def test_a_folder_without_a_row_fails(self):
        self.write('src/newthing/X.cpp', '#include "../core/Vec.h"\n')
        code, out = run(self.tmp)
        self.assertEqual(code, 1, out)
        self.assertIn('src/newthing/: a folder with no row', out)


if __name__ == '__main__':
    unittest.main()
