"""Same bits on other machines: where they differ, what pinning fixes, what is left.

Other machines are played on this one, each by a subprocess started with the environment that
makes its libraries take another code path: ``OPENBLAS_CORETYPE`` (the BLAS kernel a CPU of
another generation would get), ``NPY_DISABLE_CPU_FEATURES`` (NumPy without AVX-512) and
``GLIBC_TUNABLES=glibc.cpu.hwcaps=-FMA`` (glibc's libm on a CPU without FMA). Three parts:

- **controller**: the arm's torques for one state (the first substep of libero_90/42's settle),
  from robosuite's OSC (Numba, LAPACK, BLAS) and from ``libero_data.sim.osc``, per machine;
- **episodes**: expert episodes (actions and states hashed) per machine, unpinned
  (``LIBERO_DATA_NUMERICS=native``) and pinned as the tools run;
- **drift**: how far a replay on a CPU without FMA departs from episodes made here.

Prints Markdown and, with ``--results``, replaces the "Same bits on other machines" section of
``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

from libero_data.numerics import NUMPY_AVX512, OPT_OUT, cpu_flags, libm_uses_fma

ROOT = Path(__file__).resolve().parents[1]
NO_AVX512 = " ".join(NUMPY_AVX512)
#: name -> environment of a played machine (kernels every CPU that runs MuJoCo can run).
MACHINES = {
    "native": {OPT_OUT: "native"},
    "Nehalem kernel": {OPT_OUT: "native", "OPENBLAS_CORETYPE": "Nehalem"},
    "Sandybridge kernel, NumPy without AVX-512": {
        OPT_OUT: "native",
        "OPENBLAS_CORETYPE": "Sandybridge",
        "NPY_DISABLE_CPU_FEATURES": NO_AVX512,
    },
    "pinned": {},
    "pinned, Nehalem kernel asked for": {"OPENBLAS_CORETYPE": "Nehalem"},
}
DEFAULT_TASKS = [
    "libero_spatial/0",
    "libero_object/1",
    "libero_goal/3",
    "libero_goal/5",
    "libero_10/0",
    "libero_90/42",
    "libero_90/8",
    "libero_90/89",
]
DRIFT_TASKS = ["libero_90/42", "libero_10/0", "libero_goal/3"]


def _digest(*arrays: object) -> str:
    import numpy as np

    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:12]


# ------------------------------------------------------------------------------------------
# what one played machine computes (run in a subprocess)


def child_controller() -> dict[str, object]:
    """Torques of robosuite's controller and of ours for the first substep of a settle."""
    import numpy as np

    from libero_data.numerics import machine_fingerprint
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    task = get_task("libero_90/42")
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        env.reset(task.init_states()[1], seed=1, render=False)
        arm = env._stepper.arms[0]
        c = arm.controller
        c.update(force=True)
        inputs = _digest(c.J_full, c.mass_matrix, c.ee_pos, c.ee_ori_mat, c.joint_pos, c.joint_vel)
        noop = np.zeros(6)
        arm.osc.set_goal(noop)
        ours = arm.osc.torques().copy()
        type(c).set_goal(c, noop)
        c.new_update = False
        theirs = type(c).run_controller(c).copy()
    return {
        "kernel": "/".join(sorted({b["kernel"] for b in machine_fingerprint()["blas"]})),
        "inputs": inputs,
        "robosuite": theirs.tolist(),
        "ours": ours.tolist(),
    }


def child_episodes(tasks: list[str], starts: int) -> dict[str, object]:
    """Hashes of expert episodes (stored inits 0..starts-1, the expert report's seeds)."""
    from libero_data.experts import Expert
    from libero_data.numerics import machine_fingerprint
    from libero_data.seeding import episode_seeds
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    out = {}
    for ref in tasks:
        task = get_task(ref)
        with LiberoEnv(task, EnvConfig(cameras=())) as env:
            expert = Expert(env)
            for i in range(starts):
                reset_seed, seed = episode_seeds(0, task.id, i)
                ep = expert.run(task.init_states()[i], reset_seed=reset_seed, seed=seed)
                out[f"{ref}#{i}"] = [ep.success, ep.length, _digest(ep.actions, ep.states)]
    fp = machine_fingerprint()
    return {"numeric_key": fp["numeric_key"], "numerics": fp["numerics"], "episodes": out}


def child_drift(mode: str, folder: str, tasks: list[str]) -> dict[str, object]:
    """``make``: one expert episode per task, saved; ``replay``: its replay's deviations."""
    import numpy as np

    from libero_data.experts import Expert
    from libero_data.pipeline.resimulate import replay
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    out: dict[str, object] = {}
    for ref in tasks:
        task = get_task(ref)
        path = Path(folder) / f"{ref.replace('/', '_')}.npz"
        with LiberoEnv(task, EnvConfig(cameras=())) as env:
            if mode == "make":
                ep = Expert(env).run(task.init_states()[1], reset_seed=1, seed=11)
                np.savez(path, actions=ep.actions, states=ep.states, success=ep.success)
                continue
            stored = np.load(path)
            result = replay(env, 1, stored["states"], stored["actions"])
            dev = result.deviations
            out[ref] = {
                "frames": len(stored["actions"]),
                "first": result.first,
                "at": {str(f): float(dev[f - 1]) for f in (10, 50, 100, 200, 300, 400) if f <= dev.size},
                "max": result.worst,
                "reached": result.reached,
            }
    return out


