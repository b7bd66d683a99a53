"""The console script `crashscene` (`crashscene.cli.main`): the command's exit code is kept, and the garbage
collector's objects are frozen once the command is done (the process then ends without traversing them again)."""
from __future__ import annotations

import gc
import sys

import pytest

from crashscene.cli import main

from tests.conftest import EXAMPLES


@pytest.mark.parametrize(("path", "code"), [(EXAMPLES / "100237" / "golden.yaml", 0), ("no/such/file.yaml", 1)])
def test_main_keeps_the_exit_code_and_freezes_the_objects(path, code, monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["crashscene", "validate", str(path)])
    gc.unfreeze()
    try:
        with pytest.raises(SystemExit) as exit_info:
            main()
        frozen = gc.get_freeze_count()
    finally:
        gc.unfreeze()  # this test process goes on
    assert (exit_info.value.code or 0) == code
    assert frozen > 0
    capsys.readouterr()
