"""``render_quality="fast"``: our own offscreen renderer drawing simplified visual meshes.

One job per module: ``renderer`` (MuJoCo's renderer in a GL context of its own), ``images``
(each camera's renderer, and the full-quality reference), ``simplify`` (which meshes are
simplified, to what error), ``meshes`` (simplification and its cache; ``meshopt``,
meshoptimizer's C library), ``cameras`` (mounted cameras and the meshes they carry),
``distant`` (coarser meshes for what the fixed cameras see from afar), ``texture_size``
(textures capped to the image's scale), ``near`` (detailed copies near the wrist camera),
``culling``, ``hidden`` (occlusion queries) and ``sky`` (what a frame may leave out).

None of it decides an episode: the expert's code hash leaves this folder out
(:data:`libero_data.provenance.NOT_EPISODE_CODE`).
"""
