"""The user cache directory, and values cached in it by the hash of their inputs.

The directory is `$CRASHSCENE_CACHE_DIR`, else `$CRASHSCENE_CACHE` (both
spellings are accepted), else `$XDG_CACHE_HOME/crashscene`, else
`~/.cache/crashscene`. Everything in it can be deleted at any time: it is
rebuilt from the inputs. Pickled entries are written by crashscene itself, and
their key includes the hash of crashscene's own source, so what an older or
edited version of the code derived is never read back.
"""
from __future__ import annotations

import functools
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


DERIVING_PACKAGES = ("scenic", "shapely", "numpy")  # whose versions change what cached values hold


@functools.cache
def code_fingerprint() -> bytes:
    """SHA-256 of every Python source file of the crashscene package and of the versions of DERIVING_PACKAGES
    (a few ms, once per process)."""
    from importlib.metadata import PackageNotFoundError, version

    digest = hashlib.sha256()
    for name in DERIVING_PACKAGES:
        try:
            digest.update(f"{name}=={version(name)}".encode())
        except PackageNotFoundError:
            digest.update(f"{name} absent".encode())
    package = Path(__file__).resolve().parent
    for path in sorted(package.rglob("*.py")):
        digest.update(str(path.relative_to(package)).encode())
        digest.update(path.read_bytes())
    return digest.digest()


def pickled(kind: str, inputs: list[bytes], build: Callable[[], T]) -> T:
    """`build()`, or the value an earlier call with the same `kind`, `inputs` and code (`code_fingerprint`)
    stored under `cache_dir()/kind`.

    A cache that cannot be read or written (read-only, damaged entry) only costs the rebuild.
    """
    digest = hashlib.sha256(code_fingerprint())
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
