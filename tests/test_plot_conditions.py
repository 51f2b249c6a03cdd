"""``benchmarks/plot_conditions.py``: runs of the independent generator, pooled by label, drawn
and summarised; bad arguments refused in one line."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest
from benchmodule import bench_module


def _module():
    return bench_module("plot_conditions")


def _run_file(path: Path, records: list[dict], zipped: bool = False) -> Path:
    text = json.dumps({"benchmark": "bench_foreign_sea", "records": records}).encode()
    path.write_bytes(gzip.compress(text) if zipped else text)
    return path


def _rec(row: str, est: float, trusted: bool, h: float = 5.0) -> dict:
    return {"row": row, "est": est, "altitude_m": h, "trusted": trusted}


def test_runs_sharing_a_label_are_pooled_and_summarised(tmp_path, capsys) -> None:
    a = _run_file(tmp_path / "a.json", [_rec("blind30", 5.5, False), _rec("blind30", 5.05, True),
                                        _rec("exact10", 4.0, True)])
    b = _run_file(tmp_path / "b.json.gz", [_rec("blind30", 5.0, True)], zipped=True)
    c = _run_file(tmp_path / "c.json", [_rec("blind30", 6.0, True), _rec("blind30", 5.0, False)])
    out = tmp_path / "fig" / "conditions.png"
    mod = _module()
    assert mod.main(["--out", str(out), f"clear={a}", f"clear={b}", f"cumulus={c}"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    res = json.loads(capsys.readouterr().out)["conditions"]
    clear = res["clear"]["blind30"]
    assert clear["windows"] == 3 and clear["trusted_share"] == pytest.approx(2 / 3)
    assert clear["mae"] == pytest.approx((0.1 + 0.01 + 0.0) / 3)
    assert clear["trusted_mae"] == pytest.approx(0.005) and clear["trusted_over_10pct"] == 0
    assert res["clear"]["exact10"]["trusted_over_10pct"] == 1  # 4.0 for 5.0: -20 %, trusted
    assert res["cumulus"]["blind30"]["trusted_over_10pct"] == 1
    # the rows drawn by default are those every label holds
    assert mod.common_rows(mod.parse_runs([f"clear={a}", f"cumulus={c}"])) == ["blind30"]


@pytest.mark.parametrize(("argv", "message"), [
    (["nolabel.json"], "expected LABEL=RUN.json"),
    (["x={missing}"], "not a bench_foreign_sea.py run"),
    (["x={notrun}"], "not a bench_foreign_sea.py run"),
    (["--rows", "prior10", "x={run}"], "--rows: no run holds ['prior10']"),
])
def test_bad_arguments_are_refused_in_one_line(tmp_path, capsys, argv, message) -> None:
    run = _run_file(tmp_path / "run.json", [_rec("blind30", 5.0, True)])
    (tmp_path / "notrun.json").write_text('{"rows": []}')
    paths = {"missing": tmp_path / "missing.json", "notrun": tmp_path / "notrun.json",
             "run": run}
    argv = [arg.format(**paths) for arg in argv]
    with pytest.raises(SystemExit) as exc:
        _module().main(["--out", str(tmp_path / "f.png"), *argv])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err.strip().splitlines()[-1]
    assert not (tmp_path / "f.png").exists()
