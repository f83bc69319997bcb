"""Python stepping against the CLI's run, for the same simulated time (a benchmark, not a
test: time it with a paired timer, e.g. the repository's farm-bench):

    farm-bench -n 10 --vs "agvsim run scenes/lab_offset_120mm.toml --duration 300 --out /tmp/b" -- \\
        python python/benches/step_vs_run.py scenes/lab_offset_120mm.toml 10 300

steps the scene for DURATION s (its ``sim.duration_s`` if not given) in chunks of CHUNK
physics steps and reads the outputs after each chunk, as a controller or a learner
would. The CLI's run also writes its recording and computes its summary. Both are timed
as whole processes: a long simulated time keeps Python's start (about 0.2 s with numpy)
from swamping the stepping.
"""

import sys

import agvsim


def main() -> None:
    scene, chunk = sys.argv[1], int(sys.argv[2])
    duration = float(sys.argv[3]) if len(sys.argv) > 3 else None
    sim = agvsim.Sim(scene if duration is None else agvsim.Scene.load(scene).with_values({"sim.duration_s": duration}))
    steps = int(round(sim.duration / sim.dt))
    done = 0
    while done < steps:
        k = min(chunk, steps - done)
        sim.step(n=k)
        sim.outputs
        done += k
    print(f"t = {sim.time:.3f} s, x = {sim.output('x_m'):.4f} m")


if __name__ == "__main__":
    main()
