"""Builds peha's compiled module (peha._core) with the project's own CMake, then packages it.

The extension is the CMake target peha_python (python/src, linked against the C++ core); nothing is
compiled by setuptools itself. PEHA_BUILD_DIR=<a configured build folder> (e.g. build/release)
reuses that build instead of configuring a new one in setuptools' temporary folder.
"""
import os
import pathlib
import shutil
import subprocess

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

SOURCE = pathlib.Path(__file__).resolve().parent.parent  # the checkout: CMakeLists.txt


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = os.environ.get("PEHA_BUILD_DIR")
        if build:
            build = pathlib.Path(build).resolve()
            if not (build / "CMakeCache.txt").is_file():
                raise RuntimeError(f"PEHA_BUILD_DIR={build}: not a configured CMake build folder (no CMakeCache.txt)")
        else:
            build = pathlib.Path(self.build_temp).resolve() / "cmake"
            subprocess.run(["cmake", "-S", str(SOURCE), "-B", str(build), "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
                            "-DPEHA_BUILD_TESTS=OFF", "-DPEHA_BUILD_BENCH=OFF", "-DPEHA_BUILD_PYTHON=ON"], check=True)
        subprocess.run(["cmake", "--build", str(build), "--target", "peha_python"], check=True)
        built = sorted((build / "python" / "peha").glob("_core*.so"))
        if not built:
            raise RuntimeError(f"{build}/python/peha: no _core*.so after building peha_python")
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[0], target)


setup(ext_modules=[Extension("peha._core", sources=[])], cmdclass={"build_ext": CMakeBuild})
