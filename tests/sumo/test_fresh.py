"""Calls in a process of their own (enn_traffic/traffic/fresh.py; docs/sumo.md, "One SUMO
start, one process")."""

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.sumo.fresh import fresh, fresh_map


def test_a_call_runs_in_a_new_process_and_its_error_is_raised_here():
    assert fresh(os.getpid) != os.getpid()
    assert fresh_map(math.hypot, [(3, 4), (5, 12), (8, 15)], workers=2) == [5.0, 13.0, 17.0]
    with pytest.raises(InputError, match="no_such_scenario"):
        fresh(shipped_scenario, "no_such_scenario")


def test_a_crash_is_reported_with_its_exit_status():
    from enn_traffic.sumo.fresh import FreshProcessError

    with pytest.raises(FreshProcessError, match="_exit ended with exit status 3"):
        fresh(os._exit, 3)


def test_a_call_sees_the_callers_environment_and_folder_as_they_are_now(monkeypatch, tmp_path):
    """The processes are forked from a process started once: one started before the caller
    changed its environment or folder must not answer for it."""
    monkeypatch.setenv("ENN_TRAFFIC_PROBE", "one")
    assert fresh(os.getenv, "ENN_TRAFFIC_PROBE") == "one"
    monkeypatch.setenv("ENN_TRAFFIC_PROBE", "two")
    monkeypatch.chdir(tmp_path)
    assert fresh(os.getenv, "ENN_TRAFFIC_PROBE") == "two"
    assert fresh(os.getcwd) == str(tmp_path)


def test_the_zygote_outlives_a_change_no_child_reads(monkeypatch):
    """pytest rewrites PYTEST_CURRENT_TEST at every test phase: the zygote (each child's
    parent) stays; a variable a child may read starts another."""
    zygote = fresh(os.getppid)
    monkeypatch.setenv("PYTEST_CURRENT_TEST", "another test (call)")
    assert fresh(os.getppid) == zygote
    monkeypatch.setenv("ENN_TRAFFIC_PROBE", "three")
    assert fresh(os.getppid) != zygote


def test_a_script_without_a_main_guard_may_call_it(tmp_path):
    """multiprocessing's spawn would run the script again in the child; this does not."""
    script = tmp_path / "script.py"
    script.write_text("import math\nfrom enn_traffic.sumo.fresh import fresh\n"
                      "print(fresh(math.hypot, 6, 8))\n")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "10.0"


class _Unpicklable(Exception):
    def __reduce__(self):
        raise TypeError("cannot pickle this exception")


def _raise_unpicklable():
    raise _Unpicklable("Vehicle 'enn_learner' is not known")


def test_an_error_that_does_not_pickle_keeps_its_type_and_message(monkeypatch):
    """libsumo's exceptions do not pickle: the caller still reads what went wrong."""
    from pathlib import Path

    from enn_traffic.sumo.fresh import FreshProcessError

    monkeypatch.setenv("PYTHONPATH", str(Path(__file__).parent))
    with pytest.raises(FreshProcessError, match="_Unpicklable: Vehicle 'enn_learner' is not"):
        fresh(_raise_unpicklable)


def test_an_interrupted_caller_ends_its_fresh_processes_at_once(tmp_path):
    """``kill -INT`` sent to the caller alone (not its process group) while two fresh
    processes sleep for a minute: it ends within seconds, not when they would have."""
    script = tmp_path / "script.py"
    script.write_text("import sys, time\nfrom enn_traffic.sumo.fresh import fresh_calls\n"
                      "print('started', flush=True)\n"
                      "fresh_calls([(time.sleep, 60)] * 2, workers=2)\n")
    inherited = _signal_state(os.getpid())  # this test process's, for a failure's message
    caller = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True,
                              preexec_fn=_sigint_as_a_terminal_gives_it)
    assert caller.stdout.readline().strip() == "started"
    time.sleep(4)  # the two fresh processes are asleep
    interrupted = time.perf_counter()
    caller.send_signal(signal.SIGINT)
    try:
        caller.wait(timeout=50)
    except subprocess.TimeoutExpired:
        state = _signal_state(caller.pid)
        caller.kill()
        raise AssertionError(f"the caller ignored its Ctrl-C; its signals: {state}; this "
                             f"test process's when it started the caller: {inherited}") from None
    assert time.perf_counter() - interrupted < 15
    assert caller.returncode != 0


def _sigint_as_a_terminal_gives_it() -> None:
    """The caller starts as a shell starts a command: SIGINT at its default and unblocked,
    whatever this test process inherited or holds."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _signal_state(pid: int) -> str:
    """A process's blocked, ignored and caught signals (Linux), for a failure's message."""
    try:
        lines = Path(f"/proc/{pid}/status").read_text().splitlines()
    except OSError:
        return "gone"
    return "; ".join(line for line in lines if line.startswith(("SigBlk", "SigIgn", "SigCgt")))
