"""The package's layout: data flows one way (sim -> dataset -> deglint -> altimetry ->
evaluation -> report -> cli, with io, camera and _checks under every stage), no import cycle
(imports inside functions count), no module over 500 lines, docstrings that state the method
rather than benchmark history."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import wavealt

ROOT = Path(wavealt.__file__).parent
#: Each top-level part of the package and its place in the pipeline: a module may import
#: its own part or one placed lower, never one placed higher.
RANK = {"__init__": 0, "_checks": 0, "io": 1, "framesource": 1, "camera": 1, "sim": 2,
        "dataset": 3, "deglint": 4, "plots": 5, "altimetry": 5, "live": 6, "evaluation": 7,
        "report": 8, "cli": 9, "__main__": 10}
MAX_LINES = 500
#: What benchmark history looks like in prose (STYLE.md: docstrings carry the method and its
#: sources; seeds, windows and before/after figures belong in docs/): a benchmark window
#: ("seed 223 #99", "#13 clean"), a before/after MAE, the seeds a rule was tuned or held out
#: on, a count of benchmark windows or scenes.
HISTORY = [re.compile(p) for p in (
    r"\bseeds? \d+(?: ?/ ?\d+)*,? #\d+", r"(?<![\w`])#\d+ (?:clean|glinty)\b",
    r"relative MAE[^.]*?\d(?:\.\d+)? ?%?\s*(?:->|\u2192)", r"\btuning seeds? \d+",
    r"\bheld[- ]out seeds? \d+", r"\b\d+ of \d+ (?:windows|scenes|tiles)\b")]


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports() -> dict[str, set[str]]:
    """Every module of wavealt -> the wavealt modules it imports (anywhere in its body)."""
    modules = {_module_name(p): p for p in ROOT.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        deps = set()
        is_pkg = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    pkg = name.split(".") if is_pkg else name.split(".")[:-1]
                    base = ".".join(pkg[:len(pkg) - node.level + 1] + ([base] if base else []))
                targets = [f"{base}.{a.name}" for a in node.names] + [base]
            else:
                continue
            for t in targets:
                while t and t not in modules:
                    t = t.rpartition(".")[0]
                if t and t.startswith("wavealt") and t != name:
                    deps.add(t)
        graph[name] = deps
    return graph


def _part(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_part_has_a_place_in_the_pipeline() -> None:
    assert {_part(m) for m in _imports()} <= set(RANK)


def test_data_flows_one_way() -> None:
    wrong = sorted(f"{m} -> {d}" for m, deps in _imports().items() for d in deps
                   if RANK[_part(d)] > RANK[_part(m)])
    assert wrong == []


def test_no_import_cycle() -> None:
    graph = _imports()
    state: dict[str, int] = {}
    cycles = []

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for d in sorted(graph[m]):
            if state.get(d) == 1:
                cycles.append(" -> ".join([*path[path.index(d):], d]))
            elif d not in state:
                visit(d, [*path, d])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert sum(map(len, graph.values())) > 100  # the graph was read
    assert cycles == []


def test_no_module_over_500_lines() -> None:
    long = {str(p.relative_to(ROOT)): n for p in ROOT.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert long == {}


def test_docstrings_state_the_method_not_benchmark_history() -> None:
    found = []
    for path in ROOT.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                 ast.AsyncFunctionDef)):
                doc = " ".join((ast.get_docstring(node, clean=False) or "").split())
                found += [f"{path.relative_to(ROOT)} {getattr(node, 'name', '')}: {m.group()}"
                          for pat in HISTORY for m in pat.finditer(doc)]
    assert found == [], "move these to docs/dispersion.md and point there: " + "; ".join(found)


def test_no_plain_result_file_over_100_kb() -> None:
    # docs/results/README.md: a benchmark's JSON or CSV over 100 kB is stored gzipped, so
    # that the working tree stays small enough to travel to a lent GPU machine (64 MiB)
    results = ROOT.parent.parent / "docs" / "results"
    if not results.is_dir():  # an installed package, without the repository around it
        return
    big = [p.name for p in results.iterdir()
           if p.suffix in (".json", ".csv") and p.stat().st_size > 100_000]
    assert not big, f"gzip these (docs/results/README.md): {big}"
