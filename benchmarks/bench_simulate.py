"""Benchmark: `crashscene simulate FILE -n 2000` with default options, by stage, against Newtonian, for three cases.

Run by hand: `.venv/bin/python benchmarks/bench_simulate.py [--variations 2000] [--newtonian 20]
[--cases 100237 108812 105203] [--mode test|reproduce]`.

For each case (default: a 4-way junction, a curve, three actors) it runs the
real command line as a subprocess (default options: compiled sampler, one
worker per core) and prints its wall time (target: at most 10 s), the stages
from its summary.json (render, sample, simulate, monitor), and the peak
memory of the whole process tree, worker processes included (sum of
proportional set sizes; target: at most 1.5 GB) and its CPU time. In the same run it times `--newtonian` variations of the same
scenario in Scenic's Newtonian simulator (its one-off compile excluded) and
prints Newtonian seconds per variation over embedded seconds per variation
(target: at least 150x): wall time against the embedded simulate stage alone
and against the whole command (render + sample + simulate + monitor +
start-up), and CPU time against the whole command's CPU time. The
machine's load average is printed beside the figures: the machine is shared.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEFAULT_CASES = ["100237", "108812", "105203"]  # 4-way junction, curve, three actors


def tree_rss(root: int) -> int:
    """[bytes] memory of `root` and all its descendants now (sum of their proportional set sizes)."""
    parents: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as fh:
                    parents[int(entry)] = int(fh.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    tree, frontier = {root}, [root]
    while frontier:
        pid = frontier.pop()
        for child, parent in parents.items():
            if parent == pid and child not in tree:
                tree.add(child)
                frontier.append(child)
    total = 0
    for pid in tree:  # proportional set size: pages a forked worker shares with its parent count once
        try:
            with open(f"/proc/{pid}/smaps_rollup") as fh:
                total += next(int(line.split()[1]) for line in fh if line.startswith("Pss:")) * 1024
        except (OSError, StopIteration, ValueError):
            continue
    return total


def run_cli(case: Path, n: int, mode: str, out: Path) -> tuple[float, float, int, dict]:
    """(wall [s], CPU [s], peak tree memory [bytes], summary) of `crashscene simulate case -n n`, default options."""
    crashscene = Path(sys.executable).parent / "crashscene"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.Popen([str(crashscene), "simulate", str(case), "-n", str(n), "--mode", mode, "--out", str(out),
                             "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    peak = [0]

    def watch() -> None:
        while proc.poll() is None:
            peak[0] = max(peak[0], tree_rss(proc.pid))
            time.sleep(0.05)

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    stdout, stderr = proc.communicate()
    wall = time.perf_counter() - start
    watcher.join()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)  # the command and the worker processes it waited for
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    if proc.returncode != 0:
        raise SystemExit(f"crashscene simulate {case} failed:\n{stderr.decode()[-2000:]}")
    return wall, cpu, peak[0], json.loads(stdout)


def newtonian_seconds(case: Path, k: int, mode: str, tmp: Path) -> tuple[float, float]:
    """([s] wall, [s] CPU) per variation in Scenic's Newtonian simulator, over k variations (compile excluded)."""
    from crashscene.dsl import load_file
    from crashscene.render import render
    from crashscene.render.sample import sample_scenes
    from crashscene.simulate.backend import SimulationRequest, SimulationSettings
    from crashscene.simulate.newtonian import NewtonianSimulator

    scenario = load_file(case)
    rendered = render(scenario, tmp)
    scenes = sample_scenes(rendered.program, k, 0, sampler="scenic")  # Newtonian re-generates Scenic's own scenes
    settings = SimulationSettings(mode=mode)
    program = Path(rendered.program).read_text(encoding="utf-8")
    with NewtonianSimulator(settings) as simulator:
        simulator.compiled(program, Path(rendered.map))
        wall, cpu = time.perf_counter(), time.process_time()
        simulator.simulate(SimulationRequest(scenario, scenes, Path(rendered.map), settings, program=program))
        return (time.perf_counter() - wall) / k, (time.process_time() - cpu) / k


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variations", type=int, default=2000)
    parser.add_argument("--newtonian", type=int, default=20, help="Newtonian runs to time per case (0: skip)")
    parser.add_argument("--mode", choices=("test", "reproduce"), default="test")
    parser.add_argument("--cases", nargs="+", default=DEFAULT_CASES, help="CIREN case ids in examples/ciren")
    args = parser.parse_args()
    warnings.filterwarnings("ignore")
    n = args.variations
    print(f"crashscene simulate FILE -n {n} --mode {args.mode} (default options: compiled sampler, "
          f"--workers {os.cpu_count()}), {os.cpu_count()} cores")
    header = (f"{'case':<8} {'wall s':>7} {'CPU s':>7} {'render':>7} {'sample':>7} {'simul.':>7} {'monitor':>7} "
              f"{'PSS MB':>7} {'newt wall/var':>13} {'newt CPU/var':>12} {'x simul.':>8} {'x wall':>7} {'x CPU':>6}"
              f"  load (1 min)")
    print(header)
    with tempfile.TemporaryDirectory(prefix="bench-simulate-") as tmp:
        for case_id in args.cases:
            case = REPO / "examples" / "ciren" / case_id / "golden.yaml"
            load = os.getloadavg()[0]
            wall, cpu, rss, summary = run_cli(case, n, args.mode, Path(tmp) / case_id)
            t = summary["timings"]
            cols = f"{'-':>13} {'-':>12} {'-':>8} {'-':>7} {'-':>6}"
            if args.newtonian > 0:
                newton_wall, newton_cpu = newtonian_seconds(case, args.newtonian, args.mode,
                                                            Path(tmp) / f"{case_id}-newtonian")
                cols = (f"{newton_wall:13.3f} {newton_cpu:12.3f} {newton_wall * n / t['simulate']:8.0f} "
                        f"{newton_wall * n / wall:7.0f} {newton_cpu * n / cpu:6.0f}")
            print(f"{case_id:<8} {wall:7.2f} {cpu:7.2f} {t['render']:7.2f} {t['sample']:7.2f} {t['simulate']:7.2f} "
                  f"{t.get('monitor', 0.0):7.2f} {rss / 2**20:7.0f} {cols}  {load:.1f} -> {os.getloadavg()[0]:.1f}",
                  flush=True)
    print("targets: wall <= 10 s, memory <= 1536 MB, Newtonian / embedded >= 150x. x simul.: Newtonian wall per "
          "variation over the embedded simulate stage's; x wall: over the whole command's; x CPU: Newtonian CPU per "
          "variation over the whole command's CPU (workers included) per variation, the figure a loaded machine "
          "distorts least. CPU s / cores is about the wall time's floor on an idle machine.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
