"""reproduce's report pieces and the CLI of train/evaluate (the full pipeline is too slow for
the default suite; it is exercised by ``benchmarks/bench_cnn.py --reproduce``)."""

from __future__ import annotations

import base64
import json

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
