"""The report of ``wavealt reproduce`` as markdown: the verdict first, then Table 2 against
the paper, every method against every condition, the deglint quality, figures, runs, times
and exact configs."""

from __future__ import annotations

import json
import math
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

from wavealt import __version__
from wavealt.evaluation import (
    CONDITION_LABELS,
    PAPER_TABLE2,
    fmt,
    paired_mae_difference,
    read_abs_errors,
)
from wavealt.report.scales import ReproduceScale


def _f(x: Any, signed: bool = False) -> str:
    return fmt(x, signed=signed)


def _label(c: str) -> str:
    return CONDITION_LABELS.get(c, c)


def build_report_markdown(out: Path, sc: ReproduceScale, stages: dict[str, Any],
                          evals: dict[str, dict[str, Any]], runs: dict[str, Path]) -> str:
    """The report text (markdown); figures are referenced relative to ``out``. It opens with
    the verdict (:func:`verdict_paragraph`), then the setting, then the evidence."""
    # run folders inside OUT are named relative to it (the report travels with OUT)
    evals = {k: {**e, "baseline_label": str(e.get("baseline_label", "")).replace(f"{out}/", "")}
             for k, e in evals.items()}
    errors = {name: read_abs_errors(out / "eval" / name / "predictions.csv") for name in evals
              if (out / "eval" / name / "predictions.csv").is_file()}
    stage_sum = sum(v.get("seconds") or 0.0 for k, v in stages.items()
                    if k != "total" and isinstance(v, dict))
    L: list[str] = [f"# wavealt reproduce — scale `{sc.name}`", "", f"> {sc.note}", "",
                    *verdict_paragraph(evals, errors),
                    "## Setting", "",
                    f"wavealt {__version__}, torch {torch.__version__}, numpy {np.__version__}, "
                    f"python {platform.python_version()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}. "
                    f"Total wall time of this invocation: {_f(stages.get('total', {}).get('seconds'))} s "
                    "(stages done by an earlier invocation are not re-timed; see the stage table). "
                    f"Sum of all stage times: {_f(stage_sum)} s.",
                    "",
                    "Protocol notes: splits are the manifest's 70/15/15 by sequence (seed 42), so no "
                    "frame of a test sequence is seen in training. Training augments by a random crop "
                    "*without resize* (the altitude lives in the pixel scale of the waves), H/V flips "
                    "and brightness/contrast/saturation jitter; evaluation uses the deterministic centre "
                    "crop of the same size and reports, per test sequence, the mean of its per-frame "
                    "predictions (the temporal CNN sees all frames at once, stacked as grayscale "
                    "channels). n counts sequences, as in the paper's Table 2.",
                    ""]
    main = evals.get("cnn-clean")
    L += ["## Table 2 — CNN trained on clean, tested per condition (ours vs the paper)", ""]
    if main:
        m = main["metrics"]
        n = sorted({v["n"] for v in m.values()})
        L += [f"Ours: n = {', '.join(map(str, n))} test sequences per condition; the paper: n = 30.",
              "", "| Condition | MAE ours | MAE paper | RMSE ours | RMSE paper | Bias ours | Bias paper | Max ours | Max paper | Rel. MAE ours (%) |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for c in [c for c in ("clean", "glinty", "residual") if c in m] + \
                 [c for c in m if c not in ("clean", "glinty", "residual")]:
            v, p = m[c], PAPER_TABLE2.get(c, {})
            L.append(f"| {_label(c)} | {_f(v['mae_m'])} | {_f(p.get('mae_m'))} | {_f(v['rmse_m'])} | "
                     f"{_f(p.get('rmse_m'))} | {_f(v['bias_m'], True)} | {_f(p.get('bias_m'), True)} | "
                     f"{_f(v['max_abs_err_m'])} | {_f(p.get('max_abs_err_m'))} | "
                     f"{_f(v.get('rel_mae_pct'))} |")
        if "clean" in m and "glinty" in m:
            L.append(f"| Glint penalty | {_f(m['glinty']['mae_m'] - m['clean']['mae_m'], True)} | +0.67 | | | | | | | |")
        b = main["baseline"]
        L.append(f"| Constant baseline ({main['baseline_label']}) | {_f(b['mae_m'])} | — | {_f(b['rmse_m'])} | — | "
                 f"{_f(b['bias_m'], True)} | — | {_f(b['max_abs_err_m'])} | — | {_f(b.get('rel_mae_pct'))} |")
        L += ["", "![Fig. 5](eval/cnn-clean/fig5_predicted_vs_actual.png)", "",
              "![Fig. 6](eval/cnn-clean/fig6_error_distribution.png)", ""]
    else:
        L += ["(not available: the CNN trained on clean did not run; see the stage table)", ""]

    # every method side by side
    L += side_by_side_markdown(evals, stages, errors)
    L += _deglint_quality_markdown(out / "dataset")

    # figures
    L += ["", "## Figures", ""]
    figs = [("Fig. 2 — clean vs glinty frames", "figures/fig2_examples.png"),
            ("Fig. 3 — generation steps", "figures/fig3_generation.png"),
            ("Fig. 4 — TMF decomposition", "figures/fig4_tmf_decomposition.png"),
            ("Fig. 7 — per-pixel trace and rolling minimum", "figures/fig7_pixel_trace.png")]
    for name in evals:
        figs += [(f"Fig. 5 — {evals[name]['estimator']}", f"eval/{name}/fig5_predicted_vs_actual.png"),
                 (f"Fig. 6 — {evals[name]['estimator']}", f"eval/{name}/fig6_error_distribution.png")]
    for title, rel in figs:
        if (out / rel).is_file():
            L += [f"### {title}", "", f"![{title}]({rel})", ""]
        else:
            L += [f"### {title}", "", "(not produced: its stage did not run)", ""]

    # training curves summary
    L += ["## Training runs", "", "| Run | Model | Train condition | Temporal | Best epoch | Best val MAE (m) | Train time (s) | s / epoch | Device |",
          "|---|---|---|---|---:|---:|---:|---:|---|"]
    for name, path in runs.items():
        try:
            info = json.loads((path / "config.json").read_text(encoding="utf-8"))
            hist = json.loads((path / "history.json").read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            continue
        best = min(hist, key=lambda h: h["val_mae_m"])
        t = info["train"]
        dev = info.get("device", {})
        dev_txt = f"{dev.get('name', 'cpu')} ({dev.get('device', 'cpu')}, {dev.get('precision', 'float32')}, {info.get('threads', '?')} threads)"
        total_s = sum(h["seconds"] for h in hist)
        L.append(f"| {name} | {t['model']} | {t['condition']} | {t['temporal']} | {best['epoch']} | "
                 f"{_f(best['val_mae_m'])} | {_f(total_s)} | {_f(total_s / len(hist))} | {dev_txt} |")

    # stage times and configs
    L += ["", "## Run times", "", "| Stage | Status | Seconds |", "|---|---|---:|"]
    for k, v in stages.items():
        if isinstance(v, dict):
            L.append(f"| {k} | {v.get('status', '')} | {_f(v.get('seconds'))} |")
    L += ["", "## Exact configs", "", "Dataset (`dataset/dataset.json`):", "", "```json",
          json.dumps(json.loads((out / "dataset" / "dataset.json").read_text(encoding="utf-8"))["config"],
                     indent=2) if (out / "dataset" / "dataset.json").is_file() else "{}", "```", ""]
    for name, path in runs.items():
        cfg = path / "config.json"
        if cfg.is_file():
            info = json.loads(cfg.read_text(encoding="utf-8"))
            show = {k: info[k] for k in ("train", "stats", "splits", "objective", "threads") if k in info}
            L += [f"Run `{name}` (`runs/{name}/config.json`, abridged):", "", "```json",
                  json.dumps(show, indent=2), "```", ""]
    return "\n".join(L) + "\n"



def _ordered_conditions(evals: dict[str, dict[str, Any]]) -> list[str]:
    conds: list[str] = []
    for e in evals.values():
        conds += [c for c in e["metrics"] if c not in conds]
    first = [c for c in ("clean", "glinty", "residual") if c in conds]
    return first + [c for c in conds if c not in first]


def _method_label(name: str, e: dict[str, Any]) -> str:
    if name == "constant":
        return f"constant baseline ({e['baseline_label'].removeprefix('constant ')})"
    return str(e["estimator"])


def side_by_side_markdown(evals: dict[str, dict[str, Any]],
                          stages: dict[str, Any] | None = None,
                          errors: dict[str, dict[str, dict[str, float]]] | None = None
                          ) -> list[str]:
    """Every evaluated method against every test condition (MAE, relative MAE) and the honest
    verdict against the constant baseline, as markdown lines.

    Parameters
    ----------
    evals : dict
        ``name -> {"estimator", "metrics", "baseline", "baseline_label"}`` as ``reproduce``
        records them; ``"constant"`` is the baseline.
    stages : dict, optional
        ``stages.json``; skipped stages are listed.
    errors : dict, optional
        ``name -> condition -> {sequence_id: absolute error}`` (the evaluations'
        ``predictions.csv``, :func:`wavealt.evaluation.read_abs_errors`) for the verdict's
        paired test; without them no method is judged.
    """
    conds = _ordered_conditions(evals)
    L = ["## Every method × every test condition", "",
         "Rows: the CNN per training condition (beyond the paper: its conclusion proposes "
         "training on deglinted images), the temporal CNN (all frames of a sequence stacked as "
         "channels), the physics-based dispersion altimeter (no training; the dispersion "
         "relation of the simulator's renderer), blind (it searches the camera's velocity over "
         "the water too) and with the velocity known (as a vehicle's navigation gives it), "
         "each followed by a *trusted only* row (the same estimates less those the altimeter "
         "flags itself as not trusted; n counts what is left), "
         "and the constant baseline (training-set mean "
         "altitude). Columns: the test condition (`residual` is the paper's eq. (6) glint "
         "estimate; `tmf-min`, `median`, `percentile`, `glint-mask`, `achromatic` are "
         "deglinted frames, see the deglint table below).", ""]
    for title, key, style in (("MAE (m) [bias (m)]", "mae_m", None),
                            ("Relative MAE (% of the true altitude)", "rel_mae_pct", "pct")):
        L += [f"### {title}", "",
              "| Method | " + " | ".join(_label(c) for c in conds) + " |",
              "|---|" + "---:|" * len(conds)]
        for name, e in evals.items():
            m = e["metrics"]
            n0 = next(iter(m.values()))["n"] if m else 0
            rows = [(_method_label(name, e), m, False)]
            if any("trusted" in v for v in m.values()):
                # the same estimates, less those the estimator flagged itself
                rows.append((f"{_method_label(name, e)}, trusted only",
                             {c: v["trusted"] for c, v in m.items() if "trusted" in v}, True))
            for label, mm, always_n in rows:
                cells = []
                for c in conds:
                    v = mm.get(c)
                    if v is None:
                        cells.append("—")
                        continue
                    val = v.get(key, math.nan)
                    if not math.isfinite(val):
                        cell = "—"
                    elif style is None:
                        cell = f"{_f(val)} [{_f(v['bias_m'], True)}]"
                    else:
                        cell = f"{val:.1f}"
                    if always_n or v["n"] != n0:
                        cell += f" (n={v['n']})"
                    cells.append(cell)
                L.append(f"| {label} | " + " | ".join(cells) + " |")
        L.append("")
    if stages:
        skipped = {k: v["status"] for k, v in stages.items()
                   if isinstance(v, dict) and str(v.get("status", "")).startswith("skipped")}
        if skipped:
            L += ["Not run: " + "; ".join(f"`{k}` {v}" for k, v in skipped.items()), ""]
    L += ["## What beats the constant baseline", ""]
    const = evals.get("constant")
    if not const or not conds:
        return L + ["The constant baseline was not evaluated.", ""]
    cm = const["metrics"]
    L.append("The constant baseline (always the training-set mean altitude) scores MAE "
             + ", ".join(f"{_f(cm[c]['mae_m'])} m ({_f(cm[c]['rel_mae_pct'])} %) on {_label(c)}"
                         for c in conds[:1] if c in cm)
             + " (the same on every condition: it does not look at the frames). A method "
             "beats it on a condition when the 95 % paired bootstrap interval of the "
             "difference of MAEs over the same test sequences lies wholly below zero, and "
             "is worse when it lies wholly above; otherwise this test split cannot tell them "
             "apart.")
    L.append("")
    for name, judged in baseline_verdicts(evals, errors).items():
        e = evals[name]
        parts = {k: [f"{_label(c)} ({txt})" if txt else _label(c)
                     for c, status, txt in judged if status == k]
                 for k in ("beats", "worse", "tie", "untested", "failed")}
        line = (("**beats it on " + ", ".join(parts["beats"]) + "**") if parts["beats"]
                else "**beats it nowhere**")
        for key, words in (("tie", "no clear difference on"), ("worse", "worse on"),
                           ("untested", "no per-sequence predictions to test on"),
                           ("failed", "no estimate on")):
            if parts[key]:
                line += f"; {words} {', '.join(parts[key])}"
        L.append(f"- {_method_label(name, e)}: {line}.")
    L += ["", "MAE differences are (method − constant) in metres with their 95 % interval. A "
          "model that does not beat the constant has not learnt altitude, whatever its MAE "
          "looks like next to the paper's. The dispersion altimeter measures the waves' "
          "motion from frame to frame: a temporal filter over the whole window (`median`, "
          "`percentile`, `tmf-min`) freezes that motion, so it cannot work on those "
          "conditions.", ""]
    return L


def baseline_verdicts(evals: dict[str, dict[str, Any]],
                      errors: dict[str, dict[str, dict[str, float]]] | None
                      ) -> dict[str, list[tuple[str, str, str]]]:
    """Per method (the constant baseline aside), per test condition: ``(condition, status,
    text)`` with status ``beats``, ``worse``, ``tie`` (the paired bootstrap interval of the
    MAE difference against the constant, :func:`wavealt.evaluation.paired_mae_difference`,
    holds zero), ``untested`` (no per-sequence errors) or ``failed`` (no estimate)."""

    errors = errors or {}
    conds = _ordered_conditions(evals)
    base = errors.get("constant", {})
    cm = evals["constant"]["metrics"]
    out: dict[str, list[tuple[str, str, str]]] = {}
    for name, e in evals.items():
        if name == "constant":
            continue
        judged = []
        for c in conds:
            v = e["metrics"].get(c)
            if v is None or c not in cm:
                continue
            if not math.isfinite(v["mae_m"]) or v["n"] == 0:
                judged.append((c, "failed", ""))
                continue
            mine, theirs = errors.get(name, {}).get(c), base.get(c)
            shared = sorted(set(mine or ()) & set(theirs or ()))
            if len(shared) < 2:
                judged.append((c, "untested", f"{_f(v['mae_m'])} m"))
                continue
            d = paired_mae_difference([mine[k] for k in shared], [theirs[k] for k in shared])
            status = "beats" if d["hi_m"] < 0 else "worse" if d["lo_m"] > 0 else "tie"
            judged.append((c, status, f"{_f(v['mae_m'])} m, {_f(d['diff_m'], True)} "
                                      f"[{_f(d['lo_m'], True)}, {_f(d['hi_m'], True)}] m, "
                                      f"n={d['n']}"))
        out[name] = judged
    return out


def verdict_paragraph(evals: dict[str, dict[str, Any]],
                      errors: dict[str, dict[str, dict[str, float]]] | None) -> list[str]:
    """The report's opening verdict, one short paragraph: which methods beat the constant
    baseline where, by the paired bootstrap of :func:`baseline_verdicts` (a difference whose
    95 % interval holds zero is no difference on this many test sequences)."""
    if "constant" not in evals:
        return []
    winners, others = [], []
    n_seq = sorted({v["n"] for v in evals["constant"]["metrics"].values()})
    for name, judged in baseline_verdicts(evals, errors).items():
        label = _method_label(name, evals[name])
        beats = [_label(c) for c, status, _ in judged if status == "beats"]
        worse = [_label(c) for c, status, _ in judged if status == "worse"]
        if beats:
            text = f"{label} on {_join(beats)}"
            if worse:
                text += f" (but is worse on {_join(worse)})"
            winners.append(text)
        else:
            others.append(label + (f" (worse on {_join(worse)})" if worse else ""))
    n_txt = " or ".join(map(str, n_seq)) or "no"
    parts = [f"Judged against the constant baseline (always the training-set mean altitude) "
             f"by a 95 % paired bootstrap interval of the MAE difference over the same {n_txt} "
             f"test sequences: "]
    parts.append(("beats it " + "; ".join(winners) + ". ") if winners
                 else "no method beats it on any condition. ")
    if others:
        parts.append(f"No clear win for {_join(others)}: on this test split their errors "
                     "cannot be told apart from the baseline's, or are larger.")
    return ["## Verdict", "", "".join(parts).rstrip(), ""]


def _join(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _deglint_quality_markdown(ds_path: Path) -> list[str]:
    """The measured deglint quality table of the dataset (``deglint_table.md``), if any."""
    table = ds_path / "deglint_table.md"
    if not table.is_file():
        return []
    return ["## Deglint quality (every frame of the dataset vs `clean/`)", "",
            "Written by `wavealt deglint` into `dataset/deglint_table.md`; `glinty` is the "
            "untouched input. `residual` (the paper's eq. (6)) is the glint estimate, not a "
            "clean-frame estimate, so its scores against clean are low by design.", "",
            *table.read_text(encoding="utf-8").rstrip("\n").split("\n"), ""]


__all__ = ["baseline_verdicts", "build_report_markdown", "side_by_side_markdown",
           "verdict_paragraph"]
