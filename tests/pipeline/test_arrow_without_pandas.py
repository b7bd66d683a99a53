"""`crashscene simulate` spares its processes pyarrow's pandas import, and explicit pandas conversions still work."""
from __future__ import annotations

import subprocess
import sys

from tests.conftest import EXAMPLES

SCRIPT = """
import sys
from crashscene.cli import main
case, out = sys.argv[1:]
sys.argv = ["crashscene", "simulate", case, "-n", "3", "--out", out, "--json"]
try:
    main()
except SystemExit as exc:
    assert not exc.code, exc.code
assert "pandas" not in sys.modules, "the command imported pandas"
import pyarrow.parquet as pq
frame = pq.read_table(out + "/actors.parquet").to_pandas()  # pyarrow imports pandas when asked to
assert "pandas" in sys.modules and len(frame) == 3 * 2, frame
"""


def test_the_command_line_does_not_import_pandas(tmp_path):
    done = subprocess.run([sys.executable, "-c", SCRIPT, str(EXAMPLES / "100237" / "golden.yaml"),
                           str(tmp_path / "run")], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
