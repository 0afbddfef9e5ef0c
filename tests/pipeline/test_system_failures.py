"""A full disk, a folder without permission, a read-only file system: one sentence that says what
to do, the finished work kept, and the same command continues. The failures are injected at the
writer (OSError with the system's errno), which any machine can do; a size-limited tmpfs gives
the same OSError where one may be mounted."""

from __future__ import annotations

import errno
import shutil
from pathlib import Path
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from libero_data.cli import app
from libero_data.cli.common import system_failure, user_errors
from libero_data.pipeline.publish import STAMP
from tests.pipeline.conftest import TINY, data_table

OUTPUTS = ("data", "videos", "meta", "mcap", "README.md")


@pytest.mark.parametrize(
    ("error", "expected"),
    [
        (
            OSError(errno.ENOSPC, "No space left on device", "/data/out/x.parquet"),
            "no space left on the device",
        ),
        (
            OSError("Error writing bytes to file. Detail: [errno 28] No space left on device"),
            "free some space",
        ),
        (OSError(errno.EDQUOT, "Disk quota exceeded", "/data/out"), "quota is exceeded"),
        (PermissionError(errno.EACCES, "Permission denied", "/data/out"), "permission denied for /data/out"),
        (
            OSError(errno.EROFS, "Read-only file system", "/data/out"),
            "/data/out is on a read-only file system",
        ),
    ],
)
def test_a_system_failure_is_one_sentence_that_says_what_to_do(error: OSError, expected: str) -> None:
    def command() -> None:
        raise error

    demo = typer.Typer()
    demo.command()(user_errors(command))
    result = CliRunner().invoke(demo, [])
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines() == [f"error: {system_failure(error)}"]
    assert expected in result.stderr


def test_an_error_that_names_no_file_names_the_commands_output() -> None:
    wrapped = OSError("Error writing bytes to file. Detail: [errno 28] No space left on device")  # pyarrow's
    sentence = system_failure(wrapped, where="/data/out")
    assert sentence is not None and sentence.startswith(
        "no space left on the device while writing /data/out;"
    )

    def command(out: str) -> None:
        raise wrapped

    demo = typer.Typer()
    demo.command()(user_errors(command))
    result = CliRunner().invoke(demo, ["/data/out"])
    assert result.stderr.strip() == f"error: {sentence}"


def test_other_os_errors_stay_bugs_with_their_traceback() -> None:
    assert system_failure(OSError(errno.ENOENT, "No such file or directory", "/x")) is None
    assert system_failure(OSError("something else")) is None


def _unpublished_copy(tiny_dataset: Path, out: Path) -> Path:
    """The tiny dataset's finished episodes (work files kept) with nothing published yet: a
    generate run that stopped before writing its dataset, continued without simulating."""
    shutil.copytree(tiny_dataset, out)
    for name in OUTPUTS:
        path = out / name
        shutil.rmtree(path) if path.is_dir() else path.unlink()
    return out


@pytest.mark.sim
def test_a_full_disk_while_publishing_keeps_the_episodes_and_the_same_command_continues(
    tiny_dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from libero_data.pipeline import snapshot

    out = _unpublished_copy(tiny_dataset, tmp_path / "dataset")
    build = snapshot.build_snapshot

    def disk_fills(shards: Any, target: Path, **kwargs: Any) -> None:
        build(shards, target, **kwargs)  # the snapshot is half-published when the disk is full
        raise OSError(errno.ENOSPC, "No space left on device", str(target / "data" / "chunk-000"))

    monkeypatch.setattr(snapshot, "build_snapshot", disk_fills)
    args = ["generate", *TINY, "--out", str(out)]
    failed = CliRunner().invoke(app, args)
    assert failed.exit_code == 2, failed.output
    last = failed.stderr.strip().splitlines()[-1]  # after the progress bar of the work done
    assert (
        last.startswith("error: no space left on the device while writing ")
        and "run the same command" in last
    )
    assert "Traceback" not in failed.output
    assert not (out / "meta").exists()  # nothing half-published
    monkeypatch.setattr(snapshot, "build_snapshot", build)
    again = CliRunner().invoke(app, args)
    assert again.exit_code == 0, again.output
    assert data_table(out).equals(data_table(tiny_dataset))
    # finished: no work folder and no publishing stamps
    assert not (out / ".libero-data").exists()
    assert not list(out.glob(f"*/{STAMP}")) and not list(out.rglob(".*"))


@pytest.mark.sim
def test_generate_into_a_folder_being_written_is_refused_with_its_sentence_only(
    tiny_dataset: Path, tmp_path: Path
) -> None:
    from libero_data.runtime.folder import DATASET_WORK, WorkFolder

    out = _unpublished_copy(tiny_dataset, tmp_path / "busy")
    with WorkFolder(out / DATASET_WORK, "dataset").locked(owner=out):
        result = CliRunner().invoke(app, ["generate", *TINY, "--out", str(out)])
    assert result.exit_code == 2
    assert result.stdout == ""
    assert result.stderr.strip().splitlines() == [f"error: another process is writing the dataset in {out}"]
