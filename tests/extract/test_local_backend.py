"""The local backend: model assembly from parts with a pinned SHA-256, and the embedded server wiring."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

import pytest

from crashscene.extract.local_backend import (
    MODEL_SHA256,
    LocalModelError,
    LocalServer,
    assemble_model,
    cache_dir,
    installed_parts,
    local_chat_backend,
)


@pytest.fixture
def parts(tmp_path: Path) -> tuple[list[Path], str]:
    """Three small fake parts and the SHA-256 of their concatenation."""
    chunks = [b"GGUF" + bytes(range(256)) * 40, os.urandom(5000), b"tail" * 300]
    paths = []
    for index, chunk in enumerate(chunks, start=1):
        path = tmp_path / "parts" / f"part{index:02d}.bin"
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(chunk)
        paths.append(path)
    return paths, hashlib.sha256(b"".join(chunks)).hexdigest()


def test_assembles_once_and_verifies(parts, tmp_path: Path) -> None:
    paths, digest = parts
    dest = tmp_path / "cache" / "model.gguf"
    assert assemble_model(paths, dest, digest) == dest
    assert dest.read_bytes() == b"".join(p.read_bytes() for p in paths)
    assert dest.with_name("model.gguf.sha256").read_text().split()[0] == digest
    for path in paths:  # the second call trusts the verified stamp and reads no part
        path.unlink()
    assert assemble_model(paths, dest, digest) == dest


def test_refuses_a_sha256_mismatch_and_keeps_nothing(parts, tmp_path: Path) -> None:
    paths, _ = parts
    dest = tmp_path / "cache" / "model.gguf"
    with pytest.raises(LocalModelError, match="refusing it"):
        assemble_model(paths, dest, "0" * 64)
    assert list(dest.parent.iterdir()) == []


def test_a_tampered_part_is_refused_even_with_an_old_stamp(parts, tmp_path: Path) -> None:
    paths, digest = parts
    dest = tmp_path / "cache" / "model.gguf"
    assemble_model(paths, dest, digest)
    dest.write_bytes(b"GGUF" + b"x" * 10)  # the file changed size: the stamp no longer vouches for it
    paths[1].write_bytes(b"tampered")
    with pytest.raises(LocalModelError, match="SHA-256"):
        assemble_model(paths, dest, digest)


def test_missing_part_names_the_file(parts, tmp_path: Path) -> None:
    paths, digest = parts
    paths[2].unlink()
    with pytest.raises(LocalModelError, match="part03.bin"):
        assemble_model(paths, tmp_path / "model.gguf", digest)


def test_cache_dir_follows_the_environment(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("CRASHSCENE_CACHE_DIR", str(tmp_path))
    assert cache_dir() == tmp_path


def test_model_path_that_is_not_gguf_is_refused(tmp_path: Path) -> None:
    fake = tmp_path / "model.gguf"
    fake.write_bytes(b"<html>not a model</html>")
    with pytest.raises(LocalModelError, match="not a GGUF"):
        LocalServer(fake).start()
    with pytest.raises(LocalModelError, match="cannot read"):
        LocalServer(tmp_path / "absent.gguf").start()


def _available_gguf() -> Path | None:
    """A GGUF to run the real server with: $CRASHSCENE_TEST_GGUF, or the installed local-model parts."""
    if os.environ.get("CRASHSCENE_TEST_GGUF"):
        return Path(os.environ["CRASHSCENE_TEST_GGUF"])
    try:
        installed_parts()
    except LocalModelError:
        return None
    return assemble_model()  # verified against MODEL_SHA256; cached after the first time


@pytest.mark.slow
def test_embedded_server_answers_a_structured_request() -> None:
    pytest.importorskip("xllamacpp", reason="xllamacpp (the 'local' extra) is not installed")
    gguf = _available_gguf()
    if gguf is None:
        pytest.skip("no GGUF model: install crashscene[local-model] or set CRASHSCENE_TEST_GGUF")
    from pydantic import BaseModel

    class Conditions(BaseModel):
        weather: str
        lanes: int

    with LocalServer(gguf, context_tokens=1024) as server:
        assert server.base_url.startswith("http://127.0.0.1:")
        backend = local_chat_backend(server)
        assert backend.send_image is False and backend.cost(backend_usage()) == 0.0
        response = backend.client.chat.completions.parse(
            model=backend.model, response_format=Conditions, temperature=0, max_tokens=40,
            messages=[{"role": "user", "content": "It was raining on a two-lane road. Give weather and lanes."}])
    parsed = response.choices[0].message.parsed
    assert isinstance(parsed, Conditions) and parsed.lanes == 2


def backend_usage():
    from crashscene.extract.openai_backend import Usage

    return Usage(prompt_tokens=1000, completion_tokens=100)


def test_pinned_digest_is_a_sha256() -> None:
    assert len(MODEL_SHA256) == 64 and int(MODEL_SHA256, 16) >= 0
