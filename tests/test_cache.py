"""The user cache: one directory for every cached thing, values rebuilt when missing or damaged."""
from __future__ import annotations

from crashscene.cache import cache_dir, pickled


def test_both_spellings_name_the_cache_dir(monkeypatch, tmp_path):
    monkeypatch.delenv("CRASHSCENE_CACHE_DIR", raising=False)
    monkeypatch.setenv("CRASHSCENE_CACHE", str(tmp_path / "a"))
    assert cache_dir() == tmp_path / "a"
    monkeypatch.setenv("CRASHSCENE_CACHE_DIR", str(tmp_path / "b"))
    assert cache_dir() == tmp_path / "b"


def test_pickled_builds_once_per_inputs_and_survives_a_damaged_entry(monkeypatch, tmp_path):
    monkeypatch.setenv("CRASHSCENE_CACHE_DIR", str(tmp_path))
    calls = []

    def build():
        calls.append(1)
        return {"value": len(calls)}

    assert pickled("things", [b"x", b"y"], build) == {"value": 1}
    assert pickled("things", [b"x", b"y"], build) == {"value": 1}   # read back, not rebuilt
    (entry,) = (tmp_path / "things").iterdir()
    entry.write_bytes(b"not a pickle")
    assert pickled("things", [b"x", b"y"], build) == {"value": 2}   # damaged: rebuilt and stored again
    assert pickled("things", [b"x", b"y"], build) == {"value": 2}
    assert pickled("things", [b"xy"], build) == {"value": 3}        # inputs are hashed one by one
