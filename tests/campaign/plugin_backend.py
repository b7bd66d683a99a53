"""A simulation backend that lives outside the crashscene package (the plug-in test).

It is the embedded simulator under another class, and it leaves a mark (its process id) in
`$CRASHSCENE_PLUGIN_MARKS` each time it simulates, so a test can see which processes ran it.
"""
from __future__ import annotations

import os
from pathlib import Path

from crashscene.simulate.backend import BatchResult, SimulationRequest
from crashscene.simulate.embedded.simulator import EmbeddedSimulator


class MarkedSimulator(EmbeddedSimulator):
    name = "marked"

    def simulate(self, request: SimulationRequest) -> BatchResult:
        marks = os.environ.get("CRASHSCENE_PLUGIN_MARKS")
        if marks:
            with open(Path(marks), "a", encoding="utf-8") as fh:
                fh.write(f"{os.getpid()} {len(request.scenes)}\n")
        return super().simulate(request)
