"""LIBERO's real scenes as data, and new tasks written in them: the catalogue of each scene's
objects, fixtures and regions (``catalogue``, built in the simulator by
``libero_data.procedural.catalogue_build``), behaviour templates (``templates``) and the sampler
that fills a template in a scene and writes its BDDL (``sampler``). Below the simulator: the
robustness kinds that rewrite tasks use them, and so does procedural generation."""
