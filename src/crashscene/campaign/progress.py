"""Progress of a campaign: rich bars (counts, rate, ETA) on a terminal, one plain line per chunk otherwise."""
from __future__ import annotations

import sys
import time

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn


class CampaignProgress:
    """Tracks variations done; `live` forces bars on/off (default: bars only when stderr is a terminal)."""

    def __init__(self, total: int, chunks: int, live: bool | None = None, quiet: bool = False):
        self.console = Console(stderr=True)
        self.live = self.console.is_terminal if live is None else live
        self.quiet = quiet
        self.total, self.chunks = total, chunks
        self.done_variations = self.done_chunks = 0
        self.start = time.perf_counter()
        self._progress: Progress | None = None
        if self.live and not quiet:
            self._progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                                      TextColumn("{task.fields[unit]}"), TextColumn("{task.fields[rate]}"),
                                      TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
                                      console=self.console, transient=False)
            self._bar = self._progress.add_task("campaign", total=total, rate="", unit="variations")
            self._chunk_bar = self._progress.add_task("chunks", total=chunks, rate="", unit="chunks")

    def __enter__(self) -> CampaignProgress:
        if self._progress is not None:
            self._progress.start()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._progress is not None:
            self._progress.stop()

    def chunk_done(self, key: str, count: int, seconds: float, failed: str | None = None) -> None:
        self.done_chunks += 1
        self.done_variations += 0 if failed else count
        elapsed = time.perf_counter() - self.start
        rate = self.done_variations / elapsed if elapsed > 0 else 0.0
        if self._progress is not None:
            self._progress.update(self._bar, advance=0 if failed else count, rate=f"{rate:,.1f}/s")
            self._progress.update(self._chunk_bar, advance=1)
            if failed:
                self._progress.console.print(f"[red]chunk {key} failed:[/red] {failed.splitlines()[0]}")
        elif not self.quiet:
            status = f"FAILED: {failed.splitlines()[0]}" if failed else f"done in {seconds:.1f} s"
            print(f"[{self.done_chunks}/{self.chunks} chunks, {self.done_variations}/{self.total} variations, "
                  f"{rate:.1f}/s] chunk {key} {status}", file=sys.stderr, flush=True)

    def note(self, text: str) -> None:
        if self.quiet:
            return
        if self._progress is not None:
            self._progress.console.print(text)
        else:
            print(text, file=sys.stderr, flush=True)
