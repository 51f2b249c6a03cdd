"""The independent sea generator of ``benchmarks/bench_foreign_sea.py`` (the altimeter's
out-of-distribution check): its physics self-checks pass, and a one-clip run reports every
window of its rows."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_foreign_sea.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                          timeout=300)


def test_the_generators_physics_checks_pass() -> None:
    """One wave's phase step, no advection when the current equals the drift, the slope
    variance of the spectrum, the altimeter's velocity convention, the tilted camera's
    rays (level: the nadir crop itself; tilted: the axis meets the sea H tan(tilt) away),
    and the CIE clear sky's luminance against the standard's formula."""
    res = _run("--self-check")
    assert res.returncode == 0, res.stdout + res.stderr[-2000:]
    lines = res.stdout.splitlines()
    assert sum(line.startswith("PASS") for line in lines) == 6
    assert not any(line.startswith("FAIL") for line in lines)


def test_a_one_clip_run_reports_every_window(tmp_path) -> None:
    out = tmp_path / "run.json"
    res = _run("--clips", "1", "--seed", "5", "--rows", "exact10,prior10", "--out", str(out))
    assert res.returncode == 0, res.stderr[-2000:]
    summary = json.loads(res.stdout)
    saved = json.loads(out.read_text())
    assert saved["metrics"] == summary["metrics"]
    assert [(r["row"], r["start"]) for r in saved["records"]] == [
        ("exact10", 0), ("exact10", 10), ("exact10", 20),
        ("prior10", 0), ("prior10", 10), ("prior10", 20)]
    assert summary["metrics"]["exact10"]["all"]["windows"] == 3
    for row in ("exact10", "prior10"):
        stats = summary["metrics"][row]["all"]
        untrusted = sum(not r["trusted"] for r in saved["records"] if r["row"] == row)
        assert sum(stats["untrusted_reasons"].values()) == untrusted
    bad = _run("--clips", "1", "--rows", "blind99")
    assert bad.returncode == 2 and "unknown rows: blind99" in bad.stderr


def test_a_tilted_run_records_each_clips_tilt_and_refuses_a_bad_one(tmp_path) -> None:
    out = tmp_path / "tilted.json"
    res = _run("--clips", "2", "--seed", "5", "--rows", "exact10", "--max-tilt-deg", "15",
               "--out", str(out))
    assert res.returncode == 0, res.stderr[-2000:]
    saved = json.loads(out.read_text())
    assert saved["max_tilt_deg"] == 15.0
    tilts = {r["seed"]: r["tilt_deg"] for r in saved["records"]}
    assert sorted(tilts) == [5, 6] and all(0.0 < t <= 15.0 for t in tilts.values())
    bad = _run("--clips", "1", "--max-tilt-deg", "45")
    assert bad.returncode == 2 and "--max-tilt-deg must be within 0-30; got 45" in bad.stderr


def test_a_cie_sky_run_changes_the_radiance_and_nothing_else(tmp_path) -> None:
    """``--sky cie`` draws the same scenes (the sky draws nothing) and renders other frames;
    an unknown sky is refused."""
    runs = {}
    for sky in ("gradient", "cie"):
        out = tmp_path / f"{sky}.json"
        res = _run("--clips", "1", "--seed", "5", "--rows", "exact10", "--sky", sky,
                   "--save-clips", str(tmp_path / sky), "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        assert json.loads(out.read_text())["sky"] == sky
        runs[sky] = json.loads((tmp_path / sky / "clip5.json").read_text())
    keep = {k: v for k, v in runs["gradient"].items() if k not in ("sky", "texture_dn",
                                                                     "noise_dn")}
    assert keep == {k: runs["cie"][k] for k in keep}
    assert runs["cie"]["sky"] == "cie" and runs["cie"]["texture_dn"] != runs["gradient"][
        "texture_dn"]
    bad = _run("--clips", "1", "--sky", "overcast")
    assert bad.returncode == 2 and "invalid choice: 'overcast'" in bad.stderr
