"""Benchmark of the Python module and studies (docs/python.md), measured in one run:

1. study throughput (points/s) on a LocalCluster with 1, 2 and 4 worker processes, and on a
   scheduler with 2 separate worker processes (`dask scheduler` + `dask worker`, started as
   they would be on two machines; here on one);
2. per-point overhead of the study machinery (Dask tasks, hashing, Parquet store) against a
   bare loop of `simulate` calls on the same points;
3. the extension's `simulate` against `geardyn simulate` (CLI), process start excluded.

Run: .venv/bin/python scripts/bench_study.py [--points 300] [--stop-time 0.06] [--repeat 5]
Prints a Markdown table. Each wall is the median of `--repeat` rounds within this one run, the
measured configurations alternating within each round (so a change of load from other processes
hits all alike), after a warm-up; on a shared machine the 2-worker speedup needs a free core.
"""

import argparse
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import geardyn
from geardyn import study as gs

REPO = Path(__file__).resolve().parents[1]
CLI = REPO / "target" / "release" / "geardyn"


def base_scene(stop_time: float) -> "geardyn.Scene":
    # The RK path: its cost per point is set by stop_time (about 10 ms at 0.06 s of gear time
    # with 600 output rows; the scene's own 1e-5 s interval would make sampling the larger part).
    scene = geardyn.Scene.from_file(REPO / "fmu" / "spur_pair")
    scene.update({"solver.method": "rk", "solver.stop_time": stop_time, "solver.output_interval": 1e-4})
    return scene


def write_study(folder: Path, scene, points: int) -> Path:
    (folder / "scene.toml").write_text(scene.to_toml())
    path = folder / "study.toml"
    path.write_text(
        'scene = "scene.toml"\n'
        'results = ["dte_rms", "peak_force", "dynamic_factor", "contact_loss_fraction"]\n'
        "[[parameter]]\n"
        'path = "operating.pinion_speed"\n'
        f"from = 300.0\nto = 520.0\npoints = {points}\n"
        "[analysis]\n"
        'kind = "simulate"\n'
    )
    return path


def study_seconds(path: Path, workers: int, warmup: Path):
    """Wall of one study run on a started cluster that has run a short warm-up study (a new
    worker process is slower on its first points: imports, allocator, caches; a real study
    of 10^4 points pays that once). Cluster start and warm-up are not per point."""
    from distributed import Client

    with gs.local_cluster(workers) as cluster, Client(cluster) as client:
        return timed_study(client, path, warmup)


def timed_study(client, path: Path, warmup: Path):
    """The warm-up study, then the wall and the workers' time in the points of the study at
    ``path``, on ``client``; every point must be computed."""
    gs.run(gs.load(warmup), client=client, progress=False)
    study = gs.load(path)
    start = time.perf_counter()
    summary = gs.run(study, client=client, progress=False)
    seconds = time.perf_counter() - start
    assert summary.computed == len(study.points()) and summary.failed == 0
    return seconds, summary.task_seconds