# ------------------------------------------------------------------------------------------
# the parent: play the machines, compare


def play(env: dict[str, str], *args: str) -> dict:
    """Run this script's child part as a played machine; its JSON result."""
    run_env = {
        k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")
    }
    run_env.update(env)
    run_env.setdefault("OMP_NUM_THREADS", "1")
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.bench_numerics", "--child", *args],
        cwd=ROOT,
        env=run_env,
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        raise RuntimeError(f"played machine {env} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def controller_part() -> str:
    import numpy as np

    rows = {name: play(env, "controller") for name, env in MACHINES.items() if not name.startswith("pinned,")}
    base = rows["native"]
    lines = [
        "**Controller**, for one state (libero_90/42, init 1, the first substep of the settle; the "
        "controller's inputs hash the same on every machine): largest difference from this machine's "
        "native torques, N·m.",
        "",
        "| played machine | OpenBLAS kernel | inputs | robosuite's OSC | ours (`sim/osc.py`) |",
        "|---|---|---|---:|---:|",
    ]
    for name, r in rows.items():
        theirs = np.abs(np.array(r["robosuite"]) - np.array(base["robosuite"])).max()
        ours = np.abs(np.array(r["ours"]) - np.array(base["ours"])).max()
        same = "same" if r["inputs"] == base["inputs"] else "differ"
        lines.append(f"| {name} | {r['kernel']} | {same} | {theirs:.1e} | {ours:.1e} |")
    return "\n".join(lines)


def episodes_part(tasks: list[str], starts: int) -> str:
    rows = {
        name: play(env, "episodes", "--tasks", *tasks, "--starts", str(starts))
        for name, env in MACHINES.items()
    }
    base = rows["native"]["episodes"]
    n = len(base)
    lines = [
        f"**Episodes**: {n} expert episodes ({len(tasks)} tasks × stored inits 0..{starts - 1}, the expert "
        "report's seeds), actions and states hashed; how many equal this machine's native ones, bit for bit.",
        "",
        "| played machine | numerics | numeric key | equal to native | successes |",
        "|---|---|---|---:|---:|",
    ]
    for name, r in rows.items():
        eps = r["episodes"]
        equal = sum(eps[k] == base[k] for k in base)
        wins = sum(bool(v[0]) for v in eps.values())
        lines.append(f"| {name} | {r['numerics']} | `{r['numeric_key']}` | {equal}/{n} | {wins}/{n} |")
    lines += [
        "",
        f"Tasks: {', '.join(f'`{t}`' for t in tasks)}.",
    ]
    return "\n".join(lines)


def drift_part(tasks: list[str]) -> str:
    import tempfile

    if not libm_uses_fma(cpu_flags()):
        return "**Drift**: not measured (this machine's libm has no FMA variants to take away)."
    with tempfile.TemporaryDirectory() as folder:
        play({}, "drift", "make", folder, "--tasks", *tasks)
        rows = play({"GLIBC_TUNABLES": "glibc.cpu.hwcaps=-FMA"}, "drift", "replay", folder, "--tasks", *tasks)
    lines = [
        "**Drift**: one expert episode per task made here (pinned), replayed from its first state on a played "
        "CPU without FMA (glibc's libm takes its other variants of sin, cos, exp, ..., which MuJoCo and NumPy "
        "call). Largest deviation of a joint or object position (m or rad) from the stored one, by frame.",
        "",
        "| task | frames | departs at frame | frame 50 | frame 100 | frame 200 | frame 300 | frame 400 | largest | replay reaches the goal |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for ref, r in rows.items():
        at = r["at"]
        cells = " | ".join(f"{at[f]:.1e}" if f in at else "–" for f in ("50", "100", "200", "300", "400"))
        lines.append(
            f"| `{ref}` | {r['frames']} | {r['first']} | {cells} | {r['max']:.1e} | {'yes' if r['reached'] else 'no'} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--part", choices=["controller", "episodes", "drift", "all"], default="all")
    parser.add_argument("--tasks", nargs="+", default=None, help="Tasks of the episodes part.")
    parser.add_argument("--starts", type=int, default=3, help="Stored inits per task (episodes part).")
    parser.add_argument("--results", type=Path, help="RESULTS.md to update.")
    parser.add_argument("--child", nargs="*", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child is not None:
        what = args.child[0]
        if what == "controller":
            result = child_controller()
        elif what == "episodes":
            result = child_episodes(args.tasks or DEFAULT_TASKS, args.starts)
        else:
            result = child_drift(args.child[1], args.child[2], args.tasks or DRIFT_TASKS)
        print(json.dumps(result))
        return
    parts = []
    if args.part in ("controller", "all"):
        parts.append(controller_part())
    if args.part in ("episodes", "all"):
        parts.append(episodes_part(args.tasks or DEFAULT_TASKS, args.starts))
    if args.part in ("drift", "all"):
        parts.append(drift_part(DRIFT_TASKS))
    command = "python -m benchmarks.bench_numerics" + (f" --part {args.part}" if args.part != "all" else "")
    text = (
        f"Run: `{command}` (each played machine is a subprocess; see the script's docstring).\n\n"
        + "\n\n".join(parts)
    )
    print(text)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(args.results, "Same bits on other machines", text)


if __name__ == "__main__":
    main()
