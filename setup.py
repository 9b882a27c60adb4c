"""The compiled lexer and LALR driver (`reconf_dsl/_fastparse.pyx`), built where Cython and a C
compiler are there. Without them, or when the build fails, reconf installs all the same and
parses with its Python driver (the same results, slower: docs/editor.md, "Parsing"). The
project's metadata is in pyproject.toml."""
from __future__ import annotations

import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext


class OptionalBuildExt(build_ext):
    """build_ext that reports a failed build instead of failing the install."""

    def run(self) -> None:
        try:
            super().run()
        except Exception as e:  # noqa: BLE001 - no compiler, no headers: the Python driver serves
            print(f"reconf: the compiled parser was not built ({e}); the Python driver will parse", file=sys.stderr)

    def build_extension(self, ext: Extension) -> None:
        try:
            super().build_extension(ext)
        except Exception as e:  # noqa: BLE001
            print(f"reconf: the compiled parser was not built ({e}); the Python driver will parse", file=sys.stderr)


def extensions() -> list[Extension]:
    try:
        from Cython.Build import cythonize
    except ImportError:
        print("reconf: Cython is not installed; the Python driver will parse", file=sys.stderr)
        return []
    return cythonize([Extension("reconf_dsl._fastparse", ["reconf_dsl/_fastparse.pyx"])],
                     compiler_directives={"language_level": 3}, quiet=True)


setup(ext_modules=extensions(), cmdclass={"build_ext": OptionalBuildExt})