def scheduler_seconds(path: Path, warmup: Path):
    """Wall of one study run on a `dask scheduler` process with two `dask worker` processes
    (one single-threaded worker each, MALLOC_ARENA_MAX=1 as docs/python.md says), after the
    same warm-up; the processes are started before and stopped after (not timed)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    bin_dir = Path(os.sys.executable).parent
    env = dict(os.environ, MALLOC_ARENA_MAX="1")
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([bin_dir / "dask", "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], env=env, **quiet)]
    try:
        from distributed import Client

        for _ in range(2):
            procs.append(subprocess.Popen([bin_dir / "dask", "worker", address, "--nworkers", "1",
                                           "--nthreads", "1", "--no-dashboard"], env=env, **quiet))
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
            return timed_study(client, path, warmup)[0]
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=60)


def bare_seconds(path: Path) -> float:
    """The same points in a plain loop: copy the scene, set the point, simulate."""
    study = gs.load(path)
    base = study.base_scene()
    start = time.perf_counter()
    for point in study.points():
        scene = base.copy()
        scene.update(point)
        geardyn.simulate(scene)
    return time.perf_counter() - start


def cli_vs_extension(repeats: int = 7):
    """Median walls of alternated rounds after a warm-up: extension simulate; CLI long run minus
    CLI minimal run (process start, scene read and a 2-row CSV: what the extension does not
    do)."""
    scene = base_scene(1.0)
    scene["solver.output_interval"] = 1e-4
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.toml"
        path.write_text(scene.to_toml())
        out = Path(tmp) / "out.csv"

        def cli(*extra):
            start = time.perf_counter()
            subprocess.run([CLI, "simulate", path, "--out", out, "--quiet", *extra], check=True)
            return time.perf_counter() - start

        walls = {"py": [], "long": [], "short": []}
        geardyn.simulate(scene)
        cli()
        for _ in range(repeats):
            start = time.perf_counter()
            geardyn.simulate(scene)
            walls["py"].append(time.perf_counter() - start)
            walls["long"].append(cli())
            walls["short"].append(cli("--stop-time", "1e-4"))
    med = {k: statistics.median(v) for k, v in walls.items()}
    return med["py"], med["long"] - med["short"], med["short"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=300)
    parser.add_argument("--stop-time", type=float, default=0.06)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    scene = base_scene(args.stop_time)
    load_start = os.getloadavg()[0]
    walls = {"bare": [], "w1": [], "w2": [], "w4": [], "sched": []}
    in_tasks = []
    for r in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            # Fresh stores: every run computes every point.
            folders = {}
            # Warm-up studies, 20 points per worker, each in a store of its own.
            warm = {"warm1": 20, "warm2": 40, "warm4": 80, "warm_sched": 40}
            for name in [*walls, *warm]:
                (Path(tmp) / name).mkdir()
                n = args.points if name in walls else warm[name]
                folders[name] = write_study(Path(tmp) / name, scene, n)
            walls["bare"].append(bare_seconds(folders["bare"]))
            wall, busy = study_seconds(folders["w1"], 1, folders["warm1"])
            walls["w1"].append(wall)
            in_tasks.append((wall, busy))
            walls["w2"].append(study_seconds(folders["w2"], 2, folders["warm2"])[0])
            walls["w4"].append(study_seconds(folders["w4"], 4, folders["warm4"])[0])
            walls["sched"].append(scheduler_seconds(folders["sched"], folders["warm_sched"]))
    bare, one, two, four, sched = (statistics.median(walls[k]) for k in ("bare", "w1", "w2", "w4", "sched"))
    # Ratios are paired within a round (the configurations ran minutes apart at most), then the
    # median over rounds: the CPU time of one solve varies by up to 30 % over minutes on a
    # virtual machine with nothing else running (measured 2026-11-30), and a ratio of medians
    # would pair a fast round of one configuration with a slow round of another.
    def paired(a, b):
        return statistics.median(x / y for x, y in zip(walls[a], walls[b]))
    # The 1-worker round of median wall, with its time inside the tasks.
    wall1, busy1 = sorted(in_tasks)[len(in_tasks) // 2]
    py, cli, start = cli_vs_extension()
    n = args.points
    per_point = bare / n
    load = os.getloadavg()[0]
    print(f"machine: {os.cpu_count()} cores, load average {load_start:.1f} at the start and {load:.1f} at the end; "
          f"{n} points of spur_pair (RK, {args.stop_time} s of gear time)\n")
    print("| measure | value |")
    print("|---|---|")
    print(f"| bare loop of `simulate` | {per_point * 1e3:.2f} ms/point ({n / bare:.1f} points/s) |")
    print(f"| study, 1 worker | {n / one:.1f} points/s |")
    print(f"| study, 2 workers | {n / two:.1f} points/s |")
    print(f"| study, 4 workers | {n / four:.1f} points/s |")
    print(f"| study, scheduler + 2 separate worker processes | {n / sched:.1f} points/s |")
    print(f"| speedup 2 vs 1 worker (median of the rounds' ratios) | {paired('w1', 'w2'):.2f}× |")
    print(f"| 4 workers vs 2 workers ({os.cpu_count()} cores) | {paired('w2', 'w4'):.2f}× |")
    print(f"| study overhead per point (1 worker vs bare loop) | {(paired('w1', 'bare') - 1) * per_point * 1e3:+.2f} ms = {(paired('w1', 'bare') - 1) * 100:+.1f} % |")
    print(f"| of which outside the tasks (scheduling, transfer, store; 1 worker) | {(wall1 - busy1) / n * 1e3:.2f} ms = {(wall1 - busy1) / busy1 * 100:+.1f} % |")
    print(f"| extension `simulate`, 1.0 s RK run | {py * 1e3:.1f} ms |")
    print(f"| CLI `simulate`, same run, minus process start ({start * 1e3:.1f} ms) | {cli * 1e3:.1f} ms |")
    print(f"| extension / CLI | {py / cli:.3f}× |")


if __name__ == "__main__":
    main()
