"""Benchmark of the Python module and studies (docs/python.md), measured in one run:

1. study throughput (points/s) on a LocalCluster with 1, 2 and 4 worker processes, and on a
   scheduler with 2 separate worker processes (`dask scheduler` + `dask worker`, started as
   they would be on two machines; here on one);
2. per-point overhead of the study machinery (Dask tasks, hashing, Parquet store) against a
   bare loop of `simulate` calls on the same points;
3. the extension's `simulate` against `geardyn simulate` (CLI), process start excluded.

Run: .venv/bin/python scripts/bench_study.py [--points 200] [--stop-time 0.06] [--repeat 15]
Prints a Markdown table. Every cluster is started once and warmed up; then each round runs a
block of `--points` points in every configuration (fresh stores, the order rotating from round
to round). A ratio pairs two blocks of one round and the table gives its median over the rounds
with the quartiles: the speed of this virtual machine changes from second to second, so blocks
minutes apart would not compare. On a shared machine the 2-worker speedup needs a free core.
"""

import argparse
import contextlib
import json
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


def timed_study(client, path: Path):
    """Wall of one study run on ``client`` (a fresh store: every point computed) and the
    workers' time inside its tasks."""
    study = gs.load(path)
    start = time.perf_counter()
    summary = gs.run(study, client=client, progress=False)
    seconds = time.perf_counter() - start
    assert summary.computed == len(study.points()) and summary.failed == 0
    return seconds, summary.task_seconds


@contextlib.contextmanager
def separate_processes():
    """A `dask scheduler` process with two `dask worker` processes (one single-threaded worker
    each, with the environment docs/python.md gives), started as they would be on two
    machines; yields its address."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    bin_dir = Path(os.sys.executable).parent
    # What `geardyn.study.local_cluster` sets, as environment variables (docs/python.md).
    env = dict(os.environ, MALLOC_ARENA_MAX="1", DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL="1s",
               DASK_DISTRIBUTED__ADMIN__SYSTEM_MONITOR__INTERVAL="2s")
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([bin_dir / "dask", "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], env=env, **quiet)]
    try:
        for _ in range(2):
            procs.append(subprocess.Popen([bin_dir / "dask", "worker", address, "--nworkers", "1",
                                           "--nthreads", "1", "--no-dashboard"], env=env, **quiet))
        yield address
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
    """Median walls of alternated rounds after a warm-up, both with the statistics summary: extension
    simulate; CLI long run minus
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
            subprocess.run([CLI, "simulate", path, "--out", out, *extra], check=True,
                           stdout=subprocess.DEVNULL)
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


def run_block(config: str, points: int, stop_time: float) -> dict:
    """One timed block in this (fresh) process: the configuration's cluster is started and
    warmed up (a new worker process is slower on its first points: imports, allocator,
    caches; a real study of 10^4 points pays that once), then `points` points are timed."""
    from distributed import Client

    scene = base_scene(stop_time)
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory()))
        count = iter(range(10**9))

        def fresh(n: int) -> Path:
            folder = tmp / str(next(count))
            folder.mkdir()
            return write_study(folder, scene, n)

        if config == "bare":
            bare_seconds(fresh(20))
            cpu = cpu_seconds()
            return {"wall": bare_seconds(fresh(points)), "cpu": cpu_seconds() - cpu}
        if config == "cli":
            py, cli, start = cli_vs_extension()
            return {"py": py, "cli": cli, "start": start}
        if config == "sched":
            client = stack.enter_context(Client(stack.enter_context(separate_processes()), timeout=60))
            client.wait_for_workers(2, timeout=120)
        else:
            cluster = stack.enter_context(gs.local_cluster(int(config[1:])))
            client = stack.enter_context(Client(cluster))
        timed_study(client, fresh(20 * sum(client.nthreads().values())))
        cpu = cpu_seconds()
        wall, busy = timed_study(client, fresh(points))
        return {"wall": wall, "busy": busy, "cpu": cpu_seconds() - cpu}


def cpu_seconds() -> float:
    """User + system CPU seconds of this process and every process below it (the cluster's
    workers and nannies, or the separate scheduler and workers) so far."""
    import psutil

    me = psutil.Process()
    total = sum(me.cpu_times()[:2])
    for child in me.children(recursive=True):
        try:
            total += sum(child.cpu_times()[:2])
        except psutil.NoSuchProcess:
            pass
    return total


def idle_cost(workers: int, quiet: bool, seconds: float = 5.0) -> float:
    """CPU time an idle `local_cluster(workers)` with a connected client takes, in % of one
    core, with `QUIET_TICKS` (as shipped) or with Dask's default timers."""
    from distributed import Client

    if not quiet:
        gs.QUIET_TICKS = {}
    with gs.local_cluster(workers) as cluster, Client(cluster):
        time.sleep(2.0)
        before = cpu_seconds()
        time.sleep(seconds)
        return (cpu_seconds() - before) / seconds * 100


