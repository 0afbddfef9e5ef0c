"""Training presets are validated data that survive a JSON round trip."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from libero_bench.train.presets import PAPER, PRESETS, SMOKE, TrainPreset, get_preset


def test_paper_preset_matches_the_libero_protocol() -> None:
    p = get_preset("paper")
    assert p is PAPER
    assert (p.epochs, p.batch_size, p.window) == (50, 32, 10)
    assert (p.optimizer, p.lr, p.lr_min, p.weight_decay, p.scheduler) == ("adamw", 1e-4, 1e-5, 1e-4, "cosine")
    assert (p.eval_every, p.eval_rollouts, p.eval_max_steps, p.keep_best) == (5, 20, 600, True)
    assert p.eval_epochs() == [0, 5, 10, 15, 20, 25, 30, 35, 40, 45, 50]
    assert p.image_size == 128 and p.policy_size == "paper"


def test_smoke_preset_is_small() -> None:
    s = get_preset("smoke")
    assert s is SMOKE
    assert s.epochs <= 2 and s.eval_rollouts <= 2 and s.eval_every == 1
    assert isinstance(s.eval_max_steps, int) and s.eval_max_steps <= 60
    assert s.policy_size == "smoke" and s.algo_size == "smoke"
    assert PRESETS.names() == ["paper", "quick", "smoke"]


@pytest.mark.parametrize("name", ["paper", "quick", "smoke"])
def test_json_round_trip(name: str) -> None:
    preset = get_preset(name)
    text = json.dumps(preset.to_dict())
    assert TrainPreset.from_dict(json.loads(text)) == preset


def test_invalid_fields_are_named() -> None:
    with pytest.raises(ValueError, match=r"TrainPreset\.epochs"):
        PAPER.replace(epochs=0)
    with pytest.raises(ValueError, match=r"TrainPreset\.lr_min"):
        PAPER.replace(lr_min=1e-3)
    with pytest.raises(ValueError, match="no field"):
        TrainPreset.from_dict({"name": "x", "epoch": 3})


def test_light_modules_do_not_import_torch() -> None:
    code = (
        "import sys, libero_bench.runs.metrics, libero_bench.train.presets, libero_bench.data.language;"
        "print('torch' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=os.environ
    )
    assert out.stdout.strip() == "False"


def test_augment_overrides_the_policy_default_and_runs_made_before_it_resume(tiny_dataset, tmp_path) -> None:
    from libero_bench.train.trainer import RunOptions, RunRequest, Trainer, plan_run
    from libero_data.errors import SettingsChanged

    quick = get_preset("quick")
    assert quick.augment is None and quick.with_overrides(["augment=true"]).augment is True
    with pytest.raises(ValueError, match=r"TrainPreset\.augment"):
        quick.with_overrides(["augment=3"])
    default = plan_run(RunRequest(data=tiny_dataset, algo="seql", policy="resnet_t", preset=quick))
    assert default.policy_config["augment"] is False  # the policy size's own default
    assert default.config(RunOptions(), tmp_path / "run")["preset"]["augment"] is None
    # A run made before the field existed: its config.json has no augment; it resumes as None.
    Trainer(default, tmp_path / "run").prepare()
    config_path = tmp_path / "run" / "config.json"
    old = json.loads(config_path.read_text())
    del old["preset"]["augment"]
    config_path.write_text(json.dumps(old))
    Trainer(default, tmp_path / "run").prepare()
    on = plan_run(
        RunRequest(
            data=tiny_dataset, algo="seql", policy="resnet_t", preset=quick.with_overrides(["augment=true"])
        )
    )
    assert (
        on.policy_config["augment"] is True
        and on.config(RunOptions(), tmp_path / "run")["preset"]["augment"] is True
    )
    with pytest.raises(SettingsChanged):  # but not as augmented
        Trainer(on, tmp_path / "run").prepare()


def test_an_algorithm_setting_is_part_of_the_run(tiny_dataset, tmp_path) -> None:
    from libero_bench.train.trainer import RunRequest, Trainer, plan_run
    from libero_data.errors import SettingsChanged

    smoke = get_preset("smoke")
    weaker = plan_run(
        RunRequest(
            data=tiny_dataset,
            algo="ewc",
            policy="resnet_t",
            preset=smoke,
            algo_settings=("penalty_weight=5000",),
        )
    )
    assert weaker.algo_config["penalty_weight"] == 5000
    Trainer(weaker, tmp_path / "run").prepare()
    default = plan_run(RunRequest(data=tiny_dataset, algo="ewc", policy="resnet_t", preset=smoke))
    assert default.algo_config["penalty_weight"] == 5e4
    with pytest.raises(SettingsChanged):  # a run is resumed with its own settings only
        Trainer(default, tmp_path / "run").prepare()
