"""Reinforcement learning on LIBERO tasks: a gymnasium vector environment stepped in action chunks.

:class:`~libero_bench.rl.vector.LiberoVectorEnv` (registered as ``Libero-v0`` by
:mod:`libero_bench.rl.ids`) runs its environments in worker processes (:mod:`libero_bench.rl.host`)
and leaves the policy, batched, to the caller. docs/rl.md says what it observes, rewards and resets.
"""
