"""Datasets on disk: the dataset folder, tar shards (at a path or any fsspec URL), the
manifest, and the simulator's writer.

``folder``     the dataset folder, ``dataset.json`` and the manifest (:class:`Dataset`)
``shards``     the sharded layout in tar files (:class:`ShardDataset`), :func:`open_dataset`
``location``   local paths and fsspec URLs, atomic writes to either
``simulate``   :func:`simulate_dataset`: a simulated dataset, on one process, a local pool
               or a Dask cluster, resumable
"""

from wavealt.dataset.folder import (
    BASE_CONDITIONS,
    FORMAT,
    FORMAT_VERSION,
    MANIFEST_COLUMNS,
    Dataset,
    SequenceRecord,
    manifest_row,
    manifest_text,
    read_info,
    read_manifest,
    records_of,
    records_of_index,
    sequence_id,
)
from wavealt.dataset.shards import (
    DEFAULT_SHARD_SIZE,
    ShardDataset,
    open_dataset,
    require_folder,
)
from wavealt.dataset.simulate import FORMATS, simulate_dataset

__all__ = ["BASE_CONDITIONS", "DEFAULT_SHARD_SIZE", "FORMAT", "FORMATS", "FORMAT_VERSION",
           "MANIFEST_COLUMNS", "Dataset", "SequenceRecord", "ShardDataset", "manifest_row",
           "manifest_text", "open_dataset", "read_info", "read_manifest", "records_of",
           "records_of_index", "require_folder", "sequence_id", "simulate_dataset"]
