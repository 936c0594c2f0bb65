"""Python-input fuzzer (issue 34, acceptance 4): 1 200 bad inputs (input_fuzz.py: scenes from
dicts with hostile values, keys, depths and cycles; TOML texts; counts, speeds and scene paths
the API refuses; study specs), each run in a subprocess, never in the test's own interpreter.
Every one must end in a Python exception; a dead interpreter (a signal, an abort, an exit),
a hang or a call that returns fails the test, naming the input.

Starting one interpreter per input (import numpy and geardyn: ~0.3 s) would cost minutes, so
each of two worker processes runs a share of the inputs one at a time and reports the start and
the end of each: the input a worker was running when it died is known, and the remaining
inputs continue in a fresh worker. Replay one input with `python tests/python/input_fuzz.py I`.
"""

import os
import pathlib
import select
import subprocess
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
CASES = 1200
WORKERS = 2
# Far above any input's time (the slowest, a 100 000-deep structure, takes well under 1 s).
HANG_SECONDS = 60.0


class Worker:
    """A worker process running `indices` in order, one at a time."""

    def __init__(self, indices, env=None):
        self.env = env
        self.pending = list(indices)
        self.current = None
        self.since = None
        self.proc = None
        self.buffer = b""
        self.start()

    def start(self):
        self.proc = subprocess.Popen(
            [sys.executable, str(HERE / "input_fuzz.py"), "--worker"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env=self.env,
        )
        self.buffer = b""
        self.feed()

    def feed(self):
        """Sends the next index (one at a time, so a death names its input)."""
        if self.pending:
            self.current = self.pending.pop(0)
            self.since = time.monotonic()
            self.proc.stdin.write(f"{self.current}\n".encode())
            self.proc.stdin.flush()
        else:
            self.current = None
            self.proc.stdin.close()

    def lines(self):
        data = os.read(self.proc.stdout.fileno(), 65536)
        if not data:
            return None
        self.buffer += data
        *complete, self.buffer = self.buffer.split(b"\n")
        return [c.decode() for c in complete]


def run_all(indices, env=None):
    outcomes, deaths = {}, []
    shares = [indices[w::WORKERS] for w in range(WORKERS)]
    workers = [Worker(s, env) for s in shares if s]
    while any(w.current is not None for w in workers):
        live = [w for w in workers if w.current is not None]
        ready, _, _ = select.select([w.proc.stdout for w in live], [], [], 1.0)
        for w in live:
            if w.proc.stdout in ready:
                lines = w.lines()
                if lines is None:  # the interpreter is gone: the running input killed it
                    code = w.proc.wait()
                    deaths.append((w.current, f"worker died (exit status {code})"))
                    w.start()
                    continue
                for line in lines:
                    parts = line.split()
                    if parts[:1] == ["done"] and int(parts[1]) == w.current:
                        outcomes[w.current] = (parts[2], parts[3])
                        w.feed()
            elif time.monotonic() - w.since > HANG_SECONDS:
                w.proc.kill()
                w.proc.wait()
                deaths.append((w.current, f"no answer after {HANG_SECONDS} s"))
                w.start()
    for w in workers:
        w.proc.wait()
    return outcomes, deaths


def test_bad_inputs_raise_and_never_kill_the_interpreter():
    t0 = time.monotonic()
    outcomes, deaths = run_all(list(range(CASES)))
    returned = sorted(i for i, (_, o) in outcomes.items() if o == "RETURNED")
    exceptions, kinds = {}, {}
    for kind, o in outcomes.values():
        exceptions[o] = exceptions.get(o, 0) + 1
        kinds[kind] = kinds.get(kind, 0) + 1
    summary = (
        f"python input fuzzer: {CASES} inputs, {len(outcomes)} answered, "
        f"{len(outcomes) - len(returned)} exceptions {dict(sorted(exceptions.items()))}, "
        f"by kind {dict(sorted(kinds.items()))}, "
        f"{len(returned)} returned, {len(deaths)} dead interpreters or hangs, "
        f"{time.monotonic() - t0:.1f} s"
    )
    print(summary)
    assert not deaths, f"{summary}\n" + "\n".join(f"input {i}: {why}" for i, why in deaths[:20])
    assert not returned, f"{summary}\ninputs that returned instead of raising: {returned[:20]}"
    assert len(outcomes) == CASES, summary
    # Every kind of input is exercised.
    assert len(kinds) == 8 and min(kinds.values()) >= 40, summary


def test_the_harness_names_the_input_that_killed_its_interpreter():
    """The harness itself: a worker that segfaults in input 3 is reported with that input, and
    the inputs after it still run (in a fresh worker)."""
    env = dict(os.environ, INPUT_FUZZ_SELFTEST_CRASH="3")
    outcomes, deaths = run_all(list(range(12)), env)
    assert [i for i, _ in deaths] == [3], deaths
    assert "-11" in deaths[0][1], deaths
    assert sorted(outcomes) == [i for i in range(12) if i != 3]
