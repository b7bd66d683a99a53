"""The user cache directory, and values cached in it by the hash of their inputs.

The directory is `$CRASHSCENE_CACHE_DIR`, else `$CRASHSCENE_CACHE` (both
spellings are accepted), else `$XDG_CACHE_HOME/crashscene`, else
`~/.cache/crashscene`. Everything in it can be deleted at any time: it is
rebuilt from the inputs. Pickled entries are written by crashscene itself, and
their key includes a format version, so a changed layout is never read back.
"""
from __future__ import annotations

import hashlib
import os
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

ENV_VARS = ("CRASHSCENE_CACHE_DIR", "CRASHSCENE_CACHE")

T = TypeVar("T")


def cache_dir() -> Path:
    """The user cache directory (created by whoever first writes into it)."""
    for name in ENV_VARS:
        if os.environ.get(name):
            return Path(os.environ[name])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "crashscene"


def pickled(kind: str, inputs: list[bytes], build: Callable[[], T]) -> T:
    """`build()`, or the value an earlier call with the same `kind` and `inputs` stored under `cache_dir()/kind`.

    A cache that cannot be read or written (read-only, damaged entry) only costs the rebuild.
    """
    digest = hashlib.sha256()
    for part in inputs:
        digest.update(hashlib.sha256(part).digest())
    path = cache_dir() / kind / f"{digest.hexdigest()}.pkl"
    try:
        with open(path, "rb") as fh:
            return pickle.load(fh)
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError, IndexError, TypeError):
        pass
    value = build()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        with open(tmp, "wb") as fh:
            pickle.dump(value, fh, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, path)
    except OSError:
        pass
    return value
