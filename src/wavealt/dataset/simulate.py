"""A simulated dataset to disk: a dataset folder or tar shards, written by this process, a
local process pool or a Dask cluster, resumed where it stopped.

Every sequence is a pure function of the config and its index, and every file is written
whole or not at all, so the bytes do not depend on the runner, the number of workers or
interruptions. A dataset folder is written one task per sequence, a sharded one one task per
shard (its N sequences, in order), so that each tar has a single writer.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tqdm import tqdm

from wavealt.dataset.folder import (
    Dataset,
    ids_missing,
    manifest_text,
    new_info,
    read_info,
    records_of,
    records_of_index,
    storage_of,
    write_info,
)
from wavealt.dataset.location import (
    Location,
    as_location,
    exists,
    filesystem,
    is_file,
    is_url,
    join,
    write_bytes,
)
from wavealt.dataset.shards import (
    DEFAULT_SHARD_SIZE,
    SURFACE_FIELDS,
    sample_of,
    shard_count,
    shard_location,
    shard_storage,
    write_shard,
)
from wavealt.io import atomic_save_npz, write_frames_folder
from wavealt.sim.cluster import RunnerSpec, TaskRunner, runner_spec
from wavealt.sim.config import SimConfig
from wavealt.sim.generate import generate_sequence

FORMATS = ("folder", "shards")
SURFACE_DESCRIPTION = ("ground truth per sequence: surface/<id>.npz with height_m, slope_x, "
                       "slope_y (T, H, W) float32")
SHARD_SURFACE_DESCRIPTION = ("ground truth per sequence: the <id>.surface.npz member of its "
                             "shard, with height_m, slope_x, slope_y (T, H, W) float32")


# -- the tasks (module level: pickled by name to the workers) -----------------------------
def _write_one(args: tuple[str, dict, int, bool]) -> int:
    """Write sequence ``index`` of a dataset folder (the parts it lacks); returns 1."""
    root_s, cfg_dict, index, save_surface = args
    root = Path(root_s)
    config = SimConfig.from_dict(cfg_dict)
    rec = records_of_index(config, index)
    need = [c for c in ("clean", "glinty") if not (root / c / rec.sequence_id).is_dir()]
    surf_path = root / "surface" / f"{rec.sequence_id}.npz"
    need_surface = save_surface and not surf_path.is_file()
    if not need and not need_surface:
        return 1
    data = generate_sequence(rec.scenario, config, with_height=need_surface)
    for c in need:
        write_frames_folder(root / c / rec.sequence_id, getattr(data, c))
    if need_surface:
        atomic_save_npz(surf_path, **{k: getattr(data, k) for k in SURFACE_FIELDS})
    return 1


def _write_shard(args: tuple[str, dict, int, int, bool]) -> int:
    """Write shard ``k`` (its sequences in order) unless it is there; returns its size."""
    root_s, cfg_dict, k, shard_size, save_surface = args
    config = SimConfig.from_dict(cfg_dict)
    indices = range(k * shard_size, min((k + 1) * shard_size, config.sequences))
    loc = shard_location(as_location(root_s), k)
    if is_file(loc):
        return len(indices)

    def samples():
        for i in indices:
            rec = records_of_index(config, i)
            data = generate_sequence(rec.scenario, config, with_height=save_surface)
            yield rec.sequence_id, sample_of(rec, data, save_surface=save_surface)

    write_shard(loc, samples())
    return len(indices)


# -- the command --------------------------------------------------------------------------
def _flat(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """A nested config dict as ``{"sensor.compression": ..., ...}`` (for messages)."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def _describe_storage(st: dict[str, Any]) -> str:
    if st.get("format") != "shards":
        return "a dataset folder (--format folder)"
    surf = ", with surfaces" if st.get("surface") else ""
    return f"shards of {st['shard_size']} sequences (--format shards --shard-size {st['shard_size']}{surf})"


def _holds_files(out: Location) -> bool:
    """Whether ``out`` holds anything but the temporary files of an atomic write (another
    job of an array may be writing ``dataset.json`` there this very moment)."""
    if not is_url(out):
        return Path(out).is_dir() and any(not p.name.startswith(".") for p in Path(out).iterdir())
    fs, path = filesystem(str(out))
    try:
        return bool(fs.ls(path, detail=False))
    except (FileNotFoundError, NotADirectoryError):
        return False


def _check_out(out: Location, config: SimConfig, storage: dict[str, Any]) -> None:
    """The overwrite rule: a new location, an empty folder, or a dataset of this very
    config and layout (which is resumed); anything else is refused before any write."""
    if not is_url(out) and Path(out).exists() and not Path(out).is_dir():
        msg = f"OUT {out} is an existing file; give a folder for the dataset"
        raise ValueError(msg)
    if is_url(out) and storage["format"] != "shards":
        msg = f"OUT {out} is a URL: --format folder writes a local folder (use --format shards)"
        raise ValueError(msg)
    if exists(join(out, "dataset.json")):
        info = read_info(out)
        existing = SimConfig.from_dict(info["config"])
        if existing != config:
            a, b = _flat(existing.to_dict()), _flat(config.to_dict())
            diff = ", ".join(f"{k}: {a.get(k, '-')!r} -> {b.get(k, '-')!r}"
                             for k in sorted(a.keys() | b.keys()) if a.get(k) != b.get(k))
            msg = f"OUT {out} holds a dataset made with a different config ({diff}); choose another folder"
            raise ValueError(msg)
        have = storage_of(info)
        if storage["format"] == "folder":
            same = have.get("format") == "folder"
        else:
            same = all(have.get(k) == storage[k] for k in ("format", "shard_size", "surface"))
        if not same:
            msg = (f"OUT {out} holds {_describe_storage(have)}; this run would write "
                   f"{_describe_storage(storage)}: choose another folder")
            raise ValueError(msg)
    elif _holds_files(out):
        msg = f"OUT {out} is a non-empty folder that holds no wavealt dataset; choose another folder"
        raise ValueError(msg)


