"""Simulating on a Dask cluster: real LocalClusters on the loopback, the same bytes as one
process, resume, and the one-line errors of bad --cluster / --scheduler input."""

from __future__ import annotations

import shutil
import socket
from pathlib import Path

import pytest

import wavealt.sim.cluster as cluster_mod
from wavealt.dataset import simulate_dataset
from wavealt.sim.cluster import runner_spec
from wavealt.sim.config import preset_config

SMALL = dict(sequences=5, size=48, frames=4)


def tree_bytes(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """The single-process datasets: a folder and shards of 2 (both with surfaces)."""
    root = tmp_path_factory.mktemp("ref")
    cfg = preset_config("paper", **SMALL)
    simulate_dataset(root / "folder", cfg, save_surface=True, progress=False)
    simulate_dataset(root / "shards", cfg, format="shards", shard_size=2, save_surface=True,
                     progress=False)
    return root


@pytest.fixture(scope="module")
def scheduler():
    """An independent 2-worker Dask cluster on the loopback, for --scheduler."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cl:
        yield cl.scheduler_address


def test_local_cluster_writes_the_single_process_bytes(tmp_path, references, run_cli):
    code, out, err = run_cli(["simulate", str(tmp_path / "c"), "--sequences", "5", "--size", "48",
                              "--frames", "4", "--save-surface", "--no-figures",
                              "--cluster", "local:2"])
    assert code == 0, err
    assert tree_bytes(tmp_path / "c") == tree_bytes(references / "folder")


def test_scheduler_writes_the_single_process_bytes_and_resumes(tmp_path, references, scheduler):
    assert scheduler.startswith("tcp://127.0.0.1:")
    cfg = preset_config("paper", **SMALL)
    simulate_dataset(tmp_path / "s", cfg, scheduler=scheduler, format="shards", shard_size=2,
                     save_surface=True, progress=False)
    assert tree_bytes(tmp_path / "s") == tree_bytes(references / "shards")
    # an interrupted run: a shard lost, a temporary file left behind; the kept shards stay
    (tmp_path / "s" / "shards" / "shard-000001.tar").unlink()
    (tmp_path / "s" / "shards" / ".shard-000001.tar.xyz").write_bytes(b"half")
    kept = tmp_path / "s" / "shards" / "shard-000000.tar"
    mtime = kept.stat().st_mtime_ns
    simulate_dataset(tmp_path / "s", cfg, scheduler=scheduler, format="shards", shard_size=2,
                     save_surface=True, progress=False)
    assert kept.stat().st_mtime_ns == mtime
    got = {k: v for k, v in tree_bytes(tmp_path / "s").items() if ".xyz" not in k}
    assert got == tree_bytes(references / "shards")
    # a dataset folder resumed on the cluster, after a crash that lost one sequence
    shutil.copytree(references / "folder", tmp_path / "f")
    shutil.rmtree(tmp_path / "f" / "glinty" / "seq_00003")
    simulate_dataset(tmp_path / "f", cfg, scheduler=scheduler, save_surface=True, progress=False)
    assert tree_bytes(tmp_path / "f") == tree_bytes(references / "folder")


def test_parts_of_a_job_array_write_the_whole_dataset(tmp_path, references, run_cli):
    argv = ["simulate", str(tmp_path / "a"), "--sequences", "5", "--size", "48", "--frames", "4",
            "--save-surface", "--no-figures", "--format", "shards", "--shard-size", "2"]
    for i in (2, 0):
        code, out, err = run_cli([*argv, "--part", f"{i}/3"])
        assert code == 0 and f"part {i}/3 done" in out, err
    names = sorted(p.name for p in (tmp_path / "a" / "shards").iterdir())
    assert names == ["shard-000000.tar", "shard-000002.tar"]
    assert run_cli([*argv, "--part", "1/3"])[0] == 0
    assert run_cli(argv)[0] == 0  # the check without --part: whole, nothing to do
    assert tree_bytes(tmp_path / "a") == tree_bytes(references / "shards")
    for bad in ("3/3", "1", "-1/2", "a/b"):
        code, _, err = run_cli([*argv, "--part", bad])
        assert code == 2 and err.count("\n") == 1 and "--part must be I/N" in err, err


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _expect_one_line(run_cli, argv, match):
    code, out, err = run_cli(argv)
    assert code == 2, (out, err)
    assert err.startswith("wavealt: error:") and err.count("\n") == 1, err
    assert match in err, err
    return err


BASE = ["--sequences", "2", "--size", "40", "--frames", "3", "--no-figures"]


@pytest.mark.parametrize("extra, match", [
    (["--cluster", "local"], "--cluster must be local:N"),
    (["--cluster", "local:0"], "--cluster must be local:N"),
    (["--cluster", "local:two"], "--cluster must be local:N"),
    (["--cluster", "slurm:4"], "--cluster must be local:N"),
    (["--scheduler", "127.0.0.1:8786"], "--scheduler must be a Dask scheduler address"),
    (["--scheduler", "tcp://host"], "--scheduler must be a Dask scheduler address"),
    (["--scheduler", "tcp://host:99999"], "--scheduler must be a Dask scheduler address"),
    (["--cluster", "local:2", "--scheduler", "tcp://h:1"], "one of --cluster and --scheduler"),
    (["--cluster", "local:2", "--workers", "2"], "drop --workers"),
    (["--format", "zip"], "'zip' is not one of 'folder', 'shards'"),
    (["--shard-size", "4"], "--shard-size is for --format shards"),
    (["--format", "shards", "--shard-size", "0"], "--shard-size must be an integer >= 1"),
])
def test_bad_cluster_and_format_input(tmp_path, run_cli, extra, match):
    _expect_one_line(run_cli, ["simulate", str(tmp_path / "x"), *BASE, *extra], match)
    assert not (tmp_path / "x").exists()


def test_unreachable_scheduler_is_one_line_and_writes_nothing(tmp_path, run_cli, references,
                                                              monkeypatch):
    monkeypatch.setattr(cluster_mod, "CONNECT_TIMEOUT_S", 1.0)
    addr = f"tcp://127.0.0.1:{_free_port()}"
    _expect_one_line(run_cli, ["simulate", str(tmp_path / "new"), *BASE, "--scheduler", addr],
                     f"--scheduler {addr}: no Dask scheduler answered within 1 s")
    assert not (tmp_path / "new").exists()
    # a dataset to resume is left as it was, not half-updated
    shutil.copytree(references / "folder", tmp_path / "old")
    shutil.rmtree(tmp_path / "old" / "clean" / "seq_00004")
    before = tree_bytes(tmp_path / "old")
    _expect_one_line(run_cli, ["simulate", str(tmp_path / "old"), "--sequences", "5", "--size",
                               "48", "--frames", "4", "--save-surface", "--no-figures",
                               "--scheduler", addr], "no Dask scheduler answered")
    assert tree_bytes(tmp_path / "old") == before


def test_runner_spec_is_the_command_line():
    assert runner_spec().kind == "serial"
    assert runner_spec(workers=3).kind == "processes"
    assert runner_spec(cluster="local:4").workers == 4
    spec = runner_spec(scheduler="tcp://10.0.0.5:8786")
    assert (spec.kind, spec.address) == ("dask", "tcp://10.0.0.5:8786")
    assert runner_spec(scheduler="tls://[::1]:8786").kind == "dask"


def _late_first(task: int) -> int:
    """The earlier a task, the longer it takes: completion order is the reverse of theirs."""
    import time

    time.sleep(0.05 * (4 - task))
    return task * task


@pytest.mark.parametrize("kind", ["serial", "processes", "dask"])
def test_map_yields_in_the_tasks_order_whatever_finishes_first(kind, scheduler) -> None:
    from wavealt.sim.cluster import TaskRunner

    spec = (runner_spec(workers=1) if kind == "serial"
            else runner_spec(workers=2) if kind == "processes"
            else runner_spec(scheduler=scheduler))
    with TaskRunner(spec) as runner:
        assert list(runner.map(_late_first, range(5))) == [0, 1, 4, 9, 16]
        assert sorted(runner.map_unordered(_late_first, range(5))) == [0, 1, 4, 9, 16]
        assert list(runner.map(_late_first, [])) == []
