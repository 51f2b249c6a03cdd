"""Where a dataset lives: a local folder, or any fsspec URL (``s3://bucket/ds``,
``gs://…``, ``memory://ds`` …) for a sharded one.

A location is a :class:`~pathlib.Path` when local and a ``str`` URL otherwise; a string with
a ``PROTOCOL://`` is a URL, any other string a local path. Writes are atomic either way: a
local file goes through :func:`wavealt.io.atomic_path`; a URL's bytes are written to a local
temporary file and uploaded with one ``put_file`` (an object store publishes an object only
once its upload completes), so an error leaves nothing at the location.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, BinaryIO

from wavealt.io import atomic_path

Location = Path | str


def is_url(location: Any) -> bool:
    """True for a string with a ``PROTOCOL://`` (``file://`` included)."""
    return isinstance(location, str) and "://" in location


def as_location(location: Path | str) -> Location:
    """A URL string stays a string; anything else becomes a Path."""
    return location if is_url(location) else Path(location)


def filesystem(location: str) -> tuple[Any, str]:
    """The fsspec filesystem of URL ``location`` and the path inside it; a one-line
    ``ValueError`` when fsspec cannot open that protocol here (an unknown one, or one whose
    package, such as ``s3fs`` or ``gcsfs``, is not installed)."""
    import fsspec.core  # deferred: 0.1 s, only for URLs

    try:
        return fsspec.core.url_to_fs(location)
    except (ImportError, ValueError) as exc:
        msg = f"cannot open {location}: {exc}"
        raise ValueError(msg) from None


def join(location: Location, *parts: str) -> Location:
    """``location``/``parts``, a Path or a URL like ``location``."""
    if is_url(location):
        return "/".join([str(location).rstrip("/"), *parts])
    return Path(location).joinpath(*parts)


def exists(location: Location) -> bool:
    """Whether a file or folder is at ``location``."""
    if not is_url(location):
        return Path(location).exists()
    fs, path = filesystem(str(location))
    return bool(fs.exists(path))


def is_file(location: Location) -> bool:
    """Whether a file is at ``location``."""
    if not is_url(location):
        return Path(location).is_file()
    fs, path = filesystem(str(location))
    return bool(fs.isfile(path))


def read_bytes(location: Location) -> bytes:
    """The bytes of the file at ``location``."""
    if not is_url(location):
        return Path(location).read_bytes()
    fs, path = filesystem(str(location))
    try:
        return bytes(fs.cat_file(path))
    except FileNotFoundError:
        msg = f"file not found: {location}"
        raise FileNotFoundError(msg) from None


def open_binary(location: Location) -> BinaryIO:
    """``location`` opened for reading as a binary stream (the caller closes it)."""
    if not is_url(location):
        return open(location, "rb")  # noqa: SIM115
    fs, path = filesystem(str(location))
    return fs.open(path, "rb")


@contextmanager
def atomic_output(location: Location) -> Iterator[BinaryIO]:
    """A binary stream whose bytes appear at ``location`` whole when the block ends without
    an error, or not at all."""
    if not is_url(location):
        with atomic_path(location) as tmp, open(tmp, "wb") as fh:
            yield fh
        return
    fs, path = filesystem(str(location))
    with tempfile.TemporaryDirectory(prefix="wavealt-upload-") as tmpdir:
        tmp = Path(tmpdir) / "part"
        with open(tmp, "wb") as fh:
            yield fh
        parent = path.rsplit("/", 1)[0]
        if parent and parent != path:
            fs.makedirs(parent, exist_ok=True)
        fs.put_file(str(tmp), path)


def write_bytes(location: Location, data: bytes) -> None:
    """Write ``data`` at ``location`` atomically."""
    with atomic_output(location) as fh:
        fh.write(data)


__all__ = ["Location", "as_location", "atomic_output", "exists", "filesystem", "is_file",
           "is_url", "join", "open_binary", "read_bytes", "write_bytes"]