def _storage(fmt: str, config: SimConfig, shard_size: int, save_surface: bool) -> dict[str, Any]:
    if fmt not in FORMATS:
        msg = f"--format must be folder or shards; got {fmt!r}"
        raise ValueError(msg)
    if fmt == "folder":
        return {"format": "folder"}
    return shard_storage(config.sequences, shard_size, save_surface)


def _missing(out: Location, records: list, storage: dict[str, Any],
             save_surface: bool) -> list[int]:
    """Tasks not done: sequence indices (folder) or shard indices (shards)."""
    if storage["format"] == "folder":
        return ids_missing(Path(out), records, ("clean", "glinty"), save_surface)
    return [k for k in range(shard_count(len(records), storage["shard_size"]))
            if not is_file(shard_location(out, k))]


def _part_filter(part: tuple[int, int] | None):
    """The task indices of ``part`` (``(i, n)``: those equal to ``i`` modulo ``n``)."""
    if part is None:
        return lambda tasks: list(tasks)
    i, n = part
    if not (isinstance(i, int) and isinstance(n, int) and n >= 1 and 0 <= i < n):
        msg = f"--part must be I/N with 0 <= I < N; got {i}/{n}"
        raise ValueError(msg)
    return lambda tasks: [t for t in tasks if t % n == i]


def simulate_dataset(out: Path | str, config: SimConfig, *, workers: int = 1,
                     cluster: str | None = None, scheduler: str | None = None,
                     format: str = "folder", shard_size: int = DEFAULT_SHARD_SIZE,  # noqa: A002
                     save_surface: bool = False, part: tuple[int, int] | None = None,
                     progress: bool = True) -> Location:
    """Write the dataset of ``config`` to ``out``.

    Parameters
    ----------
    out : path or str
        A local folder, or (``format="shards"``) any fsspec URL.
    config : SimConfig
    workers : int
        Local processes (``--workers``).
    cluster : str, optional
        ``"local:N"``: a Dask LocalCluster of N worker processes (``--cluster``).
    scheduler : str, optional
        ``"tcp://HOST:PORT"``: an existing Dask cluster (``--scheduler``); ``out`` must be
        within its workers' reach (a shared folder or a URL).
    format : str
        ``"folder"`` (:mod:`wavealt.dataset.folder`) or ``"shards"``
        (:mod:`wavealt.dataset.shards`, ``shard_size`` sequences per tar).
    save_surface : bool
        Also write each sequence's height and slopes.
    part : (i, n), optional
        Write only part ``i`` of ``n`` (``--part I/N``): the sequences (shards) whose index
        is ``i`` modulo ``n``, so that ``n`` jobs of an array write the dataset together;
        a run without ``part`` afterwards checks that it is whole (and completes it).

    Resumes: the sequences (shards) already complete are kept; a location holding a dataset
    of another config or layout, or other files, is refused untouched. Whatever runs it,
    the bytes are those of one process.
    """
    out = as_location(out)
    spec: RunnerSpec = runner_spec(workers=workers, cluster=cluster, scheduler=scheduler)
    storage = _storage(format, config, shard_size, save_surface)
    mine = _part_filter(part)
    _check_out(out, config, storage)
    records = records_of(config)
    with TaskRunner(spec) as runner:  # started (or connected) before anything is written
        if not is_url(out):
            Path(out).mkdir(parents=True, exist_ok=True)
        if not exists(join(out, "dataset.json")):
            info = new_info(config)
            if storage["format"] == "shards":
                info["storage"] = storage
                if save_surface:
                    info["conditions"]["surface"] = {"description": SHARD_SURFACE_DESCRIPTION}
            write_info(out, info)
        write_bytes(join(out, "manifest.csv"), manifest_text(records).encode("utf-8"))
        todo = mine(_missing(out, records, storage, save_surface))
        cfg = config.to_dict()
        if storage["format"] == "folder":
            if save_surface:
                (Path(out) / "surface").mkdir(exist_ok=True)
            fn, tasks = _write_one, [(str(out), cfg, i, save_surface) for i in todo]
            n_tasks, weight = len(records), (lambda i: 1)
        else:
            size = storage["shard_size"]
            fn, tasks = _write_shard, [(str(out), cfg, k, size, save_surface) for k in todo]
            n_tasks = shard_count(len(records), size)
            weight = lambda k: min(size, len(records) - k * size)  # noqa: E731
        total = sum(map(weight, mine(range(n_tasks))))
        left = sum(map(weight, todo))
        with tqdm(total=total, initial=total - left, unit="seq",
                  desc=f"simulate ({spec.describe()})", disable=not progress) as bar:
            for n in runner.map_unordered(fn, tasks):
                bar.update(n)
    lost = mine(_missing(out, records, storage, save_surface))
    if lost:
        what = "sequences" if storage["format"] == "folder" else "shards"
        msg = (f"OUT {out} lacks {len(lost)} of the {what} the workers reported written: with "
               "--scheduler, OUT must be a folder every worker shares with this machine, or a "
               "URL they all reach")
        raise ValueError(msg)
    if save_surface and storage["format"] == "folder":
        folder = Dataset(out)
        folder.info["conditions"]["surface"] = {"description": SURFACE_DESCRIPTION}
        write_info(out, folder.info)
    return out


__all__ = ["FORMATS", "simulate_dataset"]
