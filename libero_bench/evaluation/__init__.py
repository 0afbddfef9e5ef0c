"""Evaluating a policy in simulation: the rollout evaluator, `libero-bench eval`, its report, LeRobot policies."""
