"""Policy servers on loopback: ``libero-bench serve`` serves a policy over openpi's websocket
protocol, ``libero-bench eval --server`` evaluates it with the outputs of a local evaluation, and a
server that dies mid-evaluation is one sentence and a folder that resumes."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import datasets
import numpy as np
import pytest
from lerobot_policies import save_policy

from libero_bench.evaluation.policy_eval import EvalRequest, evaluate_policy
from libero_bench.rollouts.loop import RolloutResources
from libero_data.errors import PolicyServerError

pytestmark = pytest.mark.sim

TASK = "libero_object/0"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def served(policy: Path, port: int) -> Iterator[subprocess.Popen[str]]:
    """``libero-bench serve`` on loopback, until the block ends (or the test kills it)."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    command = [
        sys.executable,
        "-m",
        "libero_bench.cli",
        "serve",
        str(policy),
        "--port",
        str(port),
        "--device",
        "cpu",
    ]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=1):
                    break
            except OSError:
                if process.poll() is not None:
                    raise AssertionError(
                        f"the server exited: {process.stderr.read() if process.stderr else ''}"
                    ) from None
                if time.monotonic() > deadline:
                    raise AssertionError("the server did not start listening within 120 s") from None
                time.sleep(0.5)
        yield process
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()


def actions(folder: Path) -> dict[int, np.ndarray]:
    frames = datasets.load_dataset(str(folder / "rollouts"), split="train")
    by_episode: dict[int, list[list[float]]] = {}
    for episode, action in zip(frames["episode_index"], frames["action"], strict=True):
        by_episode.setdefault(int(episode), []).append(action)
    return {k: np.asarray(v) for k, v in by_episode.items()}


def outcomes(folder: Path) -> list[tuple[str, bool, int, int]]:
    rollouts = json.loads((folder / "results.json").read_text())["rollouts"]
    return sorted((r["key"], r["success"], r["steps"], r["env_seed"]) for r in rollouts)


def test_a_served_policy_is_evaluated_as_a_local_one_and_a_dying_server_leaves_a_folder_that_resumes(
    tmp_path: Path,
) -> None:
    policy = save_policy("act", tmp_path / "act")
    port = free_port()
    url = f"ws://127.0.0.1:{port}"
    request: dict[str, Any] = dict(tasks=(TASK,), stored=1, heldout=1, max_steps=4, settle=2)
    local = evaluate_policy(
        EvalRequest(str(policy), **request), tmp_path / "local", execution=RolloutResources(batch_size=2)
    )
    with served(policy, port):
        remote = evaluate_policy(
            EvalRequest(url, **request), tmp_path / "remote", execution=RolloutResources(batch_size=2)
        )
    # The same starts, outcomes and actions as the local evaluation (a stored and a held-out start).
    assert outcomes(tmp_path / "remote") == outcomes(tmp_path / "local")
    assert remote["all"] == local["all"] and remote["policy_type"] == "act"
    here, there = actions(tmp_path / "local"), actions(tmp_path / "remote")
    assert sorted(here) == sorted(there) == [0, 1]
    for episode in here:
        np.testing.assert_allclose(there[episode], here[episode], atol=1e-6)
    session = json.loads((tmp_path / "remote" / "results.json").read_text())["sessions"][0]
    assert session["actor"] == "server" and session["batch_size"] == 2 and session["url"] == url
    # A finished folder holds no work files; the same evaluation again only rewrites the report.
    assert not list((tmp_path / "local").rglob(".*"))
    again = evaluate_policy(
        EvalRequest(str(policy), **request), tmp_path / "local", execution=RolloutResources(batch_size=2)
    )
    assert again["all"] == local["all"]
    # 4 steps solve nothing: every rollout is a failure cut by the step limit, and the report says so.
    assert local["max_steps"] == 4 and local["all"]["cut"] == 2 and local["tasks"][0]["cut"] == 2
    assert "| **all tasks** |" in (tmp_path / "local" / "report.md").read_text()
    assert "cut by the step limit |" in (tmp_path / "local" / "report.md").read_text()
    assert len(json.loads((tmp_path / "local" / "results.json").read_text())["sessions"]) == 1

    # The server dies after the first rollout: one sentence naming it; the folder resumes.
    dying = tmp_path / "dying"
    more = EvalRequest(url, tasks=(TASK,), stored=3, heldout=0, max_steps=3, settle=2)
    with served(policy, port) as server:

        def kill_after_first(_result: object) -> None:
            server.kill()
            server.wait(timeout=30)

        with pytest.raises(PolicyServerError, match=rf"policy server at {url}") as died:
            evaluate_policy(more, dying, execution=RolloutResources(batch_size=1), on_result=kill_after_first)
    assert "\n" not in str(died.value)
    assert len(json.loads((dying / "results.json").read_text())["rollouts"]) == 1
    with served(policy, port):
        evaluate_policy(more, dying, execution=RolloutResources(batch_size=1))
    saved = json.loads((dying / "results.json").read_text())
    assert saved["complete"] and len(saved["rollouts"]) == 3
    assert [s["rollouts"] for s in saved["sessions"]] == [1, 2]  # the finished one was not run again


def test_an_unreachable_server_is_one_sentence_from_the_command_line(tmp_path: Path) -> None:
    url = f"ws://127.0.0.1:{free_port()}"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "libero_bench.cli",
            "eval",
            "--server",
            url,
            "-t",
            TASK,
            "-o",
            str(tmp_path / "x"),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 2, result.stderr[-2000:]
    (line,) = result.stderr.strip().splitlines()
    assert line.startswith(f"error: cannot reach the policy server at {url}: ")
    assert not (tmp_path / "x").exists()  # refused before anything was written
