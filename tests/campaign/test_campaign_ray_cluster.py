"""`campaign --engine ray --address` against a real two-node Ray cluster started on this machine.

The cluster is two `ray start --block` processes (a head and a second node,
one CPU each, each with its own resources and ports), on a loopback address,
with a token of their own. `crashscene campaign` runs as a subprocess against
it; its rows must equal the local engine's. Teardown stops both nodes by the
process ids this module started (SIGTERM, then SIGKILL of their process groups
after a bounded wait), never with `ray stop`, which would stop every Ray on the
machine.
"""
from __future__ import annotations

import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from crashscene.campaign import CampaignConfig, run_campaign
from tests.campaign.rows import table_rows

pytestmark = pytest.mark.slow
pytest.importorskip("ray")

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples" / "ciren"
# loopback, but not one Ray rewrites to the machine's network address (it does so for 127.0.0.1 and localhost)
HOST = "127.0.0.2"
START_TIMEOUT = 180.0  # [s] for a node to come up on a loaded 2-core machine
STOP_TIMEOUT = 30.0  # [s]
CAMPAIGN_TIMEOUT = 600.0  # [s]
CASES = ["120013", "100237"]


def _free_ports(count: int) -> list[int]:
    socks = []
    try:
        for _ in range(count):
            sock = socket.socket()
            sock.bind(("", 0))
            socks.append(sock)
        return [sock.getsockname()[1] for sock in socks]
    finally:
        for sock in socks:
            sock.close()


def _start_node(args: list[str], env: dict[str, str], log: Path) -> subprocess.Popen:
    ray = Path(sys.executable).parent / "ray"
    with open(log, "w") as fh:  # the child keeps its own descriptor
        return subprocess.Popen([str(ray), "start", "--block", "--disable-usage-stats", f"--node-ip-address={HOST}",
                                 "--num-cpus=1", "--object-store-memory=80000000", *args],
                                env=env, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True)


def _wait_started(proc: subprocess.Popen, log: Path) -> None:
    deadline = time.monotonic() + START_TIMEOUT
    while time.monotonic() < deadline:
        text = log.read_text(errors="replace")
        if "Ray runtime started" in text:
            return
        if proc.poll() is not None:
            raise RuntimeError(f"ray start exited with {proc.returncode}:\n{text[-3000:]}")
        time.sleep(1.0)
    raise TimeoutError(f"ray start did not come up in {START_TIMEOUT:.0f} s:\n{log.read_text(errors='replace')[-3000:]}")


def _stop(proc: subprocess.Popen) -> None:
    """Stop one node this module started: SIGTERM lets `ray start --block` stop its own processes."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=STOP_TIMEOUT)
        except subprocess.TimeoutExpired:
            pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)  # whatever of its process group is left (its own session)
    except ProcessLookupError:
        pass
    proc.wait(timeout=STOP_TIMEOUT)


@pytest.fixture(scope="module")
def ray_cluster(tmp_path_factory):
    """(address, environment) of a two-node cluster: the head and one more node, one CPU each."""
    root = tmp_path_factory.mktemp("ray-cluster")
    short = Path(tempfile.mkdtemp(prefix="csray-", dir="/tmp"))  # Ray's unix sockets need paths under 108 bytes
    env = dict(os.environ, RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(32), RAY_USAGE_STATS_ENABLED="0",
               PYTHONPATH=os.pathsep.join(filter(None, [str(REPO / "src"), str(REPO), os.environ.get("PYTHONPATH")])))
    ports = _free_ports(30)
    address = f"{HOST}:{ports[0]}"
    nodes = []
    try:
        head_log, node_log = root / "head.log", root / "node.log"
        nodes.append(_start_node([
            "--head", f"--port={ports[0]}", "--include-dashboard=false", f"--temp-dir={short}",
            f"--node-manager-port={ports[1]}", f"--object-manager-port={ports[2]}",
            f"--dashboard-agent-listen-port={ports[3]}", f"--dashboard-agent-grpc-port={ports[4]}",
            f"--runtime-env-agent-port={ports[5]}", f"--metrics-export-port={ports[6]}",
            "--worker-port-list=" + ",".join(map(str, ports[14:22])), '--resources={"head_node": 1}'],
            env, head_log))
        _wait_started(nodes[0], head_log)
        nodes.append(_start_node([
            f"--address={address}", f"--node-manager-port={ports[7]}", f"--object-manager-port={ports[8]}",
            f"--dashboard-agent-listen-port={ports[9]}", f"--dashboard-agent-grpc-port={ports[10]}",
            f"--runtime-env-agent-port={ports[11]}", f"--metrics-export-port={ports[12]}",
            "--worker-port-list=" + ",".join(map(str, ports[22:30])), '--resources={"second_node": 1}'],
            env, node_log))
        _wait_started(nodes[1], node_log)
        yield address, env
    finally:
        for proc in reversed(nodes):
            _stop(proc)
        shutil.rmtree(short, ignore_errors=True)


def _cluster_nodes(address: str, env: dict[str, str]) -> list[dict]:
    code = ("import json, ray; ray.init(address=%r, log_to_driver=False, logging_level='ERROR'); "
            "print(json.dumps([{'alive': n['Alive'], 'resources': n['Resources']} for n in ray.nodes()]))" % address)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_campaign_on_a_two_node_ray_cluster_equals_the_local_engine(ray_cluster, tmp_path):
    address, env = ray_cluster
    nodes = [n for n in _cluster_nodes(address, env) if n["alive"]]
    assert len(nodes) == 2 and all(n["resources"].get("CPU") == 1.0 for n in nodes)
    assert {"head_node", "second_node"} <= {key for n in nodes for key in n["resources"]}

    cases = tmp_path / "cases"
    for case in CASES:
        shutil.copytree(EXAMPLES / case, cases / case)
    crashscene = Path(sys.executable).parent / "crashscene"
    done = subprocess.run([str(crashscene), "campaign", str(cases), "-n", "24", "--chunk-size", "8", "--seed", "4",
                           "--engine", "ray", "--address", address, "--dsl", "golden.yaml", "--no-report", "--json",
                           "--out", str(tmp_path / "ray")],
                          env=env, capture_output=True, text=True, timeout=CAMPAIGN_TIMEOUT)
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(done.stdout)
    assert summary["engine"] == "ray" and summary["workers"] == 2  # the cluster's CPUs, not this machine's
    assert summary["chunks_run"] == len(CASES) * 2 * 3 and summary["chunks_failed"] == 0

    config = CampaignConfig(n=24, chunk_size=8, seed=4, dsl_name="golden.yaml", workers=1)
    local = run_campaign([cases / case for case in CASES], tmp_path / "local", config, quiet=True)
    assert local.complete
    for table in ("variations", "violations", "collisions"):
        assert table_rows(tmp_path / "ray", table) == table_rows(tmp_path / "local", table), table
    assert len(table_rows(tmp_path / "ray", "variations")) == len(CASES) * 2 * 24