def block(config: str, args) -> dict:
    """`run_block` in a process of its own: nothing of one configuration (a cluster's event
    loop thread, its idle ticks) is left running in another's."""
    out = subprocess.run([os.sys.executable, __file__, "--block", config, "--points", str(args.points),
                          "--stop-time", str(args.stop_time)], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=200, help="points per block")
    parser.add_argument("--stop-time", type=float, default=0.06)
    parser.add_argument("--repeat", type=int, default=15, help="rounds of alternated blocks")
    parser.add_argument("--block", help=argparse.SUPPRESS)
    parser.add_argument("--idle", action="store_true",
                        help="only the CPU time of idle clusters (1, 2, 4 workers), with Dask's timers as shipped and as Dask sets them")
    args = parser.parse_args()
    if args.block and args.block.startswith("idle"):
        workers, quiet = args.block[4:].split("-")
        print(json.dumps({"percent": idle_cost(int(workers), quiet == "quiet")}))
        return
    if args.idle:
        print("| workers | idle CPU, % of one core, Dask's timers | as shipped (`QUIET_TICKS`) |")
        print("|---:|---:|---:|")
        for w in (1, 2, 4):
            default, quiet = (block(f"idle{w}-{q}", args)["percent"] for q in ("default", "quiet"))
            print(f"| {w} | {default:.1f} | {quiet:.1f} |")
        return
    if args.block:
        print(json.dumps(run_block(args.block, args.points, args.stop_time)))
        return
    n = args.points
    configs = ["bare", "w1", "w2", "w4", "sched"]
    walls = {k: [] for k in configs}
    cpus = {k: [] for k in configs}
    outside = []
    load_start = os.getloadavg()[0]
    for r in range(args.repeat):
        # The order rotates from round to round, so no configuration always follows another.
        for name in configs[r % len(configs):] + configs[:r % len(configs)]:
            result = block(name, args)
            walls[name].append(result["wall"])
            cpus[name].append(result["cpu"])
            if name == "w1":
                outside.append((result["wall"] - result["busy"]) / result["busy"])
    load = os.getloadavg()[0]
    cli = block("cli", args)

    # The CPU time of one solve on this virtual machine varies by up to 1.6x from one second to
    # the next with nothing else running (measured 2026-11-30: blocks of 100 identical solves
    # take 0.80-0.85 s or 1.2-1.5 s), so each ratio pairs two blocks of one round (seconds
    # apart), and the table gives the median over rounds with its quartiles.
    def paired(a, b):
        ratios = sorted(x / y for x, y in zip(walls[a], walls[b]))
        q = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else ratios * 3
        return statistics.median(ratios), q[0], q[2]

    def show(ratio, scale=1.0, shift=0.0, fmt="{:.2f}"):
        m, lo, hi = ((x - shift) * scale for x in ratio)
        return f"{fmt.format(m)} (quartiles {fmt.format(lo)} to {fmt.format(hi)})"

    bare = statistics.median(walls["bare"])
    print(f"machine: {os.cpu_count()} cores, load average {load_start:.2f} at the start and {load:.2f} at the "
          f"end of the timed rounds; {args.repeat} rounds of {n}-point blocks of spur_pair (RK, "
          f"{args.stop_time} s of gear time), each block in a fresh process with its cluster warmed up\n")
    print("| measure | value |")
    print("|---|---|")
    print(f"| bare loop of `simulate` | {bare / n * 1e3:.2f} ms/point ({n / bare:.1f} points/s), "
          f"CPU {statistics.median(cpus['bare']) / n * 1e3:.2f} ms/point |")
    for name, label in (("w1", "1 worker"), ("w2", "2 workers"), ("w4", "4 workers"),
                        ("sched", "scheduler + 2 separate worker processes")):
        print(f"| study, {label} | {n / statistics.median(walls[name]):.1f} points/s, "
              f"CPU {statistics.median(cpus[name]) / n * 1e3:.2f} ms/point |")
    print(f"| speedup 2 vs 1 worker | {show(paired('w1', 'w2'))}× |")
    print(f"| speedup 4 vs 2 workers ({os.cpu_count()} cores) | {show(paired('w2', 'w4'))}× |")
    print(f"| speedup scheduler + 2 separate workers vs 1 worker | {show(paired('w1', 'sched'))}× |")
    print(f"| study overhead per point (1 worker vs bare loop) | "
          f"{show(paired('w1', 'bare'), 100, 1.0, '{:+.1f}')} % |")
    print(f"| of which outside the tasks (scheduling, transfer, store; 1 worker) | "
          f"{statistics.median(outside) * 100:+.1f} % |")
    print(f"| extension `simulate`, 1.0 s RK run | {cli['py'] * 1e3:.1f} ms |")
    print(f"| CLI `simulate`, same run, minus process start ({cli['start'] * 1e3:.1f} ms) | {cli['cli'] * 1e3:.1f} ms |")
    print(f"| extension / CLI | {cli['py'] / cli['cli']:.3f}× |")


if __name__ == "__main__":
    main()
