"""A LeRobot policy: the ``pretrained_model/`` folder ``lerobot-train`` writes (read now, loaded
when rollouts start), its inputs served from its declared features."""

from __future__ import annotations

from pathlib import Path

from libero_bench.rollouts.policy_kinds import (
    LEROBOT,
    PolicyKind,
    PolicySource,
    SourceOptions,
    TrainingStarts,
    is_server,
    register_kind,
)


def lerobot_source(policy: str, options: SourceOptions) -> PolicySource:
    """The source of the LeRobot policy folder ``policy``."""
    from libero_bench.rollouts.lerobot_actor import LeRobotActor
    from libero_bench.rollouts.lerobot_inputs import inputs_from_features, lerobot_config

    folder = Path(policy).resolve()
    config = lerobot_config(folder)
    inputs = inputs_from_features(config.input_features, f"the {config.type} policy at {folder}")
    cameras = {camera for camera, _h, _w in inputs.cameras.values()}
    return PolicySource(
        str(folder),
        LEROBOT,
        config.type,
        inputs.render_size,
        {k: list(v) for k, v in {**inputs.cameras, **inputs.states}.items()},
        lambda device, _view: LeRobotActor(folder, device),
        reads=(*sorted(cameras), *(key for key, _w in inputs.states.values())),
        chunk_size=int(getattr(config, "n_action_steps", None) or 1),
        starts=lambda: lerobot_training_starts(folder),
    )


def lerobot_training_starts(policy: Path) -> TrainingStarts:
    """From the dataset ``train_config.json`` names, where it is a libero-data dataset on disk."""
    from libero_bench.data.dataset import DemoDataset
    from libero_data.errors import LiberoDataError
    from libero_data.runtime.files import read_json

    path = policy / "train_config.json"
    if not path.is_file():
        return None, {}
    config = read_json(path)
    root = ((config.get("dataset") if isinstance(config, dict) else None) or {}).get("root")
    if not root or not Path(root).is_dir():
        return root, {}
    try:
        data = DemoDataset(root)
    except LiberoDataError:
        return root, {}
    found = {}
    for task in data.tasks:
        starts = data.training_starts(task)
        if starts is not None:
            found[task.name] = starts
    return root, found


# Last: any folder (its config.json tells, or says why it is no LeRobot policy).
register_kind(PolicyKind(LEROBOT, 100, lambda ref: not is_server(ref), lerobot_source))
