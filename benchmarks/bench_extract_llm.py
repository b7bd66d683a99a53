"""Benchmark of the LLM extraction backends (local llama.cpp or an OpenAI-compatible endpoint).

Run by hand, e.g.
  .venv/bin/python benchmarks/bench_extract_llm.py --backend local --cases 5
  .venv/bin/python benchmarks/bench_extract_llm.py --backend openai --model gpt-4o-mini --cases all
Prints seconds per case (model load apart for `local`), tokens, cost and the dsl.md section 4 accuracy
of the predictions against the bundled golden files. Cases are taken in sorted order, every k-th one
so that a small sample spans the set; predictions and summary.json go to --out.
"""
from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from crashscene.dsl import load_file
from crashscene.evaluation.score import evaluate, format_result
from crashscene.extract.pipeline import ExtractOptions, extract_batch

CIREN = Path(__file__).resolve().parent.parent / "examples" / "ciren"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--backend", choices=("local", "openai"), default="local")
    parser.add_argument("--model", default="gpt-4o-mini")
    parser.add_argument("--base-url")
    parser.add_argument("--model-path", type=Path)
    parser.add_argument("--cases", default="5", help="a number (spread over the set) or 'all'")
    parser.add_argument("--no-revise", action="store_true")
    parser.add_argument("--exemplars", type=int)
    parser.add_argument("--out", type=Path, default=Path("out/bench_extract_llm"))
    parser.add_argument("--diffs", action="store_true")
    args = parser.parse_args()
    cases = sorted(p.name for p in CIREN.iterdir() if (p / "golden.yaml").is_file())
    if args.cases != "all":
        count = int(args.cases)
        step = max(1, len(cases) // count)
        cases = cases[::step][:count]
    options = ExtractOptions(backend=args.backend, model=args.model, base_url=args.base_url,
                             model_path=args.model_path, revise=not args.no_revise, exemplars=args.exemplars)
    started = time.perf_counter()
    cpu: list[float] = []  # [s] CPU time of this process per case: the llama.cpp server runs in-process,
    last = [time.process_time()]  # so on a machine shared with other jobs this is what the case cost

    def progress(result) -> None:  # noqa: ANN001
        now = time.process_time()
        cpu.append(now - last[0])
        last[0] = now
        print(f"{result.case_id}: {result.status} {result.seconds:.1f} s wall, {cpu[-1]:.1f} s cpu, "
              f"{result.tokens.total} tok ({result.tokens.cached} cached), {result.tokens.requests} requests "
              f"{result.error or ''}", flush=True)

    results = extract_batch([CIREN / case for case in cases], args.out, options=options, progress=progress)
    wall = time.perf_counter() - started
    pairs = {r.case_id: (load_file(CIREN / r.case_id / "golden.yaml"), r.scenario) for r in results}
    print(format_result(evaluate(pairs, {r.case_id: r.error for r in results if r.error}), diffs=args.diffs,
                        confusion=args.diffs))
    seconds = [r.seconds for r in results]
    ok = [r for r in results if r.status == "ok"]
    print(f"\n{len(results)} cases, {len(ok)} ok; per case: mean {statistics.mean(seconds):.1f} s, "
          f"median {statistics.median(seconds):.1f} s, max {max(seconds):.1f} s; cpu mean "
          f"{statistics.mean(cpu):.1f} s (first case includes model load); wall {wall:.0f} s "
          f"(model load included); tokens per case {statistics.mean(r.tokens.total for r in results):.0f}; "
          f"requests per case {statistics.mean(r.tokens.requests for r in results):.1f}; "
          f"cost {sum(r.cost_usd or 0 for r in results):.4f} USD")


if __name__ == "__main__":
    main()
