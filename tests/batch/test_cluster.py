"""A batch on a running Dask cluster: a `dask scheduler` and two `dask worker` processes on
127.0.0.1, started here.  The results equal the local process pool's; a worker killed in the
middle of the batch loses nothing and duplicates nothing (each drive ends with one set of
outputs and one manifest)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sideslip.batch import run_batch
from sideslip.batch.manifest import MANIFEST_SUFFIX, complete, fingerprint
from sideslip.drive import save_drive
from tests.conftest import sim_drive

pytest.importorskip("distributed", reason="dask[distributed] extra not installed")
pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("ignore::DeprecationWarning")]

N_DRIVES = 10
METHODS = ["obs_kinematic", "fused"]


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _start(args: list[str], log: Path) -> subprocess.Popen[bytes]:
    with open(log, "wb") as out:  # the child keeps its own copy of the descriptor
        return subprocess.Popen(
            [sys.executable, "-m", "dask", *args], stdout=out, stderr=subprocess.STDOUT,
            env={**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}, start_new_session=True,
        )  # fmt: skip


def _wait_for_workers(address: str, n: int, timeout_s: float = 60.0) -> None:
    from dask.distributed import Client

    with Client(address, timeout=timeout_s) as client:
        client.wait_for_workers(n, timeout=timeout_s)


@pytest.fixture
def cluster(tmp_path):
    """(address, [worker processes]); every process is killed at the end, pass or fail."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = [_start(["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                    tmp_path / "scheduler.log")]
    try:
        workers = []
        for i in range(2):
            workers.append(_start(
                ["worker", address, "--host", "127.0.0.1", "--worker-port", str(_free_port()),
                 "--nthreads", "1", "--no-nanny", "--no-dashboard", "--name", f"w{i}"],
                tmp_path / f"worker{i}.log",
            ))  # fmt: skip
        procs += workers
        _wait_for_workers(address, 2)
        yield address, workers
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.kill()
        for p in procs:
            p.wait(timeout=30)


def _fleet(tmp_path: Path) -> list[str]:
    """Ten drives named drive.parquet in ten folders (steps and slaloms, several seeds)."""
    paths = []
    for i in range(N_DRIVES):
        p = tmp_path / "fleet" / f"car{i}" / "drive.parquet"
        p.parent.mkdir(parents=True)
        save_drive(sim_drive("step_steer" if i % 2 else "slalom_low_mu", seed=i // 2), p)
        paths.append(str(p))
    return paths


def test_cluster_run_equals_the_pool_and_survives_a_killed_worker(tmp_path, cluster):
    address, workers = cluster
    drives = _fleet(tmp_path)
    pool = run_batch(drives, "seed003_sedan", tmp_path / "pool", METHODS, workers=2)
    on_cluster = run_batch(drives, "seed003_sedan", tmp_path / "cluster", METHODS, scheduler=address)
    assert [r.status for r in on_cluster] == ["run"] * N_DRIVES
    assert [(r.key, r.metrics) for r in on_cluster] == [(r.key, r.metrics) for r in pool]

    # second batch: kill one worker as soon as the first drive is back
    done_at_kill: list[int] = []
    seen: list[str] = []

    def kill_on_first(res) -> None:
        seen.append(res.key)
        if not done_at_kill:
            done_at_kill.append(len(seen))
            os.kill(workers[0].pid, signal.SIGKILL)

    out = tmp_path / "killed"
    start = time.perf_counter()
    res = run_batch(drives, "seed003_sedan", out, METHODS, scheduler=address, progress=kill_on_first)
    assert workers[0].wait(timeout=10) == -signal.SIGKILL
    assert done_at_kill == [1]  # the kill came with N_DRIVES - 1 drives still to do
    assert time.perf_counter() - start < 60.0
    # every drive completed, each reported once, with the pool's figures
    assert sorted(seen) == sorted(r.key for r in pool)
    assert [(r.key, r.status, r.metrics) for r in res] == [(r.key, "run", r.metrics) for r in pool]
    # exactly one estimate, params file and manifest per drive; no temporary file left
    assert len(list(out.rglob("*_est.parquet"))) == N_DRIVES
    assert len(list(out.rglob("*_est.params.json"))) == N_DRIVES
    manifests = list(out.rglob("*" + MANIFEST_SUFFIX))
    assert len(manifests) == N_DRIVES
    assert not [p for p in out.rglob("*") if p.name.endswith(".part")]
    # and each manifest vouches for its outputs' content (what --resume relies on)
    import json

    for r in res:
        stored = json.loads((out / (r.key + MANIFEST_SUFFIX)).read_text())
        fp = fingerprint(stored["drive_sha256"], stored["vehicle_sha256"], METHODS, stored["settings"])
        assert complete(str(out), r.key, fp) is not None
