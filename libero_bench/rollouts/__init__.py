"""Evaluation rollouts with one policy and many environments.

The policy runs once, in the driver process, on the device asked for; the environments (physics
and rendering, the CPU work) live in worker processes or Ray actors
(:class:`libero_data.runtime.actors.ActorPool`). Each control step, the observations of every
environment waiting for an action go through one batched forward pass, and an environment whose
episode ends takes its next start while the others go on:

- :mod:`~libero_bench.rollouts.episodes`: the worker side, environments that start, step and
  store rollouts (a LeRobot shard, an MCAP log and a Rerun recording each);
- :mod:`~libero_bench.rollouts.actors`: what acts for a batch of environments (the
  :class:`~libero_bench.rollouts.actors.BatchActor` interface, per-environment action-chunk
  queues, libero-bench's own policies);
- :mod:`~libero_bench.rollouts.lerobot_actor`: LeRobot's policies, batched, with their processors;
- :mod:`~libero_bench.rollouts.loop`: the driver's loop over starts;
- :mod:`~libero_bench.rollouts.wire`, :mod:`~libero_bench.rollouts.remote`,
  :mod:`~libero_bench.rollouts.server`: policy servers over openpi's websocket protocol.

Starts are a function of the job only (task, kind of start, rollout index), never of the batch
size or of the order in which episodes end.
"""
