"""The benchmark scripts as modules, for the tests that check their parts."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def bench_module(name: str) -> ModuleType:
    """A fresh load of ``benchmarks/NAME.py`` as module ``NAME``: registered in
    ``sys.modules`` (its dataclasses and worker processes look their module up), with
    ``benchmarks/`` on ``sys.path`` for the sibling scripts it imports.  Each call loads it
    again, so that one test's changes to its globals do not reach another's."""
    path = BENCHMARKS / f"{name}.py"
    if not path.is_file():
        msg = f"no benchmark script {path}"
        raise FileNotFoundError(msg)
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod
