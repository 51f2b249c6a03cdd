"""reproduce's report pieces, the whole pipeline at a tiny registered scale, and the CLI of
train/evaluate (the quick scale itself is timed by ``benchmarks/bench_cnn.py --reproduce``)."""

from __future__ import annotations

import base64
import json
import math

import numpy as np
import pytest

from wavealt.cli import main
from wavealt.report import SCALES, markdown_to_html, reproduce


def test_html_is_self_contained(tmp_path) -> None:
    png = base64.b64decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg==")
    (tmp_path / "f.png").write_bytes(png)
    md = "# Title\n\n| a | b |\n|---|---:|\n| x<y | 1 |\n\n![cap](f.png)\n\n```json\n{}\n```\n"
    page = markdown_to_html(md, base=tmp_path)
    assert "<h1>Title</h1>" in page
    assert "<td>x&lt;y</td>" in page
    assert "data:image/png;base64," + base64.b64encode(png).decode() in page
    assert 'src="f.png"' not in page


def test_html_renders_lists_emphasis_and_code_not_their_markup(tmp_path) -> None:
    md = ("Intro with *emphasis*, **strong** and `code`.\n\n- first item\n- second item\n\n"
          "![missing](nope.png)\n")
    page = markdown_to_html(md, base=tmp_path)
    assert "<em>emphasis</em>" in page and "<strong>strong</strong>" in page
    assert "<code>code</code>" in page
    assert "<ul>" in page and "<li>first item</li>" in page
    assert "- first" not in page and "*emphasis*" not in page
    assert 'src="nope.png"' in page  # a missing figure keeps its link, no crash


def test_reproduce_resumes_its_own_scale_only(tmp_path, run_cli) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "reproduce.json").write_text('{"scale": "quick"}')
    code, _, err = run_cli(["reproduce", str(out), "--scale", "paper"])
    assert code == 2 and err.count("\n") == 1
    assert f"OUT {out} holds a `reproduce --scale quick` run" in err and "--scale paper" in err
    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "notes.txt").write_text("keep")
    code, _, err = run_cli(["reproduce", str(junk)])
    assert code == 2 and "holds no reproduce run" in err
    assert sorted(p.name for p in junk.iterdir()) == ["notes.txt"]


def test_scales_label_quick_as_not_the_paper() -> None:
    assert SCALES["paper"].model == "resnet50" and SCALES["paper"].size == 224
    assert SCALES["paper"].epochs == 30 and SCALES["paper"].batch_size == 32
    assert "not the paper's protocol" in SCALES["quick"].note
    with pytest.raises(ValueError, match="scale must be one of"):
        reproduce("unused", scale="huge")


def test_cli_train_and_evaluate(tiny_dataset, tmp_path, capsys) -> None:
    run = tmp_path / "run"
    main(["train", str(tiny_dataset), "--out", str(run), "--condition", "bright",
          "--model", "resnet-tiny", "--epochs", "1", "--batch-size", "8"])
    assert (run / "best.pt").is_file()
    main(["evaluate", str(tiny_dataset), "--estimator", f"constant:{run}",
          "--conditions", "clean,glinty", "--out", str(tmp_path / "ev")])
    assert set(json.loads((tmp_path / "ev" / "metrics.json").read_text())) == {"clean", "glinty"}
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", str(tiny_dataset), "--estimator", "nope", "--out", str(tmp_path / "x")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("wavealt: error: unknown estimator 'nope'") and err.count("\n") == 1


def _ev(estimator: str, maes: dict[str, float], label: str = "") -> dict:
    return {"estimator": estimator, "baseline_label": label,
            "metrics": {c: {"n": 5, "mae_m": m, "rmse_m": m, "bias_m": -m / 2,
                            "max_abs_err_m": 2 * m, "rel_mae_pct": 10 * m}
                        for c, m in maes.items()}}


def test_side_by_side_lists_every_method_and_condition_and_judges_the_baseline() -> None:
    from wavealt.report import side_by_side_markdown

    evals = {
        "cnn-clean": _ev("cnn (resnet-small, trained on clean)",
                         {"clean": 1.0, "glinty": 1.9, "residual": 3.0}),
        "dispersion": _ev("dispersion (gravity)", {"clean": 0.1, "glinty": math.nan}),
        "constant": _ev("constant", {"clean": 2.0, "glinty": 2.0, "residual": 2.0},
                        label="constant 3.00 m (dataset train split)"),
    }
    evals["dispersion"]["metrics"]["glinty"]["n"] = 0
    rng = np.random.default_rng(0)
    ids = [f"s{i}" for i in range(20)]
    base = {c: dict(zip(ids, rng.uniform(1.5, 2.5, 20))) for c in ("clean", "glinty", "residual")}
    errors = {"constant": base,
              # clean: every sequence 1 m better; glinty: 0.1 m better, noise of +-1 m
              "cnn-clean": {"clean": {k: v - 1.0 for k, v in base["clean"].items()},
                            "glinty": {k: max(0.0, v - 0.1 + rng.uniform(-1, 1))
                                       for k, v in base["glinty"].items()},
                            "residual": {k: v + 1.0 for k, v in base["residual"].items()}},
              "dispersion": {"clean": {k: 0.1 for k in ids}}}
    md = "\n".join(side_by_side_markdown(evals, errors=errors))
    mae_table = md.split("### Relative MAE")[0]
    rows = [r for r in mae_table.splitlines() if r.startswith("| ")]
    assert rows[0] == "| Method | Clean | Glinty | Residual (TMF) |"
    assert len(rows) == 1 + len(evals)
    assert "| constant baseline (3.00 m (dataset train split)) | 2.00 [-1.00]" in md
    assert "| dispersion (gravity) | 0.10 [-0.05] | — (n=0) | — |" in md
    rel = md.split("### Relative MAE")[1].split("##")[0]
    assert "| cnn (resnet-small, trained on clean) | 10.0 | 19.0 | 30.0 |" in rel
    verdict = md.split("## What beats the constant baseline")[1]
    cnn = next(line for line in verdict.splitlines() if line.startswith("- cnn"))
    # clean: 1 m better on every sequence; glinty: 0.1 m within noise; residual: 1 m worse
    assert cnn.startswith("- cnn (resnet-small, trained on clean): **beats it on Clean (1.00 m, "
                          "-1.00 [-1.00, -1.00] m, n=20)**; no clear difference on Glinty")
    assert "; worse on Residual (TMF) (3.00 m, +1.00 [+1.00, +1.00] m, n=20)." in cnn
    assert ("dispersion (gravity): **beats it on Clean (0.10 m, " in verdict
            and "; no estimate on Glinty." in verdict)
    assert not any(line.startswith("- constant") for line in verdict.splitlines())
    # without per-sequence errors nothing is judged
    bare = "\n".join(side_by_side_markdown(evals)).split("## What beats")[1]
    assert "**beats it on" not in bare and "no per-sequence predictions to test on Clean" in bare


def test_report_opens_with_a_verdict_paragraph_from_the_paired_test() -> None:
    from wavealt.report import verdict_paragraph

    ids = [f"s{i}" for i in range(20)]
    rng = np.random.default_rng(3)
    base = dict(zip(ids, rng.uniform(1.5, 2.5, 20)))
    evals = {"cnn-clean": _ev("cnn (trained on clean)", {"clean": 1.9, "glinty": 1.0}),
             "dispersion": _ev("dispersion (gravity)", {"clean": 0.5, "glinty": 3.0}),
             "constant": _ev("constant", {"clean": 2.0, "glinty": 2.0}, label="constant 3 m")}
    for e in evals.values():
        for v in e["metrics"].values():
            v["n"] = 20
    errors = {"constant": {"clean": base, "glinty": base},
              # a 0.1 m lower median-like MAE inside +-1 m noise: not a win
              "cnn-clean": {"clean": {k: max(0.0, v - 0.1 + rng.uniform(-1, 1))
                                      for k, v in base.items()},
                            "glinty": {k: v - 1.0 for k, v in base.items()}},
              "dispersion": {"clean": {k: v - 1.5 for k, v in base.items()},
                             "glinty": {k: v + 1.0 for k, v in base.items()}}}
    lines = verdict_paragraph(evals, errors)
    assert lines[0] == "## Verdict" and len(lines) == 4  # heading, blank, one paragraph, blank
    text = lines[2]
    assert "95 % paired bootstrap interval of the MAE difference over the same 20 test" in text
    assert "cnn (trained on clean) on Glinty" in text
    assert "dispersion (gravity) on Clean (but is worse on Glinty)" in text
    assert "Clean" not in text.split("cnn (trained on clean) on ")[1].split(";")[0]


def test_paired_bootstrap_of_the_mae_difference() -> None:
    from wavealt.evaluation import paired_mae_difference

    rng = np.random.default_rng(1)
    hard = rng.uniform(0, 5, 25)  # what both methods share does not widen the interval
    d = paired_mae_difference(hard + 0.2 + rng.normal(0, 0.05, 25), hard)
    assert d["n"] == 25 and 0.15 < d["lo_m"] < d["diff_m"] < d["hi_m"] < 0.25
    same = paired_mae_difference(hard + rng.normal(0, 0.5, 25), hard)
    assert same["lo_m"] < 0 < same["hi_m"]
    nan = paired_mae_difference([1.0, np.nan, 2.0], [0.5, 0.5, 0.5])
    assert nan["n"] == 2
    with pytest.raises(ValueError, match="same sequences"):
        paired_mae_difference([1.0], [1.0, 2.0])


