"""Sharded datasets: the WebDataset layout, round trips through an fsspec in-memory
filesystem, through `train`, `evaluate` and the torch stream; the overwrite rule."""

from __future__ import annotations

import io
import json
import shutil
import tarfile
import uuid
from pathlib import Path

import fsspec
import numpy as np
import pytest
import torch

from wavealt.altimetry.data import TrainConfig
from wavealt.altimetry.stream import SequenceStream
from wavealt.altimetry.train import train
from wavealt.dataset import Dataset, ShardDataset, manifest_row, open_dataset, simulate_dataset
from wavealt.sim.config import preset_config

CFG = dict(sequences=12, size=48, frames=4)  # the config of conftest's tiny_dataset
TINY = dict(model="resnet-tiny", batch_size=8, lr=3e-3, jitter=0.0, threads=1)


def tree_bytes(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("folder") / "ds"
    simulate_dataset(root, preset_config("paper", **CFG), save_surface=True, progress=False)
    return root


@pytest.fixture(scope="module")
def memory_shards():
    """The same dataset as shards of 5 sequences in fsspec's in-memory filesystem."""
    url = f"memory://wavealt-{uuid.uuid4().hex}/ds"
    simulate_dataset(url, preset_config("paper", **CFG), format="shards", shard_size=5,
                     save_surface=True, progress=False)
    yield url
    fs, path = fsspec.core.url_to_fs(url)
    fs.rm(path.rsplit("/", 1)[0], recursive=True)


def test_shards_hold_the_folder_bytes_in_the_webdataset_layout(folder, memory_shards):
    fs, path = fsspec.core.url_to_fs(memory_shards)
    assert sorted(p.rsplit("/", 1)[1] for p in fs.find(path)) == [
        "dataset.json", "manifest.csv", "shard-000000.tar", "shard-000001.tar", "shard-000002.tar"]
    assert fs.cat_file(f"{path}/manifest.csv") == (folder / "manifest.csv").read_bytes()
    info = json.loads(fs.cat_file(f"{path}/dataset.json"))
    assert info["storage"] == {"format": "shards", "shard_size": 5, "shards": 3, "surface": True}
    assert info["config"] == json.loads((folder / "dataset.json").read_text())["config"]
    ds = Dataset(folder)
    seen = []
    for k in range(3):
        with tarfile.open(fileobj=io.BytesIO(fs.cat_file(f"{path}/shards/shard-{k:06d}.tar"))) as tar:
            members = tar.getmembers()
            assert {(m.mtime, m.mode, m.uname) for m in members} == {(0, 0o444, "wavealt")}
            for m in members:
                key, _, suffix = m.name.partition(".")
                data = tar.extractfile(m).read()
                if suffix == "json":
                    assert json.loads(data) == manifest_row(ds.record(key))
                elif suffix == "surface.npz":
                    a, b = np.load(io.BytesIO(data)), np.load(folder / "surface" / f"{key}.npz")
                    assert all(np.array_equal(a[f], b[f]) for f in b.files)
                else:
                    cond, t, _ = suffix.split(".")
                    assert data == (folder / cond / key / f"frame_{t}.png").read_bytes()
                seen.append(key)
    keys = list(dict.fromkeys(seen))
    assert keys == [r.sequence_id for r in ds.records]  # one key per sequence, in order
    assert len(seen) == 12 * (1 + 2 * 4 + 1)  # json, 4 clean, 4 glinty, surface


def test_webdataset_reads_the_shards(tmp_path):
    from webdataset.tariterators import group_by_keys, tar_file_expander

    simulate_dataset(tmp_path / "ds", preset_config("paper", sequences=3, size=40, frames=3),
                     format="shards", shard_size=2, progress=False)
    samples = []
    for k in range(2):
        url = str(tmp_path / "ds" / "shards" / f"shard-{k:06d}.tar")
        with open(url, "rb") as fh:
            samples += list(group_by_keys(tar_file_expander([{"url": url, "stream": fh}])))
    assert [s["__key__"] for s in samples] == ["seq_00000", "seq_00001", "seq_00002"]
    assert set(samples[0]) - {"__key__", "__url__"} == {
        "json", *(f"{c}.{t:03d}.png" for c in ("clean", "glinty") for t in range(3))}
    assert json.loads(samples[2]["json"])["sequence_id"] == "seq_00002"


def test_shard_dataset_reads_like_the_folder(folder, memory_shards):
    a, b = Dataset(folder), open_dataset(memory_shards)
    assert isinstance(b, ShardDataset) and b.storage == "shards"
    assert b.records == a.records and b.config == a.config
    assert b.conditions == ["clean", "glinty", "surface"]
    for cond in ("clean", "glinty"):
        streamed = dict((r.sequence_id, f) for r, f in b.iter_sequences(cond))
        assert list(streamed) == [r.sequence_id for r in a.records]
        for r in a.records:
            want = a.read_frames(cond, r.sequence_id)
            assert np.array_equal(streamed[r.sequence_id], np.round(want * 255).astype(np.uint8))
            assert np.array_equal(b.read_frames(cond, r.sequence_id), want)
    with pytest.raises(FileNotFoundError, match="has no condition 'residual'.*need a dataset folder"):
        b.read_frames("residual", "seq_00000")
    with pytest.raises(ValueError, match="no sequence 'seq_00099'"):
        b.read_frames("clean", "seq_00099")


def test_train_and_evaluate_read_shards_as_the_folder(folder, memory_shards, tmp_path, run_cli):
    cfg = TrainConfig(condition="clean", epochs=1, **TINY)
    ra = train(folder, tmp_path / "ra", cfg, progress=False)
    rb = train(memory_shards, tmp_path / "rb", cfg, progress=False)
    strip = lambda h: [{k: v for k, v in e.items() if "seconds" not in k} for e in h]  # noqa: E731
    assert strip(ra["history"]) == strip(rb["history"])
    sa = torch.load(tmp_path / "ra" / "last.pt", weights_only=False)["model"]
    sb = torch.load(tmp_path / "rb" / "last.pt", weights_only=False)["model"]
    assert all(torch.equal(sa[k], sb[k]) for k in sa)
    assert json.loads((tmp_path / "rb" / "config.json").read_text())["dataset"] == memory_shards
    for ds, out in ((str(folder), "ea"), (memory_shards, "eb")):
        code, _, err = run_cli(["evaluate", ds, "--estimator", f"cnn:{tmp_path / 'ra'}",
                                "--conditions", "clean,glinty", "--device", "cpu",
                                "--out", str(tmp_path / out)])
        assert code == 0, err
    assert ((tmp_path / "ea" / "metrics.json").read_bytes()
            == (tmp_path / "eb" / "metrics.json").read_bytes())
    # every condition by default: the frames, not the surfaces (--save-surface)
    code, _, err = run_cli(["evaluate", memory_shards, "--estimator", "constant",
                            "--out", str(tmp_path / "ec")])
    assert code == 0, err
    assert sorted(json.loads((tmp_path / "ec" / "metrics.json").read_text())) == ["clean", "glinty"]


def test_deglint_says_it_needs_a_folder(memory_shards, tmp_path, run_cli):
    simulate_dataset(tmp_path / "sh", preset_config("paper", sequences=2, size=40, frames=3),
                     format="shards", progress=False)
    before = tree_bytes(tmp_path / "sh")
    for ds in (str(tmp_path / "sh"), memory_shards):
        code, _, err = run_cli(["deglint", ds, "--no-figures"])
        assert code == 2 and err.count("\n") == 1, err
        assert "`wavealt deglint` needs a dataset folder" in err and "--format folder" in err
    assert tree_bytes(tmp_path / "sh") == before


def test_overwrite_rule_across_formats(folder, tmp_path, run_cli):
    shutil.copytree(folder, tmp_path / "f")
    before = tree_bytes(tmp_path / "f")
    argv = ["simulate", str(tmp_path / "f"), "--sequences", "12", "--size", "48", "--frames",
            "4", "--save-surface", "--no-figures"]
    code, _, err = run_cli([*argv, "--format", "shards"])
    assert code == 2 and "holds a dataset folder (--format folder)" in err, err
    assert tree_bytes(tmp_path / "f") == before
    sh = ["simulate", str(tmp_path / "s"), "--sequences", "3", "--size", "40", "--frames", "3",
          "--format", "shards", "--shard-size", "2", "--no-figures"]
    assert run_cli(sh)[0] == 0
    before = tree_bytes(tmp_path / "s")
    for extra, match in ((["--shard-size", "3"], "holds shards of 2 sequences"),
                         (["--shard-size", "2", "--save-surface"], "with surfaces")):
        code, _, err = run_cli([*sh[:-3], *extra, "--no-figures"])
        assert code == 2 and err.count("\n") == 1 and match in err, err
    code, _, err = run_cli(["simulate", "memory://x/ds", "--no-figures"])
    assert code == 2 and "--format folder writes a local folder" in err, err
    code, _, err = run_cli(["simulate", "nosuchfs://b/ds", "--format", "shards", "--no-figures"])
    assert code == 2 and "cannot open nosuchfs://b/ds" in err, err
    assert tree_bytes(tmp_path / "s") == before
    (tmp_path / "s" / "shards" / "shard-000001.tar").write_bytes(b"not a tar")
    with pytest.raises(ValueError, match="shard-000001.tar is not a readable tar file"):
        list(open_dataset(tmp_path / "s").iter_sequences("clean"))
    (tmp_path / "s" / "shards" / "shard-000001.tar").unlink()
    with pytest.raises(FileNotFoundError, match="shard-000001.tar of dataset .* is missing"):
        open_dataset(tmp_path / "s").read_frames("glinty", "seq_00002")


def test_sequence_stream_deals_shards_to_ranks_and_workers(folder, memory_shards, tmp_path):
    ids = {r.sequence_id for r in Dataset(folder).split("train")}
    for ds in (str(folder), memory_shards):
        parts = [[s["sequence_id"] for s in SequenceStream(ds, split="train", rank=r, world_size=2)]
                 for r in range(2)]
        assert not set(parts[0]) & set(parts[1]) and set(parts[0]) | set(parts[1]) == ids
    stream = SequenceStream(memory_shards, condition="glinty", split="val")
    item = next(iter(stream))
    want = Dataset(folder).read_frames("glinty", item["sequence_id"])
    assert np.array_equal(item["frames"], np.round(want * 255).astype(np.uint8))
    assert item["altitude_m"] == np.float32(Dataset(folder).record(item["sequence_id"]).altitude_m)
    simulate_dataset(tmp_path / "sh", preset_config("paper", **CFG), format="shards",
                     shard_size=2, progress=False)
    loader = torch.utils.data.DataLoader(SequenceStream(tmp_path / "sh", split="train"),
                                         batch_size=None, num_workers=2)
    got = [s["sequence_id"] for s in loader]
    assert sorted(got) == sorted(ids) and len(got) == len(ids)
    with pytest.raises(ValueError, match="rank must be in"):
        SequenceStream(folder, rank=2, world_size=2)
