"""Helpers the Python benchmark drivers share (stdlib only)."""
import contextlib
import os
import signal
import subprocess
import threading
import time


def loadavg():
    """The 1, 5 and 15 minute load averages as strings: every benchmark prints them before
    and after, since the machine may be shared."""
    with open("/proc/loadavg") as f:
        return f.read().split()[:3]


@contextlib.contextmanager
def paused(pattern, limit_s):
    """Stop the processes whose command line matches PATTERN (pgrep -f) for the block, and
    continue them after it, whatever happens. A long background job must not be stopped for
    long (it may hold locks others wait on), so a watchdog continues them after LIMIT_S
    seconds even if the block is still running. Yields a dict: pids, and after the block
    seconds (how long they were stopped) and watchdog (whether it fired first)."""
    r = subprocess.run(["pgrep", "-f", pattern], capture_output=True, text=True)
    pids = [int(p) for p in r.stdout.split() if int(p) != os.getpid()]
    state = {"pids": pids, "watchdog": False}
    lock = threading.Lock()
    resumed = []

    def resume(by_watchdog):
        with lock:
            if resumed:
                return
            resumed.append(True)
            state["watchdog"] = by_watchdog
            for p in pids:
                try:
                    os.kill(p, signal.SIGCONT)
                except ProcessLookupError:
                    pass

    t0 = time.time()
    for p in pids:
        try:
            os.kill(p, signal.SIGSTOP)
        except ProcessLookupError:
            pass
    timer = threading.Timer(limit_s, resume, (True,))
    timer.daemon = True
    timer.start()
    try:
        yield state
    finally:
        timer.cancel()
        resume(False)
        state["seconds"] = time.time() - t0