def test_side_by_side_adds_a_trusted_only_row_for_self_grading_methods() -> None:
    from wavealt.report import side_by_side_markdown

    evals = {"dispersion": _ev("dispersion (gravity, blind)", {"clean": 0.8, "glinty": 1.2}),
             "constant": _ev("constant", {"clean": 1.0, "glinty": 1.0}, label="constant 3 m")}
    m = evals["dispersion"]["metrics"]
    m["clean"]["flagged"], m["clean"]["trusted"] = 3, {**_ev("", {"c": 0.05})["metrics"]["c"],
                                                       "n": 2}
    m["glinty"]["flagged"], m["glinty"]["trusted"] = 5, {**_ev("", {"c": math.nan})["metrics"]["c"],
                                                         "n": 0}
    md = "\n".join(side_by_side_markdown(evals))
    mae_table = md.split("### Relative MAE")[0]
    assert ("| dispersion (gravity, blind), trusted only | 0.05 [-0.03] (n=2) | — (n=0) |"
            in mae_table)
    assert "| dispersion (gravity, blind) | 0.80 [-0.40] | 1.20 [-0.60] |" in mae_table
    rel = md.split("### Relative MAE")[1].split("##")[0]
    assert "| dispersion (gravity, blind), trusted only | 0.5 (n=2) | — (n=0) |" in rel
    # the verdict against the baseline counts every sequence, flagged or not
    ids = [f"s{i}" for i in range(10)]
    errors = {"constant": {c: dict.fromkeys(ids, 1.0) for c in ("clean", "glinty")},
              "dispersion": {"clean": dict.fromkeys(ids, 0.8), "glinty": dict.fromkeys(ids, 1.2)}}
    verdict = "\n".join(side_by_side_markdown(evals, errors=errors)).split(
        "## What beats the constant baseline")[1]
    assert ("- dispersion (gravity, blind): **beats it on Clean (0.80 m, -0.20 [-0.20, -0.20] m, "
            "n=10)**; worse on Glinty (1.20 m, +0.20 [+0.20, +0.20] m, n=10).") in verdict
    assert "trusted only" not in verdict


def test_reproduce_end_to_end_at_a_tiny_scale(tmp_path, monkeypatch) -> None:
    from wavealt.report import ReproduceScale

    tiny = ReproduceScale(
        name="tiny", sequences=12, size=48, frames=4, model="resnet-tiny", epochs=1,
        batch_size=8, lr=1e-3, frames_per_sequence=2, train_conditions=("clean", "residual"),
        temporal_conditions=("clean",), note="TINY TEST SCALE", deglint_methods=("tmf", "tmf-min"),
        threads=1)
    monkeypatch.setitem(SCALES, "tiny", tiny)
    out = tmp_path / "out"
    md_path, html_path = reproduce(out, scale="tiny", progress=False)
    md = md_path.read_text()
    assert json.loads((out / "reproduce.json").read_text()) == {"scale": "tiny"}
    stages = json.loads((out / "stages.json").read_text())
    assert all(v["status"] == "done" for v in stages.values()), stages
    rows = {line.split(" | ")[0] for line in md.split("### MAE (m)")[1].split("###")[0].splitlines()
            if line.startswith("| ") and not line.startswith("| Method")}
    const = {r for r in rows if r.startswith("| constant baseline (")}
    assert len(const) == 1 and rows - const == {
        "| cnn (resnet-tiny, trained on clean)", "| cnn (resnet-tiny, trained on residual)",
        "| cnn (temporal resnet-tiny, trained on clean)", "| dispersion (gravity, blind)",
        "| dispersion (gravity, blind), trusted only", "| dispersion (gravity, velocity known)",
        "| dispersion (gravity, velocity known), trusted only"}
    header = next(line for line in md.splitlines() if line.startswith("| Method |"))
    assert header == "| Method | Clean | Glinty | Residual (TMF) | tmf-min |"
    assert "## What beats the constant baseline" in md and "## Deglint quality" in md
    assert md.split("\n## ")[1].startswith("Verdict")  # the report opens with its verdict
    assert "-0.00" not in md
    assert (out / "figures" / "fig4_tmf_decomposition.png").is_file()
    assert "data:image/png;base64," in html_path.read_text()
    # a re-run redoes nothing and gives the same tables
    again = reproduce(out, scale="tiny", progress=False)[0].read_text()
    assert again.split("### MAE (m)")[1].split("## Figures")[0] == \
        md.split("### MAE (m)")[1].split("## Figures")[0]
