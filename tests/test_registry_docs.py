"""README and docs/ show what the registries hold: their blocks are made from the registries
(``python -m libero_bench.registry_docs``), and the check names the entry a block misses."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from libero_bench import registry_docs


def test_every_block_is_what_its_registry_makes() -> None:
    found = registry_docs.problems()
    assert not found, "run `python -m libero_bench.registry_docs`:\n" + "\n".join(found)


def test_each_registrys_entries_are_in_its_block() -> None:
    for name, block in registry_docs.BLOCKS.items():
        text = block.text()
        assert block.names(), name
        assert all(entry in text for entry in block.names()), name


def test_a_new_entry_is_named_where_a_block_misses_it(monkeypatch: pytest.MonkeyPatch) -> None:
    # A kind added as ARCHITECTURE.md says: the blocks that list kinds name it as missing, and
    # rewriting them puts it in.
    kinds = registry_docs._kinds()
    extra = SimpleNamespace(name="gripper_noise", summary="noise on the gripper's width", rewrites_task=False)
    monkeypatch.setattr(registry_docs, "_kinds", lambda: [*kinds, extra])
    found = registry_docs.problems()
    assert any("block 'kind-names': misses gripper_noise" in line for line in found), found
    assert any("block 'kinds': misses gripper_noise" in line for line in found), found
    readme = (registry_docs.ROOT / "README.md").read_text()
    rewritten = registry_docs.rewrite(readme)
    assert f"{registry_docs.number(len(kinds) + 1)} kinds (" in rewritten and "gripper_noise" in rewritten
    assert registry_docs.rewrite(rewritten) == rewritten


def test_an_unknown_block_is_named(tmp_path) -> None:
    (tmp_path / "README.md").write_text("<!-- registry:colours -->red<!-- /registry:colours -->\n")
    found = registry_docs.problems(tmp_path)
    assert found[0].startswith("README.md, block 'colours': no registry makes it")
    with pytest.raises(KeyError, match="unknown registry block 'colours'"):
        registry_docs.rewrite((tmp_path / "README.md").read_text())
