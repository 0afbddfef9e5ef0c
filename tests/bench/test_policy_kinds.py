"""Every kind of policy is found through one registry, asked in its order; a reference no kind
opens is one sentence."""

from __future__ import annotations

from pathlib import Path

import pytest

from libero_bench.rollouts.policy_kinds import POLICY_KINDS, policy_kinds, policy_source
from libero_data.errors import LiberoDataError


def test_every_kind_is_registered_and_asked_in_order() -> None:
    kinds = policy_kinds()
    assert [k.name for k in kinds][:3] == ["server", "run", "lerobot"][: len(kinds)] or kinds[
        -1
    ].name == "lerobot"
    assert {k.name for k in kinds} == set(POLICY_KINDS.names()) >= {"server", "run", "lerobot"}
    assert kinds[-1].name == "lerobot"  # it takes any folder: asked last
    assert [k.order for k in kinds] == sorted(k.order for k in kinds)
    # A server's address is a server's; a folder is never claimed by the server kind.
    by_name = {k.name: k for k in kinds}
    assert by_name["server"].claims("ws://host:8000") and not by_name["server"].claims("/some/folder")
    assert not by_name["run"].claims("ws://host:8000") and not by_name["lerobot"].claims("ws://host:8000")


def test_a_folder_that_is_no_policy_is_one_sentence(tmp_path: Path) -> None:
    with pytest.raises(LiberoDataError, match="is not a LeRobot policy folder") as refused:
        policy_source(str(tmp_path))
    assert "\n" not in str(refused.value)
