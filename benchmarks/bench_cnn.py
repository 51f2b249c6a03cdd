"""CNN speed: training and inference images/s at 128² and 224² (a few batches), JSON out.

    python benchmarks/bench_cnn.py [--model resnet50] [--batches 3] [--batch-size 16]
                                   [--reproduce OUT]   # also time `reproduce --scale quick`
"""

from __future__ import annotations

import argparse
import json
import time

import torch

from wavealt.altimetry.cnn import count_parameters, create_model
from wavealt.altimetry.data import set_num_threads


def _rate(model: torch.nn.Module, size: int, batch: int, batches: int, train: bool) -> float:
    x = torch.rand(batch, 3, size, size)
    y = torch.rand(batch)
    opt = torch.optim.Adam(model.parameters(), lr=1e-4)
    model.train(train)

    def step() -> None:
        if train:
            loss = torch.nn.functional.mse_loss(model(x), y)
            opt.zero_grad()
            loss.backward()
            opt.step()
        else:
            with torch.no_grad():
                model(x)

    step()  # warm-up
    t0 = time.perf_counter()
    for _ in range(batches):
        step()
    return batch * batches / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--model", default="resnet50")
    ap.add_argument("--batches", type=int, default=3)
    ap.add_argument("--batch-size", type=int, default=16)
    ap.add_argument("--sizes", default="128,224")
    ap.add_argument("--reproduce", default=None, help="also time `reproduce --scale quick` into this folder")
    a = ap.parse_args()
    threads = set_num_threads()
    torch.manual_seed(0)
    model = create_model(a.model)
    out = {"model": a.model, "parameters": count_parameters(model), "threads": threads,
           "batch_size": a.batch_size, "batches": a.batches, "torch": torch.__version__}
    for s in (int(v) for v in a.sizes.split(",")):
        out[f"train_images_per_s_{s}"] = round(_rate(model, s, a.batch_size, a.batches, True), 2)
        out[f"infer_images_per_s_{s}"] = round(_rate(model, s, a.batch_size, a.batches, False), 2)
    if a.reproduce:
        from wavealt.report import reproduce

        t0 = time.perf_counter()
        reproduce(a.reproduce, scale="quick", progress=False)
        out["reproduce_quick_wall_s"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
