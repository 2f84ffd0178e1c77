"""Parameter sweeps on Dask (anisofrac.sweep, `main.py sweep`, docs/sweeps.md).

Grids are validated through the scene loader before anything runs; a sweep on a loopback
LocalCluster and one on a real `dask scheduler` + `dask worker` processes write one row per point
whose state hash equals a direct run's (in a separate f32 process: the test session runs f64); a
rerun computes nothing; a worker killed in the middle of a sweep does not stop it.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from anisofrac.sweep import SweepSpec, grid_points, make_security, parse_grid, run_sweep, split_values
from core.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]
PY = sys.executable
DASK = str(Path(sys.executable).with_name("dask"))
SCENE = "tet_cut_31"
FRAMES = 5
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}

DIRECT = """
import json, sys
import anisofrac as af
af.init("cpu", "f32", 1)
scene, frames, points = json.loads(sys.argv[1])
hashes = []
for overrides in points:
    with af.Simulation(af.load_config(scene, overrides)) as sim:
        sim.run(frames, until_settled=False)
        hashes.append(sim.stats()["state_hash"])
print(json.dumps(hashes))
"""


def direct_hashes(scene: str, frames: int, points: list[list[str]]) -> list[str]:
    """State hashes of direct af.Simulation runs (f32, 1 thread) in a fresh process."""
    out = subprocess.run([PY, "-c", DIRECT, json.dumps([scene, frames, points])], cwd=ROOT, env=ENV,
                         capture_output=True, text=True, timeout=600, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def read_rows(out: Path) -> list[dict]:
    import pyarrow.parquet as pq

    return pq.read_table(out / "runs.parquet").to_pylist()


# ---------------------------------------------------------------------------------------- no tasks
def test_values_split_on_commas_outside_brackets_and_quotes():
    assert split_values("[0,0,-4],[0,0,-8]") == ["[0,0,-4]", "[0,0,-8]"]
    assert split_values('"a,b", c ,{x = [1,2]}') == ['"a,b"', "c", "{x = [1,2]}"]
    grid = parse_grid(["objects.ball.velocity=[0,0,-4],[0,0,-8]", "materials.glass.cracks=4,auto"])
    assert grid == {"objects.ball.velocity": ["[0, 0, -4]", "[0, 0, -8]"], "materials.glass.cracks": ["4", '"auto"']}
    assert len(grid_points(grid)) == 4


@pytest.mark.parametrize("grid, key", [
    (["materials.clay.density=2000,-3"], "materials[0].density"),           # out of range
    (["materials.clay.density=2000,\"heavy\""], "materials[0].density"),    # wrong type
    (["materials.clay.densty=2000"], "materials[0].densty"),                # no such key
    (["objects.tet.velocity=[0,0,0],[0,0]"], "objects[0].velocity"),        # a vector of 2
])
def test_bad_grid_values_are_refused_before_any_task(tmp_path, grid, key):
    out = tmp_path / "sweep"
    with pytest.raises(ConfigError) as err:
        run_sweep(SweepSpec(scene=SCENE, grids=grid, out=out, frames=2, workers=1, progress=False))
    assert err.value.key_path == key and key in str(err.value)
    assert not out.exists()  # nothing was started or written


@pytest.mark.parametrize("grid", [[], ["materials.clay.density"], ["materials.clay.density=1,,2"],
                                  ["materials.clay.density=1,1"], ["a=1", "a=2"]])
def test_malformed_grids_are_refused(grid):
    with pytest.raises(ConfigError, match="--grid"):
        parse_grid(grid)


def test_tls_needs_all_three_files(tmp_path):
    with pytest.raises(ConfigError, match="all three"):
        make_security(str(tmp_path / "ca.pem"), None, None)
    with pytest.raises(ConfigError, match="--tls-ca"):
        make_security(*(str(tmp_path / n) for n in ("ca.pem", "c.pem", "k.pem")))
    assert make_security(None, None, None) is None


def test_cli_reports_a_bad_grid_in_one_line(tmp_path):
    out = subprocess.run([PY, "main.py", "sweep", SCENE, "--grid", "materials.clay.density=-1",
                          "--out", str(tmp_path / "s")], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 2
    assert out.stderr.strip().splitlines()[-1].startswith("error: ") and "materials[0].density" in out.stderr
    assert not (tmp_path / "s").exists()


# ---------------------------------------------------------------------------------------- LocalCluster
@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    """Two points on a one-process LocalCluster: the second run shares the worker of the first."""
    out = tmp_path_factory.mktemp("local") / "sweep"
    spec = SweepSpec(scene=SCENE, grids=["materials.clay.density=2000,3000"], frames=FRAMES, out=out, workers=1,
                     dataset=True, progress=False)
    t0 = time.perf_counter()
    result = run_sweep(spec)
    return spec, result, out, time.perf_counter() - t0


@pytest.mark.slow
def test_local_cluster_rows_match_direct_runs(local_sweep):
    spec, result, out, _ = local_sweep
    assert (result.points, result.computed, result.ok, result.failed) == (2, 2, 2, 0)
    rows = read_rows(out)
    assert [r["status"] for r in rows] == ["ok", "ok"]
    assert sorted(r["param.materials.clay.density"] for r in rows) == ["2000", "3000"]
    assert sorted(r["param_value.materials.clay.density"] for r in rows) == [2000.0, 3000.0]
    assert all(r["fragments_total"] == 2 and r["fracture_events"] == 1 for r in rows)
    points = [json.loads(r["overrides"]) for r in rows]
    assert [r["state_hash"] for r in rows] == direct_hashes(SCENE, FRAMES, points)
    assert len({r["state_hash"] for r in rows}) == 2


@pytest.mark.slow
def test_rerun_computes_nothing_new(local_sweep):
    spec, _, out, _ = local_sweep
    before = read_rows(out)
    again = run_sweep(spec)
    assert (again.computed, again.skipped, again.ok) == (0, 2, 2)
    assert read_rows(out) == before


@pytest.mark.slow
def test_sweep_run_equals_main_py_run(local_sweep, tmp_path):
    _, _, out, _ = local_sweep
    row = next(r for r in read_rows(out) if r["param.materials.clay.density"] == "3000")
    run = subprocess.run([PY, "main.py", "run", SCENE, "--set", "materials.clay.density=3000", "--frames",
                          str(FRAMES), "--renderer", "none", "--video", "none", "--all-frames", "--no-progress",
                          "--out", str(tmp_path / "run")], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    stats = json.loads((tmp_path / "run" / "stats.json").read_text())
    assert stats["state_hash"] == row["state_hash"]


@pytest.mark.slow
def test_plots_summary_and_dataset(local_sweep):
    _, _, out, _ = local_sweep
    assert (out / "fragments_vs_materials.clay.density.png").stat().st_size > 1000
    summary = (out / "summary.md").read_text()
    assert "2 ok, 0 failed" in summary and "materials.clay.density" in summary
    for row in read_rows(out):
        folder = out / "dataset" / row["key"]
        params = json.loads((folder / "params.json").read_text())
        assert params["state_hash"] == row["state_hash"]
        events = json.loads((folder / "cracks.json").read_text())["events"]
        assert events[0]["scripted"] and events[0]["cracks"][0]["normal"] == [0.0, 1.0, 0.0]
        assert (folder / "fragments.ply").read_bytes().startswith(b"ply")
    # the layout is the one its JSON Schema documents (copied beside the runs)
    import jsonschema

    schema = json.loads((out / "dataset" / "schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    for row in read_rows(out):
        folder = out / "dataset" / row["key"]
        files = {name: json.loads((folder / name).read_text()) for name in ("cracks.json", "params.json")}
        jsonschema.validate(files, schema, cls=jsonschema.Draft202012Validator)
    bad = dict(files, **{"params.json": {**files["params.json"], "frames": 0}})
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, schema, cls=jsonschema.Draft202012Validator)


# ---------------------------------------------------------------------------------------- a real cluster
def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(procs: list[subprocess.Popen]) -> None:
    """Workers first, then the scheduler, one by one: SIGTERM, and SIGKILL for one not ended in 15 s."""
    for p in procs[::-1]:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(timeout=30)


def start_cluster(folder: Path, address: str, names: tuple[str, ...], tls: list[str], security=None):
    """`dask scheduler` and one `dask worker --nthreads 1` process per name on 127.0.0.1, as separate
    processes (`tls`: the scheduler's and workers' --tls-* options). Returns ({worker name: process}, every
    process, the log file) once the workers have joined."""
    from distributed import Client

    logs = open(folder / "dask.log", "w")  # noqa: SIM115 - closed by the caller
    port = address.rsplit(":", 1)[1]
    procs = [subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", port, "--no-dashboard", *tls]
                              + (["--protocol", "tls"] if tls else []), cwd=folder, env=ENV, stdout=logs, stderr=logs)]
    workers = {}
    try:
        for name in names:
            workers[name] = subprocess.Popen(
                [DASK, "worker", address, "--nthreads", "1", "--no-nanny", "--name", name, "--host", "127.0.0.1",
                 "--no-dashboard", *tls], cwd=folder, env=ENV, stdout=logs, stderr=logs)
            procs.append(workers[name])
        deadline = time.monotonic() + 120
        while True:
            try:
                with Client(address, timeout=10, security=security) as client:
                    client.wait_for_workers(len(names), timeout=110)
                break
            except (OSError, TimeoutError):
                if time.monotonic() > deadline:
                    raise
                time.sleep(1)
    except BaseException:
        _stop(procs)
        logs.close()
        raise
    return workers, procs, logs


@pytest.fixture
def dask_cluster(tmp_path):
    """A plain-TCP scheduler and two workers (wA, wB); yields the address and {worker name: process};
    every process is stopped at teardown."""
    address = f"tcp://127.0.0.1:{free_port()}"
    workers, procs, logs = start_cluster(tmp_path, address, ("wA", "wB"), [])
    try:
        yield address, workers
    finally:
        _stop(procs)
        logs.close()


@pytest.mark.slow
def test_sweep_on_a_dask_scheduler_survives_a_killed_worker(dask_cluster, tmp_path):
    address, workers = dask_cluster
    killed = []

    def kill_the_other_worker(row):  # after the first result, kill a worker that is busy
        if not killed:
            name = next(n for n in workers if n != row["worker"])
            workers[name].kill()
            workers[name].wait(timeout=30)
            killed.append(name)

    spec = SweepSpec(scene=SCENE, grids=["materials.clay.density=2000,3000", "objects.tet.velocity=[0,0,0],[0.5,0,0]"],
                     frames=30, out=tmp_path / "sweep", scheduler=address, progress=False)
    result = run_sweep(spec, on_row=kill_the_other_worker)
    assert killed
    assert (result.points, result.ok, result.failed) == (4, 4, 0)
    rows = read_rows(tmp_path / "sweep")
    assert len(rows) == 4 and {r["status"] for r in rows} == {"ok"}
    points = [json.loads(r["overrides"]) for r in rows]
    assert [r["state_hash"] for r in rows] == direct_hashes(SCENE, 30, points)

    again = run_sweep(spec)  # the surviving worker is still there: the rerun finds every point done
    assert (again.computed, again.skipped, again.ok) == (0, 4, 4)
    assert read_rows(tmp_path / "sweep") == rows


# ---------------------------------------------------------------------------------------- TLS
def write_tls_files(folder: Path) -> dict[str, str]:
    """A throw-away certificate authority and one certificate for 127.0.0.1 signed by it (PEM files),
    used by the scheduler, the worker and the client alike. Returns {"ca", "cert", "key"}: paths."""
    import datetime
    import ipaddress

    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    now = datetime.datetime.now(datetime.timezone.utc)
    life = (now - datetime.timedelta(minutes=5), now + datetime.timedelta(days=1))

    def build(subject, issuer, public_key, signer, ca: bool):
        b = (x509.CertificateBuilder().subject_name(subject).issuer_name(issuer).public_key(public_key)
             .serial_number(x509.random_serial_number()).not_valid_before(life[0]).not_valid_after(life[1])
             .add_extension(x509.BasicConstraints(ca=ca, path_length=None), critical=True))
        if not ca:
            b = b.add_extension(x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]),
                                critical=False)
        return b.sign(signer, hashes.SHA256())

    ca_key, key = ec.generate_private_key(ec.SECP256R1()), ec.generate_private_key(ec.SECP256R1())
    ca_name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "anisofrac test CA")])
    me = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "127.0.0.1")])
    ca_cert = build(ca_name, ca_name, ca_key.public_key(), ca_key, ca=True)
    cert = build(me, ca_name, key.public_key(), ca_key, ca=False)
    files = {"ca": folder / "ca.pem", "cert": folder / "cert.pem", "key": folder / "key.pem"}
    files["ca"].write_bytes(ca_cert.public_bytes(serialization.Encoding.PEM))
    files["cert"].write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    files["key"].write_bytes(key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                               serialization.NoEncryption()))
    return {k: str(v) for k, v in files.items()}


@pytest.mark.slow
def test_sweep_on_a_tls_scheduler(tmp_path):
    """`main.py sweep --scheduler tls://... --tls-ca/--tls-cert/--tls-key` against a scheduler and a worker
    that accept TLS only: the row is the direct run's; a client without the certificates gets a one-line
    error naming --scheduler and nothing is computed."""
    tls = write_tls_files(tmp_path)
    address = f"tls://127.0.0.1:{free_port()}"
    _, procs, logs = start_cluster(tmp_path, address, ("wT",),
                                   ["--tls-ca-file", tls["ca"], "--tls-cert", tls["cert"], "--tls-key", tls["key"]],
                                   security=make_security(tls["ca"], tls["cert"], tls["key"]))
    grid = "materials.clay.density=2500"
    try:
        plain = subprocess.run([PY, "main.py", "sweep", SCENE, "--grid", grid, "--frames", str(FRAMES),
                                "--scheduler", address.replace("tls://", "tcp://"), "--out", str(tmp_path / "plain")],
                               cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=300)
        sweep = subprocess.run([PY, "main.py", "sweep", SCENE, "--grid", grid, "--frames", str(FRAMES),
                                "--scheduler", address, "--tls-ca", tls["ca"], "--tls-cert", tls["cert"],
                                "--tls-key", tls["key"], "--out", str(tmp_path / "tls")],
                               cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=600)
    finally:
        _stop(procs)
        logs.close()
    assert plain.returncode == 2 and plain.stderr.strip().splitlines()[-1].startswith("error: --scheduler")
    assert not (tmp_path / "plain" / "runs.parquet").exists()
    assert sweep.returncode == 0, sweep.stderr
    rows = read_rows(tmp_path / "tls")
    assert [(r["status"], r["worker"]) for r in rows] == [("ok", "wT")]
    assert rows[0]["state_hash"] == direct_hashes(SCENE, FRAMES, [[grid]])[0]
