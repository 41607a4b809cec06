"""NCA checkpoint files: `.npz` holding the genome, the config as JSON, and metadata.

Loading uses ``allow_pickle=False`` and JSON only, so a checkpoint can never run code.
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np

from mjregen.errors import CheckpointError, InvalidGenomeError
from mjregen.fileio import atomic_open
from mjregen.growth.nca import NCA, NCAConfig

FORMAT = "mjregen-nca-1"


def save_nca(
    path: str | os.PathLike, nca: NCA, *, metadata: dict | None = None, overwrite: bool = False
) -> Path:
    """Write `nca` (and JSON-serialisable `metadata`) to `path` (``.npz``) atomically.

    Raises:
      OutputExistsError: `path` exists and `overwrite` is False.
      CheckpointError: `path` does not end in ``.npz`` or `metadata` is not JSON.
    """
    path = Path(path)
    if path.suffix != ".npz":
        raise CheckpointError(f"NCA checkpoints are .npz files; got {str(path)!r}")
    try:
        metadata_json = json.dumps(metadata or {})
    except TypeError as error:
        raise CheckpointError(f"checkpoint metadata must be JSON-serialisable: {error}") from None
    with atomic_open(path, overwrite=overwrite) as handle:
        np.savez(
            handle,
            format=np.array(FORMAT),
            config=np.array(json.dumps(nca.config.to_dict())),
            metadata=np.array(metadata_json),
            genome=nca.genome,
        )
    return path


def load_nca(path: str | os.PathLike) -> tuple[NCA, dict]:
    """Read a checkpoint written by `save_nca`; returns the NCA and its metadata.

    Raises:
      FileNotFoundError: no file at `path`.
      CheckpointError: the file is not a valid mjregen NCA checkpoint (names the problem).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"NCA checkpoint not found: {path}")
    if path.suffix != ".npz":
        raise CheckpointError(f"NCA checkpoints are .npz files; got {str(path)!r}")
    try:
        archive = np.load(path, allow_pickle=False)
        if not isinstance(archive, np.lib.npyio.NpzFile):
            raise CheckpointError(f"{path} holds a single array, not an mjregen NCA checkpoint")
        with archive:
            fields = {name: archive[name] for name in ("format", "config", "metadata", "genome")}
    except KeyError as error:
        raise CheckpointError(f"{path} is not an mjregen NCA checkpoint (missing {error})") from None
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as error:
        raise CheckpointError(f"{path} is not a readable .npz checkpoint: {error}") from None
    if str(fields["format"]) != FORMAT:
        raise CheckpointError(f"{path} has format {str(fields['format'])!r}, expected {FORMAT!r}")
    try:
        config = NCAConfig.from_dict(json.loads(str(fields["config"])))
        metadata = json.loads(str(fields["metadata"]))
    except (ValueError, TypeError) as error:
        raise CheckpointError(f"{path} has an invalid NCA config: {error}") from None
    try:
        nca = NCA(config, fields["genome"])
    except InvalidGenomeError as error:
        raise CheckpointError(f"{path}: {error}") from None
    return nca, metadata
