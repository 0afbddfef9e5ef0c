"""A scripted expert that demonstrates any LIBERO task from its goal predicates.

Only :mod:`libero_data.sim` touches the simulator; the expert reads privileged state through
:class:`~libero_data.experts.scene.SceneView` and acts with 7-D OSC delta actions.
"""

from libero_data.experts.expert import Episode, Expert, ExpertConfig
from libero_data.experts.planner import Step, plan

__all__ = ["Episode", "Expert", "ExpertConfig", "Step", "plan"]
