"""Long calls release the GIL and Ctrl-C interrupts them."""

import signal
import subprocess
import sys
import threading
import time

import agvsim

LAB = "scenes/lab_offset_120mm.toml"


def test_a_long_call_lets_other_python_threads_run(root):
    started, done = threading.Event(), threading.Event()
    result = {}

    def work():
        started.set()
        result["rec"] = agvsim.run(root / LAB, duration_s=300)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    started.wait()
    beats = 0
    while not done.is_set():
        beats += 1
        time.sleep(0.001)
    t.join()
    # Held, the GIL would stop this thread for the whole run: a handful of beats at most.
    assert beats > 100, beats
    assert result["rec"].t_s[-1] == 300.0


CHILD = """
import signal, sys, agvsim
# Python's own Ctrl-C handler even where the child was started with SIGINT ignored (a
# shell's background job, as a CI script under nohup runs it).
signal.signal(signal.SIGINT, signal.default_int_handler)
print("start", flush=True)
try:
    if sys.argv[1] == "run":
        agvsim.run(sys.argv[2], duration_s=9000)
    else:
        agvsim.sweep(sys.argv[2], {"controller.gain_scale": "0.5..4:200"}, duration_s=200,
                     out=sys.argv[3], jobs=1)
    print("returned", flush=True)
except KeyboardInterrupt:
    print("interrupted", flush=True)
"""


def interrupted(args, root):
    p = subprocess.Popen([sys.executable, "-c", CHILD, *args], cwd=root, stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "start"
    time.sleep(1.0)
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=120)
    return out


def test_ctrl_c_interrupts_a_run(root):
    assert interrupted(["run", LAB], root).strip() == "interrupted"


def test_ctrl_c_stops_a_sweep_which_keeps_what_it_finished(root, tmp_path):
    out = tmp_path / "sweep"
    assert interrupted(["sweep", LAB, str(out)], root).strip() == "interrupted"
    # The runs finished are kept for `resume`; the results table is not written whole.
    kept = (out / "results.csv.partial").read_text().splitlines()
    assert 1 < len(kept) < 201, len(kept)
    assert not (out / "results.csv").exists()
